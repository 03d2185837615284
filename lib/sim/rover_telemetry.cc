#include "sim/rover_telemetry.h"

#include <charconv>
#include <cmath>
#include <sstream>

#include "io/atomic_file.h"
#include "io/json_io.h"
#include "sim/portable_random.h"
#include "util/check.h"

namespace lunarnav::sim {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kDefaultTraverseS = 1800.0;
constexpr double kMaxRows = 1e7;

// The slag heap of trials A and B: loose, bumpy, on a gentle slope.
GroundSurfaceOptions SlagHeap() {
  GroundSurfaceOptions t;
  t.slope_deg = 3.0;
  t.slope_azimuth_deg = 40.0;
  t.undulation_m = 0.3;
  t.undulation_wavelength_m = 20.0;
  t.roughness_m = 0.03;
  t.roughness_wavelength_m = 1.2;
  return t;
}

// Appends `motion` and a pause after it (the trials stop to measure).
void AddTrial(std::vector<MotionCommand>* commands, const MotionCommand& motion, double pause_s) {
  commands->push_back(motion);
  commands->push_back(MotionCommand::Pause(pause_s));
}

// A random route over the traverse: legs of straights, arcs and turns in place, a pause
// after each, until the estimated time covers `duration_s`.
std::vector<MotionCommand> TraverseRoute(std::uint64_t seed, double duration_s, double speed_mps) {
  PortableRandom rng(seed, "route");
  std::vector<MotionCommand> route = {MotionCommand::Pause(5.0)};
  double time = 5.0;
  while (time < duration_s + 60.0) {
    const int segments = 2 + static_cast<int>(rng.UniformInt(4));
    for (int i = 0; i < segments; ++i) {
      const double pick = rng.Uniform();
      MotionCommand c;
      if (pick < 0.4) {
        c = MotionCommand::Straight(rng.Uniform(5.0, 25.0), speed_mps);
      } else if (pick < 0.9) {
        c = MotionCommand::Arc(rng.Uniform(6.0, 20.0), rng.Sign() * rng.Uniform(15.0, 90.0), speed_mps);
      } else {
        c = MotionCommand::TurnInPlace(rng.Sign() * rng.Uniform(30.0, 120.0), 10.0);
        if (i > 0) route.back().stop_at_end = true;  // stop before turning on the spot
      }
      c.stop_at_end = c.kind == MotionKind::kTurnInPlace || i == segments - 1;
      time += c.kind == MotionKind::kTurnInPlace ? std::abs(c.angle_deg) / c.turn_rate_dps + 2.0
                                                 : c.PathLength() / speed_mps + 1.0;
      route.push_back(c);
    }
    const double pause = rng.Uniform(3.0, 8.0);
    route.push_back(MotionCommand::Pause(pause));
    time += pause;
  }
  return route;
}

// A short run of a small skid-steered rover: straights, turns in place and tight arcs, each
// from rest to rest (the motors start and stop abruptly), now and then a pause.
std::vector<MotionCommand> SkidSteerRoute(std::uint64_t seed, double duration_s) {
  PortableRandom rng(seed, "route");
  std::vector<MotionCommand> route = {MotionCommand::Pause(6.0)};
  double time = 6.0;
  while (time < duration_s + 10.0) {
    const double pick = rng.Uniform();
    MotionCommand c;
    if (pick < 0.5) {
      c = MotionCommand::Straight(rng.Uniform(3.0, 10.0), 0.55);
      time += c.PathLength() / 0.55 + 0.6;
    } else if (pick < 0.8) {
      c = MotionCommand::TurnInPlace(rng.Sign() * rng.Uniform(30.0, 120.0), 45.0);
      time += std::abs(c.angle_deg) / 45.0 + 0.3;
    } else {
      c = MotionCommand::Arc(rng.Uniform(1.5, 5.0), rng.Sign() * rng.Uniform(20.0, 90.0), 0.45);
      time += c.PathLength() / 0.45 + 0.6;
    }
    c.stop_at_end = true;
    route.push_back(c);
    if (rng.Uniform() < 0.3) {
      const double pause = rng.Uniform(2.0, 5.0);
      route.push_back(MotionCommand::Pause(pause));
      time += pause;
    }
  }
  return route;
}

// Fixed-point text, locale-independent, without negative zero.
std::string Fixed(double v, int decimals) {
  const double scale = std::pow(10.0, decimals);
  double r = std::round(v * scale) / scale;
  if (r == 0) r = 0;
  char buf[64];
  return std::string(buf, std::to_chars(buf, buf + sizeof(buf), r, std::chars_format::fixed, decimals).ptr);
}

double Wrap360(double deg) {
  const double d = std::fmod(deg, 360.0);
  return d < 0 ? d + 360.0 : d;
}

double Rounded(double v, double step) {
  const double r = std::round(v / step) * step;
  return r == 0 ? 0.0 : r;
}

nlohmann::json PoseJson(const RoverSample& s) {
  return {{"t_s", s.t_s},
          {"x_m", Rounded(s.x_m, 1e-3)},
          {"y_m", Rounded(s.y_m, 1e-3)},
          {"z_m", Rounded(s.z_m, 1e-3)},
          {"heading_deg", Rounded(Wrap360(s.heading_rad / kDeg), 0.01)},
          {"pitch_deg", Rounded(s.pitch_rad / kDeg, 0.01)},
          {"roll_deg", Rounded(s.roll_rad / kDeg, 0.01)}};
}

}  // namespace

