#include "sim/rover_motion.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "util/check.h"

namespace lunarnav::sim {
namespace {

constexpr double kDeg = M_PI / 180.0;
// Integration rate: at least this many steps per second.
constexpr double kMinStepRateHz = 100.0;
// Approach speeds near the end of a motion, so it always finishes.
constexpr double kCreepSpeedMps = 0.02;
constexpr double kCreepTurnRateDps = 0.5;
// Braking uses this fraction of the acceleration limit, so the limiter can follow it.
constexpr double kBrakeFraction = 0.8;
// Turn-slip bursts happen only while turning faster than this.
constexpr double kTurningDps = 2.0;
// A run of commands that never ends: refuse rather than loop forever (about 11.6 days).
constexpr double kMaxSimulatedSeconds = 1e6;

std::string Number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%g", v);
  return buf;
}

// Heights of the four contact points (FL, FR, RL, RR) of a rover centred at (x, y).
std::array<double, 4> ContactHeights(const HeightFunction& ground, const RoverOptions& o, double x, double y,
                                     double heading) {
  const double fx = std::sin(heading), fy = std::cos(heading);  // forward
  const double rx = std::cos(heading), ry = -std::sin(heading);  // right
  const double a = 0.5 * o.wheelbase_m, b = 0.5 * o.track_m;
  const std::array<double, 4> z = {ground(x + a * fx - b * rx, y + a * fy - b * ry),
                                   ground(x + a * fx + b * rx, y + a * fy + b * ry),
                                   ground(x - a * fx - b * rx, y - a * fy - b * ry),
                                   ground(x - a * fx + b * rx, y - a * fy + b * ry)};
  for (double h : z) LN_CHECK(std::isfinite(h)) << "the rover left its ground at (" << x << ", " << y << ")";
  return z;
}

struct Attitude {
  double pitch_left, pitch_right, pitch, roll, z;
};

Attitude AttitudeFrom(const std::array<double, 4>& z, const RoverOptions& o) {
  Attitude a;
  a.pitch_left = std::atan2(z[0] - z[2], o.wheelbase_m);
  a.pitch_right = std::atan2(z[1] - z[3], o.wheelbase_m);
  a.pitch = 0.5 * (a.pitch_left + a.pitch_right);
  a.roll = std::atan2(0.5 * (z[0] + z[2]) - 0.5 * (z[1] + z[3]), o.track_m);  // right side down +
  a.z = 0.25 * (z[0] + z[1] + z[2] + z[3]);
  return a;
}

// A first-order Gauss-Markov process with RMS sigma and correlation time tau, stepped by dt.
double GaussMarkovStep(double x, double sigma, double tau, double dt, double unit_normal) {
  const double phi = std::exp(-dt / tau);
  return phi * x + sigma * std::sqrt(1.0 - phi * phi) * unit_normal;
}

double Sign(double v) { return v < 0 ? -1.0 : 1.0; }

}  // namespace

std::string ToString(MotionKind kind) {
  switch (kind) {
    case MotionKind::kStraight: return "straight";
    case MotionKind::kArc: return "arc";
    case MotionKind::kTurnInPlace: return "turn_in_place";
    case MotionKind::kPause: return "pause";
  }
  return "unknown";
}

MotionCommand MotionCommand::Straight(double distance_m, double speed_mps) {
  MotionCommand c;
  c.kind = MotionKind::kStraight;
  c.distance_m = distance_m;
  c.speed_mps = speed_mps;
  return c;
}

MotionCommand MotionCommand::Arc(double radius_m, double angle_deg, double speed_mps) {
  MotionCommand c;
  c.kind = MotionKind::kArc;
  c.radius_m = radius_m;
  c.angle_deg = angle_deg;
  c.speed_mps = speed_mps;
  return c;
}

MotionCommand MotionCommand::TurnInPlace(double angle_deg, double turn_rate_dps) {
  MotionCommand c;
  c.kind = MotionKind::kTurnInPlace;
  c.angle_deg = angle_deg;
  c.turn_rate_dps = turn_rate_dps;
  return c;
}

MotionCommand MotionCommand::Pause(double duration_s) {
  MotionCommand c;
  c.kind = MotionKind::kPause;
  c.duration_s = duration_s;
  return c;
}

