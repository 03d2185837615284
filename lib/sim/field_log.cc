#include "sim/field_log.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <sstream>

#include <tbb/task_arena.h>

#include "io/atomic_file.h"
#include "sim/portable_random.h"
#include "sim/scene.h"
#include "util/check.h"
#include "util/format.h"
#include "util/log.h"
#include "util/parallel.h"
#include "util/summary.h"
#include "util/timer.h"

namespace lunarnav::sim {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr double kDeg = M_PI / 180.0;
// Terrain around the route: the cameras see about 12 m ahead on level ground (as simulate
// stereo's margin), plus what slip and wander may add to the commanded path.
constexpr double kTerrainMarginM = 22.0;
constexpr double kWanderMarginM = 2.0;
constexpr double kWanderMarginPerM = 0.1;
// The drive must keep this far from the terrain's edge for every frame to see ground.
constexpr double kMinEdgeDistanceM = 14.0;

struct VehicleDefaults {
  double speed_mps, turn_rate_dps, interval_s, wheel_radius_m;
  double straight_min_m, straight_max_m, radius_min_m, radius_max_m;
  double max_rock_m;  // the tallest rock it drives over (its route keeps clear of taller ones)
};

VehicleDefaults Defaults(FieldVehicle v) {
  if (v == FieldVehicle::kSkidSteer) return {0.3, 20.0, 1.0, 0.1, 2.0, 5.0, 2.0, 6.0, 0.1};
  return {0.15, 10.0, 3.2, 0.25, 2.0, 6.0, 4.0, 12.0, 0.2};  // sec. 3.1: an obstacle 20 cm tall
}
// The route's clearance beyond the wheels: what slip and wander may add to the commanded path.
constexpr double kClearMarginM = 0.6;

// The ground a wheel of radius r rests on: the highest point of the surface under a disc
// of the wheel's radius, each sample lowered by the wheel's curvature there (a rim rolling
// over a rock rises before its centre reaches it).
HeightFunction WheelGround(const Terrain& terrain, double r) {
  return [&terrain, r](double x, double y) {
    double best = terrain.HeightAt(x, y);
    if (!std::isfinite(best) || r <= 0) return best;
    for (const double rho : {0.4 * r, 0.8 * r}) {
      const double drop = r - std::sqrt(r * r - rho * rho);
      for (int k = 0; k < 8; ++k) {
        const double a = k * (M_PI / 4);
        const double h = terrain.HeightAt(x + rho * std::cos(a), y + rho * std::sin(a));
        if (!std::isfinite(h)) return h;
        best = std::max(best, h - drop);
      }
    }
    return best;
  };
}

// The scenario of the vehicle: rover, sensors and their rates as simulate telemetry's presets.
TelemetryScenario VehicleScenario(const FieldLogOptions& o) {
  const TelemetryPreset preset = o.vehicle == FieldVehicle::kPaper ? TelemetryPreset::kTrialB
                                 : *o.compass                      ? TelemetryPreset::kSkidSteerCompass
                                                                   : TelemetryPreset::kSkidSteer;
  TelemetryScenario s = PresetScenario(preset, o.stereo.seed, std::nullopt);
  s.name = "field-log-" + ToString(o.vehicle);
  s.description = (o.vehicle == FieldVehicle::kPaper
                       ? std::string("The paper's vehicle (trial B's tuned motion control and sensors)")
                       : "The small skid-steered rover (" + s.name + "'s MEMS sensors" +
                             (*o.compass ? ", compass" : ", no compass") + ")") +
                  " on simulate stereo's rocky terrain, mapping as it drives";
  s.ground = GroundSurfaceOptions();  // not used: the terrain is the scene's
  s.initial_heading_deg = 0;
  s.rover = s.rover.Scaled(o.slip_scale);
  s.sensor_errors = s.sensor_errors.Scaled(o.noise_scale);
  return s;
}

RoverTelemetryOptions TelemetryOptions(const FieldLogOptions& o) {
  RoverTelemetryOptions t;
  t.preset = o.vehicle == FieldVehicle::kPaper ? TelemetryPreset::kTrialB
             : *o.compass                      ? TelemetryPreset::kSkidSteerCompass
                                               : TelemetryPreset::kSkidSteer;
  t.seed = o.stereo.seed;
  t.bits = o.bits;
  t.noise_scale = o.noise_scale;
  t.slip_scale = o.slip_scale;
  t.faults = o.telemetry_faults;
  return t;
}

// The vehicle's pose at time t: position and heading interpolated between the drive's
// samples (at 10 Hz or more, exact to a fraction of a millimetre), the attitude from the
// ground under the wheels there.
VehiclePose PoseAt(const RoverDrive& drive, double rate_hz, double t, const HeightFunction& ground,
                   const RoverOptions& rover) {
  const std::vector<RoverSample>& s = drive.samples;
  const double u = t * rate_hz;
  const std::size_t i = std::min(static_cast<std::size_t>(std::max(0.0, std::floor(u))), s.size() - 2);
  const double f = std::clamp(u - static_cast<double>(i), 0.0, 1.0);
  const RoverSample& a = s[i];
  const RoverSample& b = s[i + 1];
  VehiclePose p;
  p.x_m = a.x_m + f * (b.x_m - a.x_m);
  p.y_m = a.y_m + f * (b.y_m - a.y_m);
  p.heading_rad = a.heading_rad + f * (b.heading_rad - a.heading_rad);
  const RoverAttitude att = RoverAttitudeOn(ground, rover, p.x_m, p.y_m, p.heading_rad);
  p.z_m = att.z_m;
  p.pitch_rad = att.pitch_rad;
  p.roll_rad = att.roll_rad;
  return p;
}

}  // namespace

