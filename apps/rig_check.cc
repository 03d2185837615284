// rig-check: the design calculation of Krotkov & Hebert sec. 3.1 for a rig on a vehicle.
// docs/rig-check.md describes every option and output.
#include <filesystem>
#include <iostream>
#include <map>
#include <string>

#include "calib/rig_check.h"
#include "calib/stereo_rig_io.h"
#include "calib/vehicle.h"
#include "io/json_io.h"
#include "util/cli.h"
#include "util/errors.h"
#include "util/log.h"
#include "util/run_main.h"
#include "util/summary.h"

namespace fs = std::filesystem;
using namespace lunarnav;

int main(int argc, char** argv) {
  CLI::App app{
      "Checks a stereo rig on a vehicle against the imaging requirements of Krotkov & Hebert\n"
      "sec. 3.1: lookahead (stopping distance), camera height over the wheels, width of the\n"
      "field of view, resolution. Prints the table on stdout.\n"
      "Exit codes: 0 all requirements pass, 1 internal error, 2 usage, 3 bad input,\n"
      "4 the calculation finished and some requirement fails."};
  fs::path rig_path, vehicle_path, json_path;
  calib::Gravity gravity = calib::Gravity::kEarth;
  bool quiet = false;
  app.add_option("--rig", rig_path, "rig file (lunarnav.rig/1)")->required();
  app.add_option("--vehicle", vehicle_path, "vehicle file (lunarnav.vehicle/1)")->required();
  app.add_option("--gravity", gravity, "earth (9.807 m/s^2) or moon (1.625 m/s^2)")
      ->transform(CLI::CheckedTransformer(
          std::map<std::string, calib::Gravity>{{"earth", calib::Gravity::kEarth}, {"moon", calib::Gravity::kMoon}},
          CLI::ignore_case))
      ->capture_default_str();
  app.add_option("--json", json_path, "also write the results as JSON (summary-style) to this file");
  util::AddCommonFlags(&app, &quiet);
  if (const auto exit_code = util::ParseCommandLine(&app, argc, argv, quiet)) return *exit_code;

  return util::RunMain([&] {
    const calib::StereoRig rig = calib::ReadStereoRig(rig_path);
    const calib::VehicleSpec vehicle = calib::ReadVehicleSpec(vehicle_path);
    const calib::RigCheckResult result = calib::CheckRig(rig, vehicle, gravity);
    if (!quiet) std::cout << result.Table() << std::flush;
    if (!json_path.empty()) {
      nlohmann::json j = util::SummaryHead("rig-check", util::CommandLineJson(argc, argv));
      j["inputs"] = {{"rig", rig_path.string()}, {"vehicle", vehicle_path.string()}};
      j["rig_notes"] = rig.notes;  // what reading the rig changed (printed precision)
      j["options"] = {{"gravity", calib::ToString(gravity)}};
      j["vehicle"] = calib::VehicleSpecToJson(vehicle);
      j.update(result.ToJson());
      io::WriteJsonAtomic(json_path, j);
    }
    LN_LOG(Info) << "rig-check: " << (result.AllPass() ? "all requirements pass" : "some requirements fail");
    return result.AllPass() ? kExitOk : kExitBatchPartial;
  });
}