double MotionCommand::PathLength() const {
  if (kind == MotionKind::kStraight) return std::abs(distance_m);
  if (kind == MotionKind::kArc) return radius_m * std::abs(angle_deg) * kDeg;
  return 0.0;
}

std::string MotionCommand::Describe() const {
  const std::string side = angle_deg >= 0 ? " right" : " left";
  switch (kind) {
    case MotionKind::kStraight:
      return std::string(distance_m < 0 ? "reverse " : "straight ") + Number(std::abs(distance_m)) + " m at " +
             Number(speed_mps) + " m/s";
    case MotionKind::kArc:
      return "arc R " + Number(radius_m) + " m, " + Number(std::abs(angle_deg)) + " deg" + side + " at " +
             Number(speed_mps) + " m/s";
    case MotionKind::kTurnInPlace:
      return "turn in place " + Number(std::abs(angle_deg)) + " deg" + side + " at " + Number(turn_rate_dps) +
             " deg/s";
    case MotionKind::kPause: return "pause " + Number(duration_s) + " s";
  }
  return "unknown";
}

nlohmann::json MotionCommand::ToJson() const {
  nlohmann::json j = {{"kind", ToString(kind)}};
  switch (kind) {
    case MotionKind::kStraight:
      j["distance_m"] = distance_m;
      j["speed_mps"] = speed_mps;
      break;
    case MotionKind::kArc:
      j["radius_m"] = radius_m;
      j["angle_deg"] = angle_deg;
      j["speed_mps"] = speed_mps;
      break;
    case MotionKind::kTurnInPlace:
      j["angle_deg"] = angle_deg;
      j["turn_rate_dps"] = turn_rate_dps;
      break;
    case MotionKind::kPause: j["duration_s"] = duration_s; break;
  }
  if (kind != MotionKind::kPause) j["stop_at_end"] = stop_at_end;
  return j;
}

void MotionCommand::Validate() const {
  switch (kind) {
    case MotionKind::kStraight:
      LN_CHECK_ARG(std::isfinite(distance_m) && speed_mps > 0 && std::isfinite(speed_mps))
          << Describe() << ": needs a finite distance and a speed > 0";
      break;
    case MotionKind::kArc:
      LN_CHECK_ARG(radius_m > 0 && std::isfinite(radius_m) && std::isfinite(angle_deg) && speed_mps > 0 &&
                   std::isfinite(speed_mps))
          << Describe() << ": needs a radius > 0, a finite angle and a speed > 0";
      break;
    case MotionKind::kTurnInPlace:
      LN_CHECK_ARG(std::isfinite(angle_deg) && turn_rate_dps > 0 && std::isfinite(turn_rate_dps))
          << Describe() << ": needs a finite angle and a turn rate > 0";
      break;
    case MotionKind::kPause:
      LN_CHECK_ARG(duration_s >= 0 && std::isfinite(duration_s)) << Describe() << ": needs a duration >= 0";
      break;
  }
}

RoverOptions RoverOptions::Scaled(double scale) const {
  RoverOptions o = *this;
  o.skid_track_factor = 1.0 + scale * (skid_track_factor - 1.0);
  o.icr_offset_m *= scale;
  o.slip_mean *= scale;
  o.slip_slope_gain *= scale;
  o.wheel_slip_sigma *= scale;
  o.turn_slip_size *= scale;
  o.yaw_disturbance_per_m *= scale;
  return o;
}

void RoverOptions::Validate() const {
  LN_CHECK_ARG(track_m > 0 && wheelbase_m > 0) << "rover: track and wheelbase must be > 0";
  LN_CHECK_ARG(max_accel_mps2 > 0 && max_turn_accel_dps2 > 0) << "rover: acceleration limits must be > 0";
  LN_CHECK_ARG(skid_track_factor >= 1) << "rover: skid track factor must be >= 1";
  LN_CHECK_ARG(icr_offset_m >= 0 && slip_slope_gain >= 0 && wheel_slip_sigma >= 0 && turn_slip_rate_hz >= 0 &&
               turn_slip_size >= 0 && turn_slip_duration_s >= 0 && yaw_disturbance_per_m >= 0)
      << "rover: slip terms must be >= 0";
  LN_CHECK_ARG(slip_mean >= 0 && slip_mean < 0.5) << "rover: mean slip must be in [0, 0.5)";
  LN_CHECK_ARG(wheel_slip_tau_s > 0 && yaw_disturbance_tau_s > 0) << "rover: correlation times must be > 0";
}