std::string ToString(FieldVehicle vehicle) { return vehicle == FieldVehicle::kPaper ? "paper" : "skid-steer"; }

FieldVehicle FieldVehicleFromString(const std::string& name) {
  if (name == "paper") return FieldVehicle::kPaper;
  LN_CHECK_ARG(name == "skid-steer") << "vehicle: paper or skid-steer, got '" << name << "'";
  return FieldVehicle::kSkidSteer;
}

std::string ToString(FieldRoute route) { return route == FieldRoute::kStraight ? "straight" : "turns"; }

FieldRoute FieldRouteFromString(const std::string& name) {
  if (name == "straight") return FieldRoute::kStraight;
  LN_CHECK_ARG(name == "turns") << "route: straight or turns, got '" << name << "'";
  return FieldRoute::kTurns;
}

FieldLogOptions FieldLogOptions::Resolved() const {
  FieldLogOptions o = *this;
  const VehicleDefaults d = Defaults(vehicle);
  if (o.speed_mps == 0) o.speed_mps = d.speed_mps;
  if (o.turn_rate_dps == 0) o.turn_rate_dps = d.turn_rate_dps;
  if (o.stereo.interval_s <= 0) o.stereo.interval_s = d.interval_s;
  if (!o.compass) o.compass = vehicle == FieldVehicle::kPaper;
  o.stereo.speed_mps = o.speed_mps;  // what summary.json's rendering options report
  o.stereo.turn_radius_m = 0;
  return o;
}

