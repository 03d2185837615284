// plan-windows: the planner's distance interval I_Y per stereo pair (Krotkov & Hebert sec. 3.3)
// from the vehicle's poses, speed, stopping distance and stereo delay, as the requests CSV that
// `stereo-batch --requests` reads. docs/terrain-map.md#the-planner.
#include <filesystem>
#include <optional>
#include <string>

#include "apps/mapping_cli.h"
#include "calib/stereo_rig_io.h"
#include "calib/vehicle.h"
#include "io/atomic_file.h"
#include "io/json_io.h"
#include "mapping/frame_poses.h"
#include "mapping/window_planner.h"
#include "util/check.h"
#include "util/cli.h"
#include "util/errors.h"
#include "util/log.h"
#include "util/run_main.h"
#include "util/summary.h"

namespace fs = std::filesystem;
using namespace lunarnav;

int main(int argc, char** argv) {
  CLI::App app{
      "Plans the distance interval I_Y = [Y_min, Y_max] stereo must cover for each pair (Krotkov & Hebert\n"
      "sec. 3.3): from the vehicle's speed (its poses), its stopping distance (sec. 3.1, the vehicle file),\n"
      "the stereo delay and the ground the previous request covered. Writes OUT_DIR/requests.csv (for\n"
      "stereo-batch --requests), plan.csv (every term) and summary.json.\n"
      "Exit codes: 0 ok, 1 internal error, 2 usage, 3 bad input."};
  mapping::WindowPlannerOptions opt;  // defaults live in the library
  fs::path poses, trajectory, frame_times, vehicle_path, map_dir, output_dir;
  std::string gravity = "earth";
  bool quiet = false;
  app.add_option("--poses", poses, "poses per pair (simulate stereo's truth/poses.csv)");
  app.add_option("--trajectory", trajectory,
                 "posfilter's trajectory.csv, TUM, a KITTI pose file or oxts/ (with --rig), at --frame-times");
  app.add_option("--frame-times", frame_times,
                 "stem,t_s per pair, or KITTI's times.txt or timestamps.txt (with --trajectory)");
  fs::path rig_path;
  app.add_option("--rig", rig_path, "rig file: its mast places a trajectory of camera poses (KITTI's) on the vehicle");
  app.add_option("--vehicle", vehicle_path, "vehicle file (speed limits, braking, wheels; default: the paper's Ratler)");
  apps::AddPlannerOptions(&app, &opt, &gravity);
  app.add_option("--map", map_dir,
                 "terrain-map output so far: each request starts from the far edge of what the map holds in the "
                 "vehicle's corridor ahead, not from the previous request (the closed loop)");
  app.add_option("-o,--output", output_dir, "output directory (created)")->required();
  util::AddCommonFlags(&app, &quiet);
  if (const auto exit_code = util::ParseCommandLine(&app, argc, argv, quiet)) return *exit_code;

  return util::RunMain([&] {
    opt.gravity = calib::GravityFromString(gravity);
    opt.Validate();
    LN_CHECK_ARG(poses.empty() != trajectory.empty()) << "give either --poses or --trajectory with --frame-times";
    LN_CHECK_ARG(trajectory.empty() || !frame_times.empty()) << "--trajectory needs --frame-times";
    const calib::VehicleSpec vehicle = vehicle_path.empty() ? calib::VehicleSpec() : calib::ReadVehicleSpec(vehicle_path);
    std::vector<mapping::FramePose> frames =
        poses.empty()
            ? mapping::InterpolateTrajectory(
                  trajectory, mapping::ReadFrameTimes(frame_times),
                  {frame_times,
                   rig_path.empty() ? std::nullopt : std::optional(calib::ReadStereoRig(rig_path).VehicleFromLeft())})
            : mapping::ReadPosesCsv(poses);
    std::optional<mapping::MapLayers> map;
    if (!map_dir.empty()) map = mapping::ReadMapElevation(map_dir);
    const std::string source = poses.empty() ? trajectory.string() : poses.string();
    std::vector<mapping::PlannedWindow> plan;
    try {
      plan = mapping::PlanWindows(frames, vehicle, opt, map ? &*map : nullptr);
    } catch (const InputError& e) {  // about a pose: named by the file it came from
      throw InputError(source + ": " + e.what());
    }
    io::CreateOutputDirectory(output_dir);
    io::WriteFileAtomic(output_dir / "requests.csv", mapping::RequestsCsv(plan));
    io::WriteFileAtomic(output_dir / "plan.csv", mapping::PlanCsv(plan));
    nlohmann::json j = util::SummaryHead("plan-windows", util::CommandLineJson(argc, argv));
    j["inputs"] = {{"poses", poses.string()}, {"trajectory", trajectory.string()},
                   {"frame_times", frame_times.string()}, {"vehicle", vehicle_path.string()},
                   {"map", map_dir.string()}};
    j["vehicle"] = calib::VehicleSpecToJson(vehicle);
    j["options"] = opt.ToJson();
    j["counts"] = {{"pairs", plan.size()}};
    j["last"] = {{"y_min_m", plan.back().y_min_m}, {"y_max_m", plan.back().y_max_m}};
    io::WriteJsonAtomic(output_dir / "summary.json", j);
    LN_LOG(Info) << "plan-windows: " << plan.size() << " pairs; last request [" << plan.back().y_min_m << ", "
                 << plan.back().y_max_m << "] m; " << (output_dir / "requests.csv").string();
    return kExitOk;
  });
}