nlohmann::json RoverOptions::ToJson() const {
  return {{"track_m", track_m},
          {"wheelbase_m", wheelbase_m},
          {"max_accel_mps2", max_accel_mps2},
          {"max_turn_accel_dps2", max_turn_accel_dps2},
          {"skid_track_factor", skid_track_factor},
          {"icr_offset_m", icr_offset_m},
          {"slip_mean", slip_mean},
          {"slip_slope_gain", slip_slope_gain},
          {"wheel_slip_sigma", wheel_slip_sigma},
          {"wheel_slip_tau_s", wheel_slip_tau_s},
          {"turn_slip_rate_hz", turn_slip_rate_hz},
          {"turn_slip_size", turn_slip_size},
          {"turn_slip_duration_s", turn_slip_duration_s},
          {"yaw_disturbance_per_m", yaw_disturbance_per_m},
          {"yaw_disturbance_tau_s", yaw_disturbance_tau_s}};
}

RoverAttitude RoverAttitudeOn(const HeightFunction& ground, const RoverOptions& rover, double x_m, double y_m,
                              double heading_rad) {
  const Attitude a = AttitudeFrom(ContactHeights(ground, rover, x_m, y_m, heading_rad), rover);
  return {a.z, a.pitch, a.roll, a.pitch_left, a.pitch_right};
}

RoverDrive DriveRover(const std::vector<MotionCommand>& commands, const RoverOptions& o, const GroundSurface& ground,
                      double initial_heading_deg, double rate_hz, std::optional<double> duration_s,
                      std::uint64_t seed) {
  return DriveRover(
      commands, o, [&ground](double x, double y) { return ground.HeightAt(x, y); }, initial_heading_deg, rate_hz,
      duration_s, seed);
}

