#include "apps/simulate_field_log_cli.h"

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "apps/simulate_stereo_cli.h"
#include "sim/field_log.h"
#include "util/log.h"
#include "util/run_main.h"

namespace lunarnav::apps {

std::function<int(const nlohmann::json&, bool)> RegisterFieldLogCommand(CLI::App& app) {
  struct State {
    StereoRenderFlags flags;
    sim::FieldLogOptions options;
    std::string vehicle = "paper", route = "turns";
    bool compass = false, no_compass = false, no_noise = false;
    std::vector<std::string> telemetry_faults;
    std::filesystem::path output_dir;
  };
  auto state = std::make_shared<State>();
  state->flags.options.interval_s = 0;  // the vehicle's default
  state->flags.options.frames = 40;     // a traverse (docs/simulate.md)
  sim::FieldLogOptions& o = state->options;
  CLI::App* cmd = app.add_subcommand(
      "field-log",
      "Both halves of one drive, as a rover records them: stereo pairs of the paper's rig and raw\n"
      "telemetry (encoders, gyro, inclinometers, compass) of the same motion over the same rocky\n"
      "terrain, the frames' times on the telemetry clock, and the truth. Writes OUT_DIR/left, right,\n"
      "rig.json, telemetry.csv, sensors.json, frame_times.csv, truth/, summary.json\n"
      "(docs/simulate.md#field-log).");
  cmd->fallthrough();
  cmd->add_option("-o,--output", state->output_dir, "output directory (created)")->required();
  cmd->add_option("--vehicle", state->vehicle,
                  "paper (10 Hz 10/7-bit telemetry, 0.15 m/s, a pair every 3.2 s) or skid-steer (MEMS sensors at "
                  "50 Hz, 0.3 m/s, a pair every second)")
      ->check(CLI::IsMember({"paper", "skid-steer"}))
      ->capture_default_str();
  cmd->add_option("--route", state->route, "turns (straights, arcs, turns in place, stops) or straight")
      ->check(CLI::IsMember({"turns", "straight"}))
      ->capture_default_str();
  cmd->add_option("--frames", state->flags.options.frames, "stereo pairs")->capture_default_str();
  cmd->add_option("--interval", state->flags.options.interval_s, "time between pairs, s (default: the vehicle's)");
  cmd->add_option("--speed", o.speed_mps, "cruise speed, m/s (default: the vehicle's)");
  cmd->add_option("--turn-rate", o.turn_rate_dps, "turns in place, deg/s (default: the vehicle's)");
  cmd->add_option("--slope", o.slope_deg, "mean slope of the terrain, deg")->capture_default_str();
  cmd->add_option("--slope-azimuth", o.slope_azimuth_deg, "its uphill direction, deg clockwise from north")
      ->capture_default_str();
  cmd->add_option("--first-frame", o.first_frame_s, "the first pair's time on the telemetry clock, s")
      ->capture_default_str();
  cmd->add_option("--start-rest", o.start_rest_s, "at rest before the first motion, s")->capture_default_str();
  CLI::Option* with = cmd->add_flag("--compass", state->compass, "the skid-steer rover with a compass");
  cmd->add_flag("--no-compass", state->no_compass, "the skid-steer rover without one (its default)")->excludes(with);
  cmd->add_option("--bits", o.bits, "telemetry digitisation of the paper vehicle (7: old telemetry)")
      ->check(CLI::IsMember({7, 10}))
      ->capture_default_str();
  CLI::Option* noise =
      cmd->add_option("--noise-scale", o.noise_scale, "multiplies every sensor error (0: ideal sensors)")
          ->capture_default_str();
  cmd->add_flag("--no-noise", state->no_noise, "ideal state sensors (same as --noise-scale 0)")->excludes(noise);
  cmd->add_option("--slip-scale", o.slip_scale, "multiplies every wheel-slip and path-wander term (0: none)")
      ->capture_default_str();
  cmd->add_option("--telemetry-faults", state->telemetry_faults,
                  "faults in the telemetry, as simulate telemetry --faults (comma-separated)")
      ->delimiter(',');
  AddStereoRenderOptions(cmd, &state->flags);

  return [state](const nlohmann::json& invocation, bool quiet) {
    return util::RunMain([&] {
      sim::FieldLogOptions opt = state->options;
      opt.stereo = state->flags.Resolved(quiet);
      opt.vehicle = sim::FieldVehicleFromString(state->vehicle);
      opt.route = sim::FieldRouteFromString(state->route);
      if (state->compass) opt.compass = true;
      if (state->no_compass) opt.compass = false;
      if (state->no_noise) opt.noise_scale = 0;
      for (const std::string& f : state->telemetry_faults) {
        for (sim::FaultSpec& spec : sim::ParseFaultSpecs(f)) opt.telemetry_faults.push_back(std::move(spec));
      }
      const sim::FieldLogSummary summary = sim::RunFieldLogSimulation(opt, state->output_dir, invocation);
      LN_LOG(Info) << "simulate field-log: " << summary.BriefReport() << "; outputs in "
                   << state->output_dir.string() << ", summary " << summary.summary_path.string();
      return 0;
    });
  };
}

}  // namespace lunarnav::apps