std::string ToString(TelemetryPreset preset) {
  switch (preset) {
    case TelemetryPreset::kTrialA: return "trial-a";
    case TelemetryPreset::kTrialB: return "trial-b";
    case TelemetryPreset::kTrialC: return "trial-c";
    case TelemetryPreset::kTraverse: return "traverse";
    case TelemetryPreset::kSkidSteer: return "skid-steer";
    case TelemetryPreset::kSkidSteerCompass: return "skid-steer-compass";
  }
  return "unknown";
}

std::map<std::string, TelemetryPreset> TelemetryPresetNames() {
  return {{"trial-a", TelemetryPreset::kTrialA},
          {"trial-b", TelemetryPreset::kTrialB},
          {"trial-c", TelemetryPreset::kTrialC},
          {"traverse", TelemetryPreset::kTraverse},
          {"skid-steer", TelemetryPreset::kSkidSteer},
          {"skid-steer-compass", TelemetryPreset::kSkidSteerCompass}};
}

nlohmann::json TelemetryScenario::ToJson() const {
  nlohmann::json commands_json = nlohmann::json::array();
  for (const MotionCommand& c : commands) commands_json.push_back(c.ToJson());
  nlohmann::json j = {{"name", name},
                      {"description", description},
                      {"ground", ground.ToJson()},
                      {"rover", rover.ToJson()},
                      {"sensor_errors", sensor_errors.ToJson()},
                      {"initial_heading_deg", initial_heading_deg},
                      {"commands", commands_json}};
  if (duration_s) j["duration_s"] = *duration_s;
  if (mems) {
    j["mems"] = true;
    j["compass"] = compass;
    j["imu_rate_hz"] = imu_rate_hz;
    j["encoder_rate_hz"] = imu_rate_hz / encoder_decimation;
  }
  return j;
}