void FieldLogOptions::Validate() const {
  const FieldLogOptions o = Resolved();
  o.stereo.Validate();
  LN_CHECK_ARG(o.stereo.preset == "terrain") << "preset: a field log is driven over the terrain preset";
  LN_CHECK_ARG(std::isfinite(o.speed_mps) && o.speed_mps > 0 && o.speed_mps <= 2) << "speed: must be in (0, 2] m/s";
  LN_CHECK_ARG(std::isfinite(o.turn_rate_dps) && o.turn_rate_dps > 0 && o.turn_rate_dps <= 90)
      << "turn rate: must be in (0, 90] deg/s";
  LN_CHECK_ARG(std::isfinite(slope_deg) && slope_deg >= 0 && slope_deg < 20) << "slope: must be in [0, 20) deg";
  LN_CHECK_ARG(std::isfinite(slope_azimuth_deg)) << "slope azimuth: not finite";
  LN_CHECK_ARG(std::isfinite(start_rest_s) && start_rest_s >= 1 && start_rest_s <= 600)
      << "start rest: must be in [1, 600] s";
  LN_CHECK_ARG(std::isfinite(first_frame_s) && first_frame_s >= 0 && first_frame_s <= 3600)
      << "first frame: must be in [0, 3600] s";
  LN_CHECK_ARG(bits == 10 || bits == 7) << "bits: 10 or 7, got " << bits;
  LN_CHECK_ARG(vehicle == FieldVehicle::kPaper || bits == 10) << "bits: the skid-steer rover's sensors give 10 bits";
  LN_CHECK_ARG(vehicle == FieldVehicle::kSkidSteer || *o.compass)
      << "compass: the paper's vehicle has one (--no-compass is for the skid-steer rover)";
  LN_CHECK_ARG(noise_scale >= 0 && noise_scale <= 10) << "noise scale: must be in [0, 10]";
  LN_CHECK_ARG(slip_scale >= 0 && slip_scale <= 10) << "slip scale: must be in [0, 10]";
  const double duration = first_frame_s + (o.stereo.frames - 1) * o.stereo.interval_s;
  LN_CHECK_ARG(duration <= 36000) << "the frames span " << duration << " s: at most 10 hours";
}

json FieldLogOptions::ToJson() const {
  const FieldLogOptions o = Resolved();
  json faults = json::array();
  for (const FaultSpec& f : telemetry_faults) faults.push_back(f.text);
  return {{"vehicle", ToString(vehicle)},
          {"route", ToString(route)},
          {"compass", *o.compass},
          {"speed_mps", o.speed_mps},
          {"turn_rate_dps", o.turn_rate_dps},
          {"interval_s", o.stereo.interval_s},
          {"frames", o.stereo.frames},
          {"first_frame_s", first_frame_s},
          {"start_rest_s", start_rest_s},
          {"slope_deg", slope_deg},
          {"slope_azimuth_deg", slope_azimuth_deg},
          {"bits", bits},
          {"noise_scale", noise_scale},
          {"slip_scale", slip_scale},
          {"telemetry_faults", faults},
          {"seed", stereo.seed}};
}

std::vector<MotionCommand> FieldRouteCommands(const FieldLogOptions& options, double duration_s) {
  const FieldLogOptions o = options.Resolved();
  const VehicleDefaults d = Defaults(o.vehicle);
  const double v = o.speed_mps;
  std::vector<MotionCommand> route = {MotionCommand::Pause(o.start_rest_s)};
  double time = o.start_rest_s;
  if (o.route == FieldRoute::kStraight) {
    MotionCommand c = MotionCommand::Straight(v * std::max(0.0, duration_s - time) + 2.0, v);
    route.push_back(c);
    return route;
  }
  PortableRandom rng(o.stereo.seed, "field-route");
  bool first = true;
  while (time < duration_s + 5.0) {
    const double pick = first ? 0.0 : rng.Uniform();
    first = false;
    MotionCommand c;
    if (pick < 0.35) {
      c = MotionCommand::Straight(rng.Uniform(d.straight_min_m, d.straight_max_m), v);
      time += c.PathLength() / v + 1.0;
    } else if (pick < 0.75) {
      c = MotionCommand::Arc(rng.Uniform(d.radius_min_m, d.radius_max_m), rng.Sign() * rng.Uniform(20.0, 60.0), v);
      time += c.PathLength() / v + 1.0;
    } else if (pick < 0.9) {
      c = MotionCommand::TurnInPlace(rng.Sign() * rng.Uniform(15.0, 40.0), o.turn_rate_dps);
      time += std::abs(c.angle_deg) / o.turn_rate_dps + 2.0;
      if (route.back().kind != MotionKind::kPause) route.back().stop_at_end = true;  // stop, then turn
    } else {
      c = MotionCommand::Pause(rng.Uniform(2.0, 5.0));
      time += c.duration_s;
      if (route.back().kind != MotionKind::kPause) route.back().stop_at_end = true;
    }
    // Straights and arcs run into each other at speed; a turn in place starts and ends at rest.
    c.stop_at_end = c.kind == MotionKind::kTurnInPlace || c.kind == MotionKind::kPause;
    route.push_back(c);
  }
  return route;
}

