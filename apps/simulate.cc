// simulate: synthetic field logs with exact ground truth. One subcommand per kind of data;
// docs/simulate.md describes every option and output.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "io/atomic_file.h"
#include "io/json_io.h"
#include "sim/rover_telemetry.h"
#include "util/cli.h"
#include "util/errors.h"
#include "util/log.h"
#include "util/run_main.h"
#include "util/timer.h"
#include "util/version.h"

namespace fs = std::filesystem;
using namespace lunarnav;

namespace {

// `simulate telemetry`: the rover's raw state-sensor log, its sensor model and the truth.
struct TelemetryCommand {
  sim::RoverTelemetryOptions options;  // defaults live in the library
  fs::path output_dir;
  double duration_s = 0;  // 0: the preset's
  std::vector<std::string> faults;

  void AddTo(CLI::App* app) {
    CLI::App* sub = app->add_subcommand(
        "telemetry",
        "Raw rover telemetry (sec. 4.1 sensors: 4 encoders, compass, 3 inclinometers, gyro) of the\n"
        "paper's commanded trials (sec. 4.2) or a traverse, with exact ground truth. Writes\n"
        "OUT_DIR/telemetry.csv, sensors.json, truth.csv, trials.json, faults.csv, summary.json.");
    sub->add_option("--preset", options.preset, "the setup")
        ->required()
        ->transform(CLI::CheckedTransformer(sim::TelemetryPresetNames(), CLI::ignore_case));
    sub->add_option("-o,--output", output_dir, "output directory (created)")->required();
    sub->add_option("--seed", options.seed, "random seed: the same seed gives the same bytes")->capture_default_str();
    sub->add_option("--bits", options.bits, "digitisation (7: old telemetry)")
        ->check(CLI::IsMember({7, 10}))
        ->capture_default_str();
    sub->add_option("--duration", duration_s, "log length, s (default: the preset's)");
    sub->add_option("--rate", options.rate_hz, "samples per second")->capture_default_str();
    sub->add_option("--noise-scale", options.noise_scale, "multiplies every sensor error (0: ideal sensors)")
        ->capture_default_str();
    sub->add_option("--slip-scale", options.slip_scale, "multiplies every wheel-slip and path-wander term (0: none)")
        ->capture_default_str();
    sub->add_option("--faults", faults, "faults to inject: KIND[:CHANNEL][@TIME|*COUNT|~PER_MINUTE][+SECONDS]")
        ->delimiter(',');
  }

  int Run(int argc, char** argv) {
    util::Timer timer;
    if (duration_s != 0) options.duration_s = duration_s;
    for (const std::string& f : faults) options.faults.push_back(sim::ParseFaultSpec(f));
    options.Validate();
    io::CreateOutputDirectory(output_dir);  // before the work, not after it
    const sim::RoverTelemetry run = sim::SimulateRoverTelemetry(options);
    sim::WriteRoverTelemetry(output_dir, run, options);
    nlohmann::json summary = {{"tool", "simulate"},
                              {"subcommand", "telemetry"},
                              {"version", kVersion},
                              {"git_revision", kGitRevision},
                              {"invocation", util::CommandLineJson(argc, argv)},
                              {"options", options.ToJson()},
                              {"seed", options.seed},
                              {"scenario", run.scenario.ToJson()},
                              {"sensor_error_draws", run.draws.ToJson()},
                              {"outputs", {"telemetry.csv", "sensors.json", "truth.csv", "trials.json", "faults.csv"}},
                              {"counts", run.CountsJson()},
                              {"seconds", timer.ElapsedSeconds()}};
    io::WriteJsonAtomic(output_dir / "summary.json", summary);
    LN_LOG(Info) << "simulate telemetry: " << run.BriefReport() << "; outputs in " << output_dir.string();
    return kExitOk;
  }
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "Synthetic field logs with exact ground truth (Krotkov & Hebert 1995).\n"
      "Exit codes: 0 ok, 1 internal error, 2 usage, 3 bad input."};
  app.require_subcommand(1);
  app.fallthrough();  // -q and --version also after the subcommand
  TelemetryCommand telemetry;
  telemetry.AddTo(&app);
  bool quiet = false;
  util::AddCommonFlags(&app, &quiet);
  if (const auto exit_code = util::ParseCommandLine(&app, argc, argv, quiet)) return *exit_code;

  return util::RunMain([&] { return telemetry.Run(argc, argv); });
}