TelemetryScenario PresetScenario(TelemetryPreset preset, std::uint64_t seed, std::optional<double> duration_s) {
  TelemetryScenario s;
  s.name = ToString(preset);
  switch (preset) {
    case TelemetryPreset::kTrialA: {
      s.description =
          "Trial A: straight lines of 4-8 m at 0.4 m/s on a slag heap, stopping 4 s after each; motion "
          "control not yet tuned (wheels fight, the path wanders)";
      s.ground = SlagHeap();
      s.rover.slip_mean = 0.04;
      s.rover.wheel_slip_sigma = 0.08;
      s.rover.yaw_disturbance_per_m = 0.02;
      s.rover.turn_slip_rate_hz = 0.1;
      s.initial_heading_deg = 65.0;
      s.commands = {MotionCommand::Pause(5.0)};
      for (double d : {4.0, 6.0, 8.0, 4.0, 6.0, 8.0}) AddTrial(&s.commands, MotionCommand::Straight(d, 0.4), 4.0);
      break;
    }
    case TelemetryPreset::kTrialB: {
      s.description =
          "Trial B: straight lines of 3-6 m at 0.4 m/s and turns in place of 45-180 deg at 10 deg/s on the "
          "slag heap, stopping 4 s after each; motion control tuned";
      s.ground = SlagHeap();
      s.rover.slip_mean = 0.03;
      s.rover.wheel_slip_sigma = 0.015;
      s.rover.yaw_disturbance_per_m = 0.006;
      s.initial_heading_deg = 150.0;
      s.commands = {MotionCommand::Pause(5.0)};
      for (const MotionCommand& c :
           {MotionCommand::Straight(5, 0.4), MotionCommand::TurnInPlace(90, 10), MotionCommand::Straight(4, 0.4),
            MotionCommand::TurnInPlace(-90, 10), MotionCommand::Straight(6, 0.4), MotionCommand::TurnInPlace(180, 10),
            MotionCommand::Straight(5, 0.4), MotionCommand::TurnInPlace(-45, 10), MotionCommand::Straight(3, 0.4)}) {
        AddTrial(&s.commands, c, 4.0);
      }
      break;
    }
    case TelemetryPreset::kTrialC: {
      s.description =
          "Trial C: curved arcs of radius 3-10 m turning 45-180 deg at 0.3 m/s on a flat, grassy field, "
          "stopping 4 s after each";
      s.ground.slope_deg = 0.5;
      s.ground.slope_azimuth_deg = 200.0;
      s.ground.undulation_m = 0.05;
      s.ground.undulation_wavelength_m = 30.0;
      s.ground.roughness_m = 0.01;
      s.ground.roughness_wavelength_m = 2.0;
      s.rover.slip_mean = 0.015;
      s.rover.wheel_slip_sigma = 0.01;
      s.rover.skid_track_factor = 1.3;
      s.rover.yaw_disturbance_per_m = 0.004;
      s.rover.turn_slip_rate_hz = 0.03;
      s.initial_heading_deg = 330.0;  // the arcs cross north
      s.commands = {MotionCommand::Pause(5.0)};
      for (const auto& [radius, angle] : {std::pair{5.0, 90.0}, std::pair{8.0, -60.0}, std::pair{4.0, 180.0},
                                          std::pair{6.0, -120.0}, std::pair{10.0, 45.0}, std::pair{3.0, -90.0}}) {
        AddTrial(&s.commands, MotionCommand::Arc(radius, angle, 0.3), 4.0);
      }
      break;
    }
    case TelemetryPreset::kTraverse: {
      s.description =
          "Traverse: a long drive at 0.4 m/s over rough, rolling terrain (slopes to about 10 deg), legs of "
          "straights, arcs and turns in place with a 3-8 s stop after each";
      s.ground.slope_deg = 2.0;
      s.ground.slope_azimuth_deg = 120.0;
      s.ground.undulation_m = 1.2;
      s.ground.undulation_wavelength_m = 50.0;
      s.ground.roughness_m = 0.05;
      s.ground.roughness_wavelength_m = 1.5;
      s.rover.slip_mean = 0.03;
      s.rover.wheel_slip_sigma = 0.02;
      s.rover.slip_slope_gain = 0.3;
      s.rover.yaw_disturbance_per_m = 0.01;
      s.duration_s = duration_s.value_or(kDefaultTraverseS);
      s.initial_heading_deg = PortableRandom(seed, "initial-heading").Uniform(0.0, 360.0);
      s.commands = TraverseRoute(seed, *s.duration_s, 0.4);
      break;
    }
    case TelemetryPreset::kSkidSteer:
    case TelemetryPreset::kSkidSteerCompass: {
      s.compass = preset == TelemetryPreset::kSkidSteerCompass;
      s.description =
          std::string("Skid-steer: a small four-wheel skid-steered rover with MEMS sensors on rough ground, ") +
          "straights at 0.55 m/s, turns in place at 45 deg/s and tight arcs, each started and stopped abruptly " +
          "(turn accelerations to 500 deg/s^2); encoders at 10 Hz, gyro and accelerometer tilt at 50 Hz" +
          (s.compass ? ", compass at 10 Hz" : ", no compass");
      s.mems = true;
      s.ground = SlagHeap();
      s.rover.track_m = 0.45;
      s.rover.wheelbase_m = 0.40;
      s.rover.max_accel_mps2 = 1.5;
      s.rover.max_turn_accel_dps2 = 500.0;
      s.rover.skid_track_factor = 1.6;
      s.rover.slip_mean = 0.03;
      s.rover.wheel_slip_sigma = 0.02;
      s.rover.turn_slip_rate_hz = 0.1;
      s.rover.yaw_disturbance_per_m = 0.01;
      // MEMS gyro: 0.07 deg/s/sqrt(Hz) noise density (0.35 deg/s RMS at 50 Hz), a bias that
      // differs from run to run and wanders with temperature, a scale error of a few %.
      s.sensor_errors.gyro_bias_dps = 0.5;
      s.sensor_errors.gyro_noise_dps = 0.07 * std::sqrt(25.0);
      s.sensor_errors.gyro_bias_walk_dps_per_sqrt_s = 0.003;
      s.sensor_errors.gyro_bias_instability_dps = 0.1;
      s.sensor_errors.gyro_bias_instability_tau_s = 60.0;
      s.sensor_errors.gyro_scale_error = 0.03;
      // Pitch and roll from an accelerometer: no pendulum lag, every acceleration read as
      // tilt, and the vibration of driving (1.5 deg RMS at 0.5 m/s).
      s.sensor_errors.tilt_bias_deg = 0.5;
      s.sensor_errors.tilt_noise_deg = 0.3;
      s.sensor_errors.tilt_vibration_deg_per_mps = 3.0;
      s.sensor_errors.tilt_accel_gain = 1.0;
      s.sensor_errors.tilt_tau_s = 0.0;
      // An electronic compass (magnetometer), not a fluid-damped flux-gate: no swirl lagging
      // the turns; accelerations read as tilt still deflect it, and the motors' currents and
      // the ground disturb the field.
      s.sensor_errors.compass_noise_deg = 2.0;
      s.sensor_errors.compass_wander_deg = 1.5;
      s.sensor_errors.compass_wander_tau_s = 20.0;
      s.sensor_errors.compass_turn_deg_per_dps = -0.05;
      s.sensor_errors.compass_turn_accel_deg_per_dps2 = 0.0;
      s.sensor_errors.compass_accel_deg_per_mps2 = 2.0;
      s.sensor_errors.compass_transient_tau_s = 0.2;
      s.duration_s = duration_s.value_or(177.0);
      s.initial_heading_deg = PortableRandom(seed, "initial-heading").Uniform(0.0, 360.0);
      s.commands = SkidSteerRoute(seed, *s.duration_s);
      break;
    }
  }
  return s;
}

