// simulate: synthetic field logs with exact ground truth. One subcommand per kind of data;
// docs/simulate.md describes every option and output.
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "io/atomic_file.h"
#include "io/json_io.h"
#include "apps/simulate_chessboard_cli.h"
#include "apps/simulate_field_log_cli.h"
#include "apps/simulate_stereo_cli.h"
#include "sim/rover_telemetry.h"
#include "util/cli.h"
#include "util/errors.h"
#include "util/log.h"
#include "util/run_main.h"
#include "util/summary.h"
#include "util/timer.h"

namespace fs = std::filesystem;
using namespace lunarnav;

namespace {

// `simulate telemetry`: the rover's raw state-sensor log, its sensor model and the truth.
struct TelemetryCommand {
  sim::RoverTelemetryOptions options;  // defaults live in the library
  std::string preset;
  fs::path output_dir;
  double duration_s = 0;  // 0: the preset's
  bool no_noise = false;
  std::vector<std::string> faults;
  CLI::App* sub = nullptr;

  void AddTo(CLI::App* app) {
    sub = app->add_subcommand(
        "telemetry",
        "Raw rover telemetry (sec. 4.1 sensors: 4 encoders, compass, 3 inclinometers, gyro) of the\n"
        "paper's commanded trials (sec. 4.2) or a traverse, with exact ground truth. Writes\n"
        "OUT_DIR/telemetry.csv, sensors.json, truth.csv, trials.json, faults.csv, summary.json.");
    sub->fallthrough();  // the tool's own flags (-q, --version) may follow the subcommand
    std::vector<std::string> presets;
    for (const auto& [name, value] : sim::TelemetryPresetNames()) presets.push_back(name);
    sub->add_option("--preset", preset, "the setup (docs/simulate.md)")->required()->check(CLI::IsMember(presets));
    sub->add_option("-o,--output", output_dir, "output directory (created)")->required();
    sub->add_option("--seed", options.seed, "random seed: the same seed gives the same bytes")->capture_default_str();
    sub->add_option("--bits", options.bits, "digitisation (7: old telemetry)")
        ->check(CLI::IsMember({7, 10}))
        ->capture_default_str();
    sub->add_option("--duration", duration_s, "log length, s (default: the preset's)")->check(CLI::PositiveNumber);
    sub->add_option("--rate", options.rate_hz, "samples per second, 1..1000")->capture_default_str();
    CLI::Option* noise_scale =
        sub->add_option("--noise-scale", options.noise_scale, "multiplies every sensor error (0: ideal sensors)")
            ->capture_default_str();
    sub->add_flag("--no-noise", no_noise, "ideal sensors: counts are the truth digitised (same as --noise-scale 0)")
        ->excludes(noise_scale);
    sub->add_option("--slip-scale", options.slip_scale, "multiplies every wheel-slip and path-wander term (0: none)")
        ->capture_default_str();
    sub->add_option("--faults", faults,
                    "faults to inject, comma-separated: KIND[:CHANNEL][@TIME|*COUNT|~PER_MINUTE][+SECONDS], KIND one "
                    "of spikes, stuck, dropouts, timestamps, out-of-range (docs/simulate.md)")
        ->delimiter(',');
  }

  int Run(const nlohmann::json& invocation) {
    util::Timer timer;
    options.preset = sim::TelemetryPresetNames().at(preset);
    if (duration_s != 0) options.duration_s = duration_s;
    if (no_noise) options.noise_scale = 0;
    for (const std::string& f : faults) {
      for (sim::FaultSpec& spec : sim::ParseFaultSpecs(f)) options.faults.push_back(std::move(spec));
    }
    options.Validate();
    io::CreateOutputDirectory(output_dir);  // before the work, not after it
    const sim::RoverTelemetry run = sim::SimulateRoverTelemetry(options);
    sim::WriteRoverTelemetry(output_dir, run, options);
    nlohmann::json summary = util::SummaryHead("simulate", invocation);
    summary.update(nlohmann::json{
        {"subcommand", "telemetry"},
        {"options", options.ToJson()},
        {"seed", options.seed},
        {"scenario", run.scenario.ToJson()},
        {"sensor_error_draws", run.draws.ToJson()},
        {"outputs", {"telemetry.csv", "sensors.json", "truth.csv", "trials.json", "faults.csv"}},
        {"counts", run.CountsJson()},
        {"seconds", timer.ElapsedSeconds()}});  // summary.json alone varies from run to run
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
  // `simulate stereo` (rendered stereo sequences) registers from its own translation unit.
  const auto run_stereo = apps::RegisterStereoCommand(app);
  // `simulate chessboard` (calibration views) likewise.
  const auto run_chessboard = apps::RegisterChessboardCommand(app);
  // `simulate field-log` (both halves of one drive) likewise.
  const auto run_field_log = apps::RegisterFieldLogCommand(app);
  bool quiet = false;
  util::AddCommonFlags(&app, &quiet);
  if (const auto exit_code = util::ParseCommandLine(&app, argc, argv, quiet)) return *exit_code;

  const nlohmann::json invocation = util::CommandLineJson(argc, argv);
  if (app.got_subcommand(telemetry.sub)) return util::RunMain([&] { return telemetry.Run(invocation); });
  if (app.got_subcommand("stereo")) return run_stereo(invocation, quiet);
  if (app.got_subcommand("chessboard")) return run_chessboard(invocation, quiet);
  if (app.got_subcommand("field-log")) return run_field_log(invocation, quiet);
  return util::RunMain([]() -> int { throw std::logic_error("simulate: no subcommand to run"); });
}