RoverDrive DriveRover(const std::vector<MotionCommand>& commands, const RoverOptions& o, const HeightFunction& ground,
                      double initial_heading_deg, double rate_hz, std::optional<double> duration_s,
                      std::uint64_t seed) {
  o.Validate();
  for (const MotionCommand& c : commands) c.Validate();
  LN_CHECK_ARG(rate_hz > 0 && std::isfinite(rate_hz)) << "sample rate: must be > 0 Hz";
  LN_CHECK_ARG(std::isfinite(initial_heading_deg)) << "initial heading: not finite";
  LN_CHECK_ARG(!duration_s || (*duration_s >= 0 && *duration_s <= kMaxSimulatedSeconds))
      << "duration: must be in [0, " << kMaxSimulatedSeconds << "] s";
  const long substeps = std::max(1L, static_cast<long>(std::ceil(kMinStepRateHz / rate_hz)));
  const double steps_per_second = rate_hz * static_cast<double>(substeps);
  const double dt = 1.0 / steps_per_second;
  const double accel_step = o.max_accel_mps2 * dt;
  const double turn_accel_step = o.max_turn_accel_dps2 * kDeg * dt;
  const double brake = kBrakeFraction * o.max_accel_mps2;
  const double turn_brake = kBrakeFraction * o.max_turn_accel_dps2 * kDeg;
  PortableRandom rng(seed, "rover");

  // State.
  double x = 0, y = 0, heading = initial_heading_deg * kDeg, v = 0, w = 0, accel = 0, turn_accel = 0;
  double distance = 0;
  std::array<double, 4> wheel{}, wheel_slip{}, burst_left{};
  double yaw_curvature = 0;
  const double z0 = AttitudeFrom(ContactHeights(ground, o, 0, 0, heading), o).z;

  // Command progress.
  std::size_t cmd = 0;
  double progress = 0, elapsed = 0;  // metres or radians along the command; seconds
  bool stopping = false;

  // Trials: runs of motion commands between pauses.
  struct PendingTrial {
    int first = 0, last = 0;
    double start_t = 0;
    std::optional<double> end_t;
  };
  std::vector<PendingTrial> runs;
  bool run_active = false, waiting_for_rest = false;
  auto begin_command = [&](double t) {
    progress = elapsed = 0;
    stopping = false;
    const bool motion = cmd < commands.size() && commands[cmd].kind != MotionKind::kPause;
    if (motion && !run_active) {
      runs.push_back({static_cast<int>(cmd), static_cast<int>(cmd), t, std::nullopt});
      run_active = true;
    } else if (!motion && run_active) {
      run_active = false;
      waiting_for_rest = true;
    }
    if (motion) runs.back().last = static_cast<int>(cmd);
  };

  RoverDrive out;
  auto record = [&](double t) {
    RoverSample s;
    s.t_s = t;
    s.x_m = x;
    s.y_m = y;
    s.heading_rad = heading;
    const Attitude a = AttitudeFrom(ContactHeights(ground, o, x, y, heading), o);
    s.z_m = a.z - z0;
    s.pitch_rad = a.pitch;
    s.roll_rad = a.roll;
    s.pitch_left_rad = a.pitch_left;
    s.pitch_right_rad = a.pitch_right;
    s.speed_mps = v;
    s.accel_mps2 = accel;
    s.turn_rate_radps = w;
    s.turn_accel_radps2 = turn_accel;
    s.distance_m = distance;
    s.wheel_m = wheel;
    s.command = cmd < commands.size() ? static_cast<int>(cmd) : -1;
    out.samples.push_back(s);
  };

  begin_command(0.0);
  record(0.0);
  const std::size_t max_samples =
      duration_s ? static_cast<std::size_t>(std::floor(*duration_s * rate_hz + 1e-9)) + 1
                 : static_cast<std::size_t>(kMaxSimulatedSeconds * rate_hz) + 1;
  long step = 0;
  for (std::size_t k = 1; k < max_samples; ++k) {
    if (!duration_s && cmd >= commands.size() && v == 0 && w == 0 && !waiting_for_rest) break;
    for (long j = 0; j < substeps; ++j) {
      ++step;
      const double t = static_cast<double>(step) / steps_per_second;
      // 1. What the commands ask for.
      double v_cmd = 0, w_cmd = 0, dir = 1;
      const MotionCommand* c = cmd < commands.size() ? &commands[cmd] : nullptr;
      if (c != nullptr && (c->kind == MotionKind::kStraight || c->kind == MotionKind::kArc)) {
        dir = c->kind == MotionKind::kStraight ? Sign(c->distance_m) : 1.0;
        const double remaining = std::max(0.0, c->PathLength() - progress);
        double speed = stopping ? 0.0 : c->speed_mps;
        if (c->stop_at_end && !stopping) speed = std::min(speed, std::max(kCreepSpeedMps, std::sqrt(2 * brake * remaining)));
        v_cmd = dir * speed;
        const double curvature = c->kind == MotionKind::kArc ? Sign(c->angle_deg) / c->radius_m : 0.0;
        w_cmd = (curvature + yaw_curvature) * v;  // steering holds a curvature
      } else if (c != nullptr && c->kind == MotionKind::kTurnInPlace) {
        dir = Sign(c->angle_deg);
        const double remaining = std::max(0.0, std::abs(c->angle_deg) * kDeg - progress);
        double rate = stopping ? 0.0 : c->turn_rate_dps * kDeg;
        if (c->stop_at_end && !stopping) {
          rate = std::min(rate, std::max(kCreepTurnRateDps * kDeg, std::sqrt(2 * turn_brake * remaining)));
        }
        w_cmd = dir * rate;
      }
      // 2. Within the vehicle's acceleration limits.
      const double v_new = v + std::clamp(v_cmd - v, -accel_step, accel_step);
      const double w_new = w + std::clamp(w_cmd - w, -turn_accel_step, turn_accel_step);
      accel = (v_new - v) * steps_per_second;
      turn_accel = (w_new - w) * steps_per_second;
      // 3. The body moves: along the ground at the mean speed, sliding outwards on turns.
      const double v_mid = 0.5 * (v + v_new), w_mid = 0.5 * (w + w_new);
      const double pitch = AttitudeFrom(ContactHeights(ground, o, x, y, heading), o).pitch;
      const double h_mid = heading + 0.5 * w_mid * dt;
      const double forward = v_mid * std::cos(pitch), lateral = -o.icr_offset_m * w_mid;  // right +
      x += (forward * std::sin(h_mid) + lateral * std::cos(h_mid)) * dt;
      y += (forward * std::cos(h_mid) - lateral * std::sin(h_mid)) * dt;
      heading += w_mid * dt;
      distance += std::abs(v_mid) * dt;
      if (c != nullptr && c->kind == MotionKind::kTurnInPlace) progress += dir * w_mid * dt;
      else progress += dir * v_mid * dt;
      // 4. The wheels: skid-steer side speeds, each wheel slipping on its own.
      const double half_spread = 0.5 * o.skid_track_factor * o.track_m * w_mid;
      const double climbing = std::max(0.0, std::sin(pitch) * Sign(v_mid));
      const bool turning = std::abs(w_mid) > kTurningDps * kDeg;
      for (int i = 0; i < 4; ++i) {
        const double side = (i % 2 == 0) ? v_mid + half_spread : v_mid - half_spread;  // left: 0, 2
        wheel_slip[i] = GaussMarkovStep(wheel_slip[i], o.wheel_slip_sigma, o.wheel_slip_tau_s, dt, rng.Normal());
        if (turning && burst_left[i] <= 0 && rng.Uniform() < o.turn_slip_rate_hz * dt) {
          burst_left[i] = o.turn_slip_duration_s;
        }
        const double burst = burst_left[i] > 0 ? o.turn_slip_size : 0.0;
        burst_left[i] -= dt;
        const double slip = o.slip_mean + o.slip_slope_gain * climbing + wheel_slip[i] + burst;
        wheel[i] += side * (1.0 + slip) * dt;
      }
      yaw_curvature =
          GaussMarkovStep(yaw_curvature, o.yaw_disturbance_per_m, o.yaw_disturbance_tau_s, dt, rng.Normal());
      v = v_new;
      w = w_new;
      // 5. Is the command done?
      bool done = false;
      if (c != nullptr) {
        elapsed += dt;
        const bool at_rest = v == 0 && w == 0;
        if (c->kind == MotionKind::kPause) {
          done = elapsed >= c->duration_s - 1e-9 && at_rest;
        } else {
          const double goal = c->kind == MotionKind::kTurnInPlace ? std::abs(c->angle_deg) * kDeg : c->PathLength();
          if (!stopping && progress >= goal) {
            if (c->stop_at_end) stopping = true;
            else done = true;
          }
          if (stopping && at_rest) done = true;
        }
      }
      if (waiting_for_rest && v == 0 && w == 0) {
        runs.back().end_t = t;
        waiting_for_rest = false;
      }
      if (done) {
        ++cmd;
        ++out.commands_completed;
        begin_command(t);
        if (waiting_for_rest && v == 0 && w == 0) {
          runs.back().end_t = t;
          waiting_for_rest = false;
        }
      }
    }
    record(static_cast<double>(step) / steps_per_second);
  }
  LN_CHECK_ARG(duration_s || cmd >= commands.size())
      << "the commands take longer than " << kMaxSimulatedSeconds << " s";

  // Runs to trials, in samples.
  const std::size_t last = out.samples.size() - 1;
  for (std::size_t r = 0; r < runs.size(); ++r) {
    const PendingTrial& p = runs[r];
    const double end_index = p.end_t ? std::ceil(*p.end_t * rate_hz - 1e-6) : 0.0;
    if (!p.end_t || end_index > static_cast<double>(last)) {
      ++out.trials_truncated;
      continue;
    }
    RoverTrial trial;
    trial.first_command = p.first;
    trial.last_command = p.last;
    trial.start_sample = static_cast<std::size_t>(std::floor(p.start_t * rate_hz + 1e-6));
    trial.end_sample = static_cast<std::size_t>(end_index);
    trial.rest_until_sample =
        r + 1 < runs.size()
            ? std::max(trial.end_sample,
                       std::min(last, static_cast<std::size_t>(std::floor(runs[r + 1].start_t * rate_hz + 1e-6))))
            : last;
    if (p.first == p.last) {
      trial.description = commands[p.first].Describe();
    } else {
      double length = 0;
      for (int i = p.first; i <= p.last; ++i) length += commands[i].PathLength();
      trial.description = std::to_string(p.last - p.first + 1) + " segments, " + Number(std::round(length * 10) / 10) +
                          " m commanded";
    }
    out.trials.push_back(trial);
  }
  return out;
}

}  // namespace lunarnav::sim