void RoverTelemetryOptions::Validate() const {
  LN_CHECK_ARG(bits >= 6 && bits <= 16) << "bits: must be in 6..16, got " << bits;
  LN_CHECK_ARG(rate_hz >= 1 && rate_hz <= 1000) << "rate: must be in [1, 1000] Hz, got " << rate_hz;
  LN_CHECK_ARG(!duration_s || (*duration_s > 0 && *duration_s * rate_hz <= kMaxRows))
      << "duration: must be > 0 s and give at most " << kMaxRows << " rows";
  LN_CHECK_ARG(noise_scale >= 0 && noise_scale <= 10) << "noise scale: must be in [0, 10]";
  LN_CHECK_ARG(slip_scale >= 0 && slip_scale <= 10) << "slip scale: must be in [0, 10]";
}

nlohmann::json RoverTelemetryOptions::ToJson() const {
  nlohmann::json faults_json = nlohmann::json::array();
  for (const FaultSpec& f : faults) faults_json.push_back(f.text);
  nlohmann::json j = {{"preset", ToString(preset)}, {"seed", seed},
                      {"bits", bits},               {"rate_hz", rate_hz},
                      {"noise_scale", noise_scale}, {"slip_scale", slip_scale},
                      {"faults", faults_json}};
  j["duration_s"] = duration_s ? nlohmann::json(*duration_s) : nlohmann::json(nullptr);
  return j;
}

RoverTelemetry SimulateRoverTelemetry(const RoverTelemetryOptions& options) {
  options.Validate();
  RoverTelemetry run;
  run.scenario = PresetScenario(options.preset, options.seed, options.duration_s);
  run.scenario.rover = run.scenario.rover.Scaled(options.slip_scale);
  run.scenario.sensor_errors = run.scenario.sensor_errors.Scaled(options.noise_scale);
  const std::optional<double> duration = options.duration_s ? options.duration_s : run.scenario.duration_s;
  const GroundSurface ground(run.scenario.ground, options.seed);
  const bool mems = run.scenario.mems;
  LN_CHECK_ARG(!mems || (options.rate_hz == RoverTelemetryOptions().rate_hz && options.bits == 10))
      << "preset " << run.scenario.name << ": its sensors have their own rates (encoders 10 Hz, IMU 50 Hz) and "
      << "10 bits; --rate and --bits do not apply";
  const double rate_hz = mems ? run.scenario.imu_rate_hz : options.rate_hz;
  run.drive = DriveRover(run.scenario.commands, run.scenario.rover, ground, run.scenario.initial_heading_deg,
                         rate_hz, duration, options.seed);
  SenseDrive(options, &run);
  return run;
}

