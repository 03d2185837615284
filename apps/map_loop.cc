// map-loop: the closed loop of Krotkov & Hebert sec. 3.3 over a recorded run, pair by pair:
// plan the pair's interval I_Y from the past poses and the map so far, match the pair in that
// window, add its points to the map, plan the next. docs/terrain-map.md, "The loop".
#include <filesystem>
#include <string>

#include "apps/mapping_cli.h"
#include "apps/matcher_cli.h"
#include "calib/stereo_rig_io.h"
#include "calib/vehicle.h"
#include "calib/window_selection.h"
#include "io/image_io.h"
#include "mapping/map_loop.h"
#include "util/check.h"
#include "util/cli.h"
#include "util/errors.h"
#include "util/log.h"
#include "util/parse.h"
#include "util/run_main.h"

namespace fs = std::filesystem;
using namespace lunarnav;

int main(int argc, char** argv) {
  CLI::App app{
      "Runs the mapping loop of Krotkov & Hebert sec. 3.3 over the rectified pairs of RECT_DIR (left/,\n"
      "right/), in time order: the planner's interval I_Y for each pair from the poses up to it and the map\n"
      "of the pairs before it (a blank or failed pair's ground is asked for again), stereo in that window\n"
      "only, the pair's points into the terrain map. Writes OUT_DIR/stereo/ (stereo-batch's outputs),\n"
      "map/ (terrain-map's), requests.csv, plan.csv, loop.csv (per pair) and summary.json.\n"
      "Exit codes: 0 ok, 1 internal error, 2 usage, 3 bad input, 4 some pairs failed."};
  mapping::MapLoopOptions opt;  // defaults live in the library
  fs::path rect_dir, output_dir, rig_path, vehicle_path;
  std::string z_range, gravity = "earth";
  bool quiet = false, no_preview = false;
  app.add_option("RECT_DIR", rect_dir, "rectified pairs: left/ and right/ (rectify's output)")->required();
  app.add_option("-o,--output", output_dir, "output directory (created)")->required();
  app.add_option("--rig", rig_path, "rectified rig file (rectify's rig.json)")->required();
  app.add_option("--poses", opt.map.poses_csv, "poses per pair: stem,t_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg "
                                               "(simulate stereo's truth/poses.csv)");
  app.add_option(
      "--trajectory", opt.map.trajectory,
      "posfilter's trajectory.csv, a TUM file, a KITTI pose file or KITTI oxts/, interpolated at --frame-times");
  app.add_option("--frame-times", opt.map.frame_times,
                 "stem,t_s per pair, or KITTI's times.txt or timestamps.txt (for --trajectory)");
  app.add_option("--vehicle", vehicle_path,
                 "vehicle file: width, wheels, braking (the planner), obstacle height and slope limit (the map) "
                 "(default: the paper's Ratler)");
  apps::AddPlannerOptions(&app, &opt.planner, &gravity);
  app.add_option("--z-range", z_range, "heights ZMIN:ZMAX metres of the objects searched in each window")
      ->default_str("-0.5:1");
  apps::MatcherCommandLine matcher_cl;
  apps::AddMatcherOptions(&app, &matcher_cl, &opt.stereo.frame_check);
  app.add_option("--sigma-d", opt.map.sigma_d_px, "disparity error of the rig's error model (the points' weights), px")
      ->capture_default_str();
  apps::AddFusionOptions(&app, &opt.map.map);
  std::string align = "auto";
  mapping::GroundAlignmentOptions align_options;
  apps::AddAlignmentOptions(&app, &align, &align_options);
  app.add_flag("--open-loop", opt.open_loop,
               "plan from the past poses only, not from the map (each request starts at the previous one's far "
               "edge): the open loop, for comparison");
  app.add_flag("--no-preview", no_preview, "do not write map/preview.png");
  app.add_flag("--resume", opt.resume,
               "continue the loop in OUT_DIR: the pairs planned keep their requests, complete outputs are kept");
  app.add_option("-j,--threads", opt.stereo.num_threads, "threads matching a pair (0 = all cores)")
      ->capture_default_str();
  long long max_pixels = io::kDefaultMaxImagePixels;
  util::AddMaxPixelsFlag(&app, &max_pixels);
  util::AddCommonFlags(&app, &quiet);
  if (const auto exit_code = util::ParseCommandLine(&app, argc, argv, quiet)) return *exit_code;

  return util::RunMain([&] {
    io::SetMaxImagePixels(max_pixels);
    LN_CHECK_ARG(opt.map.poses_csv.empty() != opt.map.trajectory.empty())
        << "give either --poses or --trajectory with --frame-times";
    LN_CHECK_ARG(opt.map.trajectory.empty() || !opt.map.frame_times.empty()) << "--trajectory needs --frame-times";
    opt.planner.gravity = calib::GravityFromString(gravity);
    if (!vehicle_path.empty()) opt.vehicle = calib::ReadVehicleSpec(vehicle_path);
    apps::ApplyVehicleLimits(opt.vehicle, &opt.map.map);
    opt.stereo.matcher = apps::MatcherFromCommandLine(app, matcher_cl);
    apps::ApplyMapPipelineDefaults(app, &opt.stereo.matcher);
    apps::ApplyVerticalAlignment(app, matcher_cl, /*map_pipeline=*/true, &opt.stereo);
    opt.stereo.rig = calib::ReadStereoRig(rig_path);
    opt.stereo.rig_source = rig_path.string();
    LN_CHECK_ARG(opt.stereo.rig->rectified) << rig_path.string() << ": not a rectified rig (run rectify first)";
    calib::RegionOfInterest region;  // the paper's heights unless --z-range
    if (!z_range.empty()) std::tie(region.z_min_m, region.z_max_m) = util::ParseDoublePair(z_range, ':', "--z-range");
    opt.stereo.requests_region = region;
    // The rig's ground window gives each request its per-row bands and guards (the quality
    // preset's semi-global search; docs/stereo-batch.md).
    calib::GroundWindowOptions ground;
    ground.z_min_m = region.z_min_m;
    ground.z_max_m = region.z_max_m;
    stereo::CheckRigAgainstPairs(*opt.stereo.rig, opt.stereo.rig_source, rect_dir);
    opt.stereo.ground =
        calib::SelectGroundWindow(*opt.stereo.rig, opt.stereo.matcher.reference, ground, opt.stereo.window_selection);
    opt.map.rig = rig_path;  // the points' errors from the rig's geometry
    opt.map.reference = opt.stereo.matcher.reference;
    opt.map.align = apps::ResolveAlignment(align, align_options, opt.map.trajectory);
    opt.map.write_preview = !no_preview;
    opt.map.num_threads = opt.stereo.num_threads;
    opt.show_progress = !quiet;
    const mapping::MapLoopSummary s = mapping::RunMapLoop(opt, rect_dir, output_dir, util::CommandLineJson(argc, argv));
    LN_LOG(Info) << "map-loop: " << s.BriefReport() << "; outputs in " << output_dir.string();
    return s.pairs_failed > 0 ? kExitBatchPartial : kExitOk;
  });
}