std::string FieldLogSummary::BriefReport() const {
  std::ostringstream s;
  s.imbue(std::locale::classic());
  s.setf(std::ios::fixed);
  s.precision(1);
  s << frames << " frames, " << telemetry_rows << " telemetry rows, " << distance_m << " m in " << duration_s
    << " s; " << seconds << " s";
  return s.str();
}

FieldLogSummary RunFieldLogSimulation(const FieldLogOptions& options_in, const fs::path& output_dir,
                                      const json& invocation) {
  options_in.Validate();
  util::Timer total;
  FieldLog log;
  log.options = options_in.Resolved();
  const FieldLogOptions& o = log.options;
  io::CreateOutputDirectory(output_dir);  // an unusable directory is refused before the work

  // The frames' times and the route that lasts past the last one.
  const int frames = o.stereo.frames;
  for (int k = 0; k < frames; ++k) log.frame_times_s.push_back(o.first_frame_s + k * o.stereo.interval_s);
  const double duration_s = log.frame_times_s.back() + 1.0;
  TelemetryScenario scenario = VehicleScenario(o);
  scenario.commands = FieldRouteCommands(o, duration_s);
  scenario.duration_s = duration_s;
  const double rate_hz = scenario.mems ? scenario.imu_rate_hz : RoverTelemetryOptions().rate_hz;

  // The terrain covers the commanded route (driven without slip on level ground) and a margin.
  const RoverDrive commanded = DriveRover(scenario.commands, scenario.rover.Scaled(0.0),
                                          HeightFunction([](double, double) { return 0.0; }), 0.0, rate_hz,
                                          duration_s, o.stereo.seed);
  double x0 = 0, x1 = 0, y0 = 0, y1 = 0;
  for (const RoverSample& s : commanded.samples) {
    x0 = std::min(x0, s.x_m), x1 = std::max(x1, s.x_m);
    y0 = std::min(y0, s.y_m), y1 = std::max(y1, s.y_m);
  }
  const double margin = kTerrainMarginM + kWanderMarginM + kWanderMarginPerM * commanded.samples.back().distance_m;
  SceneOptions scene_options = MakeSceneOptions(o.stereo);
  TerrainOptions& t = scene_options.terrain;
  const double c = t.cell_m;
  t.min_x_m = std::floor((x0 - margin) / c) * c;
  t.max_x_m = std::ceil((x1 + margin) / c) * c;
  t.min_y_m = std::floor((y0 - margin) / c) * c;
  t.max_y_m = std::ceil((y1 + margin) / c) * c;
  // The route keeps clear of rocks the vehicle cannot drive over, as its planner would.
  const VehicleDefaults vehicle = Defaults(o.vehicle);
  double last_distance = -1;
  for (const RoverSample& sample : commanded.samples) {
    if (last_distance >= 0 && sample.distance_m - last_distance < 0.25) continue;
    t.clear_path_m.emplace_back(sample.x_m, sample.y_m);
    last_distance = sample.distance_m;
  }
  t.clear_path_m.emplace_back(commanded.samples.back().x_m, commanded.samples.back().y_m);
  t.clear_half_width_m = 0.5 * scenario.rover.track_m + vehicle.wheel_radius_m + kClearMarginM;
  t.clear_max_rock_height_m = vehicle.max_rock_m;
  t.slope_x = std::tan(o.slope_deg * kDeg) * std::sin(o.slope_azimuth_deg * kDeg);
  t.slope_y = std::tan(o.slope_deg * kDeg) * std::cos(o.slope_azimuth_deg * kDeg);

  util::Timer scene_timer;
  std::unique_ptr<Scene> scene;
  tbb::task_arena arena(util::EffectiveThreadCount(o.stereo.num_threads));
  arena.execute([&] { scene = std::make_unique<Scene>(scene_options); });
  const double scene_seconds = scene_timer.ElapsedSeconds();

  // The drive over it, and what the sensors make of it.
  log.wheel_radius_m = vehicle.wheel_radius_m;
  const HeightFunction ground = WheelGround(scene->terrain(), log.wheel_radius_m);
  RoverTelemetry& run = log.telemetry;
  run.scenario = scenario;
  run.drive = DriveRover(scenario.commands, scenario.rover, ground, 0.0, rate_hz, duration_s, o.stereo.seed);
  for (const RoverSample& s : run.drive.samples) {
    const double edge = std::min({s.x_m - t.min_x_m, t.max_x_m - s.x_m, s.y_m - t.min_y_m, t.max_y_m - s.y_m});
    LN_CHECK(edge >= kMinEdgeDistanceM) << "the drive came within " << edge << " m of the terrain's edge at t = "
                                        << s.t_s << " s";
  }
  const RoverTelemetryOptions telemetry_options = TelemetryOptions(o);
  SenseDrive(telemetry_options, &run);

  // The frames' true poses: the world's origin is the start pose's vehicle frame.
  log.start_z_m = RoverAttitudeOn(ground, scenario.rover, 0.0, 0.0, 0.0).z_m;
  for (double time : log.frame_times_s) {
    log.frame_poses.push_back(PoseAt(run.drive, rate_hz, time, ground, scenario.rover));
  }

  // Outputs: the telemetry half, the frame times, then the stereo half and summary.json.
  WriteRoverTelemetry(output_dir, run, telemetry_options, output_dir / "truth");
  std::string times = "# lunarnav field log: each stereo pair's time on the telemetry clock (telemetry.csv's t_s), s\n";
  times += "stem,t_s\n";
  for (int k = 0; k < frames; ++k) times += FrameStem(k) + "," + util::Format("%.6f", log.frame_times_s[k]) + "\n";
  io::WriteFileAtomic(output_dir / "frame_times.csv", times);

  const RoverSample& last = run.drive.samples.back();
  json head = util::SummaryHead("simulate", invocation);
  head["subcommand"] = "field-log";
  head["field_log"] = {{"options", o.ToJson()},
                       {"scenario", run.scenario.ToJson()},
                       {"telemetry", telemetry_options.ToJson()},
                       {"sensor_error_draws", run.draws.ToJson()},
                       {"telemetry_counts", run.CountsJson()},
                       {"wheel_radius_m", log.wheel_radius_m},
                       {"start_z_m", log.start_z_m},
                       {"frame_times_s", {{"first", log.frame_times_s.front()}, {"last", log.frame_times_s.back()}}},
                       {"outputs",
                        {"telemetry.csv", "sensors.json", "frame_times.csv", "truth/trajectory.csv",
                         "truth/trials.json", "truth/faults.csv"}}};
  const StereoSimSummary stereo = RenderStereoSequence(o.stereo, *scene, log.frame_poses, log.frame_times_s,
                                                       log.start_z_m, output_dir, head, scene_seconds);
  FieldLogSummary summary;
  summary.frames = frames;
  summary.telemetry_rows = run.raw.size();
  summary.distance_m = last.distance_m;
  summary.duration_s = last.t_s;
  summary.seconds = total.ElapsedSeconds();
  summary.summary_path = stereo.summary_path;
  return summary;
}

}  // namespace lunarnav::sim