void SenseDrive(const RoverTelemetryOptions& options, RoverTelemetry* run_ptr) {
  RoverTelemetry& run = *run_ptr;
  const bool mems = run.scenario.mems;
  const double rate_hz = mems ? run.scenario.imu_rate_hz : options.rate_hz;
  LN_CHECK_ARG(run.drive.samples.size() <= kMaxRows) << "the log would exceed " << kMaxRows << " rows";
  run.sensor_model = mems ? MemsRoverSensorModel(run.scenario.compass) : SimulatedSensorModel(options.bits);
  run.raw = SimulateSensors(run.drive.samples, run.scenario.sensor_errors, run.sensor_model, rate_hz,
                            options.seed, &run.draws);
  if (mems) {  // the encoders and the compass at their lower rate: every n-th row
    const int n = run.scenario.encoder_decimation;
    for (std::size_t k = 0; k < run.raw.size(); ++k) {
      if (k % static_cast<std::size_t>(n) == 0) continue;
      for (telemetry::Channel c : {telemetry::Channel::kEncoderFrontLeft, telemetry::Channel::kEncoderFrontRight,
                                   telemetry::Channel::kEncoderRearLeft, telemetry::Channel::kEncoderRearRight,
                                   telemetry::Channel::kCompass}) {
        run.raw.counts[k][static_cast<int>(c)] = kEmptyCell;
      }
    }
  }
  run.faults = InjectFaults(options.faults, run.sensor_model, options.seed, &run.raw);
}

nlohmann::json RoverTelemetry::CountsJson() const {
  nlohmann::json by_kind = nlohmann::json::object();
  for (const char* kind : {"spike", "stuck", "dropout", "repeated_timestamp", "out_of_order_timestamp", "out_of_range"}) {
    by_kind[kind] = 0;
  }
  for (const InjectedFault& f : faults) by_kind[ToString(f.kind)] = by_kind[ToString(f.kind)].get<int>() + 1;
  const RoverSample& last = drive.samples.back();
  return {{"rows", raw.size()},
          {"duration_s", last.t_s},
          {"distance_m", last.distance_m},
          {"commands", scenario.commands.size()},
          {"commands_completed", drive.commands_completed},
          {"trials", drive.trials.size()},
          {"trials_truncated", drive.trials_truncated},
          {"faults", faults.size()},
          {"faults_by_kind", by_kind},
          {"final_pose", {{"x_m", last.x_m}, {"y_m", last.y_m}, {"z_m", last.z_m},
                          {"heading_deg", Wrap360(last.heading_rad / kDeg)}}}};
}

std::string RoverTelemetry::BriefReport() const {
  std::ostringstream s;
  s.imbue(std::locale::classic());
  const RoverSample& last = drive.samples.back();
  s << scenario.name << ": " << raw.size() << " rows, " << last.t_s << " s, " << std::round(last.distance_m * 10) / 10
    << " m driven, " << drive.trials.size() << " trials, " << faults.size() << " faults";
  return s.str();
}

void WriteTruthCsv(const std::filesystem::path& path, const std::vector<RoverSample>& samples) {
  io::AtomicOutputFile file(path);
  std::string s =
      "# lunarnav simulated ground truth: frame x east, y north, z up (m), origin at the start;\n"
      "# heading clockwise from north (deg, [0, 360)), pitch nose up (deg), roll right side down (deg);\n"
      "# speed along the ground (m/s, negative reversing), turn rate positive turning right (deg/s),\n"
      "# distance: path length (m); wheel_*_m: each wheel's rim travel, slip included (m)\n"
      "t_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg,speed_mps,pitch_left_deg,pitch_right_deg,turn_rate_dps,"
      "accel_mps2,distance_m,wheel_fl_m,wheel_fr_m,wheel_rl_m,wheel_rr_m\n";
  for (const RoverSample& p : samples) {
    s += FormatMicroseconds(std::llround(p.t_s * 1e6));
    for (double v : {p.x_m, p.y_m, p.z_m}) s += "," + Fixed(v, 6);
    s += "," + Fixed(Wrap360(p.heading_rad / kDeg), 6);
    for (double v : {p.pitch_rad, p.roll_rad}) s += "," + Fixed(v / kDeg, 6);
    s += "," + Fixed(p.speed_mps, 6);
    for (double v : {p.pitch_left_rad, p.pitch_right_rad, p.turn_rate_radps}) s += "," + Fixed(v / kDeg, 6);
    s += "," + Fixed(p.accel_mps2, 6) + "," + Fixed(p.distance_m, 6);
    for (double v : p.wheel_m) s += "," + Fixed(v, 6);
    s += '\n';
    if (s.size() > (1u << 20)) {
      file.Write(s);
      s.clear();
    }
  }
  file.Write(s);
  file.Commit();
}

nlohmann::json TrialsJson(const RoverTelemetry& run) {
  const std::vector<RoverSample>& samples = run.drive.samples;
  auto pose = [&](std::size_t k) {
    nlohmann::json j = PoseJson(samples[k]);
    j["line"] = TelemetryCsvLine(k);
    return j;
  };
  nlohmann::json trials = nlohmann::json::array();
  int id = 0;
  for (const RoverTrial& t : run.drive.trials) {
    const RoverSample& a = samples[t.start_sample];
    const RoverSample& b = samples[t.end_sample];
    nlohmann::json commands = nlohmann::json::array();
    double commanded_length = 0, commanded_turn = 0;
    for (int c = t.first_command; c <= t.last_command; ++c) {
      const MotionCommand& m = run.scenario.commands[c];
      commands.push_back(m.ToJson());
      commanded_length += m.PathLength();
      if (m.kind == MotionKind::kArc || m.kind == MotionKind::kTurnInPlace) commanded_turn += m.angle_deg;
    }
    const double dx = b.x_m - a.x_m, dy = b.y_m - a.y_m, dz = b.z_m - a.z_m;
    trials.push_back(
        {{"id", ++id},
         {"description", t.description},
         {"commands", commands},
         {"commanded", {{"path_length_m", commanded_length}, {"heading_change_deg", commanded_turn}}},
         {"start", pose(t.start_sample)},
         {"end", pose(t.end_sample)},
         {"rest_until", {{"t_s", samples[t.rest_until_sample].t_s}, {"line", TelemetryCsvLine(t.rest_until_sample)}}},
         {"measured",
          {{"distance_m", Rounded(std::hypot(dx, dy), 1e-3)},
           {"displacement_m", {Rounded(dx, 1e-3), Rounded(dy, 1e-3), Rounded(dz, 1e-3)}},
           {"heading_change_deg", Rounded((b.heading_rad - a.heading_rad) / kDeg, 0.01)},
           {"path_length_m", Rounded(b.distance_m - a.distance_m, 1e-3)}}}});
  }
  return {{"format", "lunarnav.trials/1"},
          {"preset", run.scenario.name},
          {"description", run.scenario.description},
          {"frame",
           "x east, y north, z up (m), origin at the start pose; heading clockwise from north (deg, [0, 360)); "
           "pitch nose up, roll right side down (deg); line: of telemetry.csv"},
          {"trials", trials},
          {"trials_truncated", run.drive.trials_truncated}};
}

void WriteRoverTelemetry(const std::filesystem::path& dir, const RoverTelemetry& run,
                         const RoverTelemetryOptions& options, const std::filesystem::path& truth_dir_or_empty) {
  const std::filesystem::path truth_dir = truth_dir_or_empty.empty() ? dir : truth_dir_or_empty;
  io::CreateOutputDirectory(dir);
  io::CreateOutputDirectory(truth_dir);
  std::ostringstream description;
  description.imbue(std::locale::classic());
  description << "preset " << run.scenario.name << ", seed " << options.seed << ", " << options.bits << " bits, ";
  if (run.scenario.mems) {
    description << "encoders " << run.scenario.imu_rate_hz / run.scenario.encoder_decimation << " Hz, IMU "
                << run.scenario.imu_rate_hz << " Hz";
  } else {
    description << options.rate_hz << " Hz";
  }
  description << " (lunarnav simulate telemetry)";
  WriteTelemetryCsv(dir / "telemetry.csv", run.raw, description.str(), run.sensor_model);
  nlohmann::json sensors = run.sensor_model.ToJson();
  sensors["description"] = "Sensor model of the simulated rover (" + description.str() +
                           "): nominal calibration; the sensors' own errors are in summary.json";
  sensors["bits"] = options.bits;
  if (!run.sensor_model.vehicle.empty()) {
    sensors["vehicle"]["description"] =
        "physical limits of the vehicle (generous): screening's rate limits derive from them";
  }
  io::WriteJsonAtomic(dir / "sensors.json", sensors);
  WriteTruthCsv(truth_dir / (truth_dir == dir ? "truth.csv" : "trajectory.csv"), run.drive.samples);
  io::WriteJsonAtomic(truth_dir / "trials.json", TrialsJson(run));
  WriteFaultsCsv(truth_dir / "faults.csv", run.faults);
}

}  // namespace lunarnav::sim
