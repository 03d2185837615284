// A skid-steered four-wheel rover (the paper's Ratler) driving commanded motions over a
// height field: the ground-truth pose at every sample and each wheel's rim travel (what its
// drive encoder turns through, slip included).
//
// Frames and angles as in positioning/dead_reckoning.h: x east, y north, z up (metres), the
// origin at the start pose; heading clockwise from north; pitch nose up; roll right side
// down. The body is articulated (Krotkov & Hebert sec. 1): the left and right halves each
// carry two wheels and pitch on their own, so the left and right body pitch follow the
// ground under their own wheels and roll follows the height difference between the sides.
#pragma once

#include <array>
#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "sim/portable_random.h"
#include "sim/ground_surface.h"

namespace lunarnav::sim {

enum class MotionKind {
  kStraight,     ///< Drive distance_m straight ahead (negative: reverse).
  kArc,          ///< Drive an arc of radius_m turning angle_deg (positive: right).
  kTurnInPlace,  ///< Skid-steer on the spot by angle_deg (positive: right).
  kPause         ///< Stand still for duration_s.
};
std::string ToString(MotionKind kind);

/// One commanded motion, as an operator would type it.
struct MotionCommand {
  MotionKind kind = MotionKind::kPause;
  double distance_m = 0.0;      ///< Straight: path length, metres; negative = reverse.
  double radius_m = 0.0;        ///< Arc: radius, metres, > 0.
  double angle_deg = 0.0;       ///< Arc, turn in place: heading change, positive = right.
  double speed_mps = 0.4;       ///< Straight, arc: cruise speed, m/s, > 0.
  double turn_rate_dps = 10.0;  ///< Turn in place: cruise turn rate, deg/s, > 0.
  double duration_s = 0.0;      ///< Pause: seconds, >= 0.
  /// Come to rest at the end (else roll into the next command at speed).
  bool stop_at_end = true;

  static MotionCommand Straight(double distance_m, double speed_mps);
  static MotionCommand Arc(double radius_m, double angle_deg, double speed_mps);
  static MotionCommand TurnInPlace(double angle_deg, double turn_rate_dps);
  static MotionCommand Pause(double duration_s);
  /// Path length of a straight or arc (arc: radius x angle), metres; 0 otherwise.
  double PathLength() const;
  /// E.g. "straight 4 m at 0.4 m/s", "arc R 5 m, 90 deg right at 0.3 m/s".
  std::string Describe() const;
  nlohmann::json ToJson() const;
  void Validate() const;
};

/// The vehicle and how its wheels slip. Slip terms are fractions of a wheel's speed: its
/// rim (what the encoder counts) turns that much further than the ground under it moves.
struct RoverOptions {
  double track_m = 0.84;           ///< Between the left and right wheels' contact lines, > 0.
  double wheelbase_m = 0.80;       ///< Between the front and rear axles, > 0.
  double max_accel_mps2 = 0.3;     ///< Speed changes at most this fast, > 0.
  double max_turn_accel_dps2 = 20.0;  ///< Turn rate changes at most this fast, > 0.
  /// Skid steering: the wheels' speeds differ by turn rate x chi x track (chi >= 1: the
  /// wheels slip sideways, so they must turn more than a differential drive would).
  double skid_track_factor = 1.5;
  /// Lateral slip while turning: the body slides outwards at icr_offset_m x turn rate (m/s
  /// per rad/s), >= 0.
  double icr_offset_m = 0.05;
  double slip_mean = 0.03;         ///< Longitudinal slip of every wheel, fraction, [0, 0.5).
  double slip_slope_gain = 0.2;    ///< Extra slip per unit sin(pitch) climbing, >= 0.
  double wheel_slip_sigma = 0.02;  ///< Per-wheel slip variation (Gauss-Markov), RMS fraction.
  double wheel_slip_tau_s = 2.0;   ///< Its correlation time, > 0.
  /// While turning (more than 2 deg/s), each wheel starts a burst of spinning at this rate
  /// (per second): slip grows by turn_slip_size for turn_slip_duration_s.
  double turn_slip_rate_hz = 0.05;
  double turn_slip_size = 0.4;
  double turn_slip_duration_s = 1.0;
  /// Path wander: a random curvature (Gauss-Markov), RMS 1/m, that turns the rover even on
  /// straight commands (uneven ground, motor controllers that disagree).
  double yaw_disturbance_per_m = 0.005;
  double yaw_disturbance_tau_s = 3.0;
  /// Every slip and disturbance term multiplied by `scale` (0: the wheels roll without slip
  /// and the rover goes exactly where commanded, up to its acceleration limits).
  RoverOptions Scaled(double scale) const;
  void Validate() const;
  nlohmann::json ToJson() const;
};

/// The true state at one sample.
struct RoverSample {
  double t_s = 0;
  double x_m = 0, y_m = 0, z_m = 0;  ///< Centre of the wheels' contact points, origin at start.
  double heading_rad = 0;            ///< Continuous (not wrapped), clockwise from north.
  double pitch_rad = 0;              ///< Mean of the left and right body pitch.
  double roll_rad = 0;
  double pitch_left_rad = 0, pitch_right_rad = 0;
  double speed_mps = 0;              ///< Along the ground, signed (negative reversing).
  double accel_mps2 = 0;             ///< d(speed)/dt.
  double turn_rate_radps = 0;        ///< d(heading)/dt, positive turning right.
  double turn_accel_radps2 = 0;      ///< d(turn rate)/dt.
  double distance_m = 0;             ///< Path length so far, along the ground.
  /// Cumulative rim travel of each wheel (front left, front right, rear left, rear right),
  /// metres, signed (forward positive): what the encoders measure.
  std::array<double, 4> wheel_m{};
  int command = -1;                  ///< Index of the command being executed (-1: none left).
};

/// A commanded motion from rest to rest: one or more consecutive motion commands between
/// pauses (a trial of the paper's Figure 7, or one leg of a traverse).
struct RoverTrial {
  int first_command = 0, last_command = 0;
  std::size_t start_sample = 0;      ///< Last sample at rest before the motion.
  std::size_t end_sample = 0;        ///< First sample at rest after it.
  std::size_t rest_until_sample = 0; ///< Last sample before the next motion (or of the log).
  std::string description;
};

struct RoverDrive {
  std::vector<RoverSample> samples;  ///< At t = k / rate, k = 0, 1, ...
  std::vector<RoverTrial> trials;    ///< Complete ones only.
  int commands_completed = 0;
  int trials_truncated = 0;          ///< Motions cut by the end of the log.
};

/// The ground a rover drives on: height (metres) at world (x, y); finite wherever it drives.
using HeightFunction = std::function<double(double x_m, double y_m)>;

/// Where the body of a rover standing at (x_m, y_m) with `heading_rad` sits on `ground`:
/// its wheels' contact points (front and rear axles wheelbase_m apart, sides track_m apart)
/// on the ground; z_m the mean of their heights (the vehicle frame's origin), the pitch of
/// each side, their mean, and the roll from the sides' mean heights, with DriveRover's signs.
struct RoverAttitude {
  double z_m = 0, pitch_rad = 0, roll_rad = 0, pitch_left_rad = 0, pitch_right_rad = 0;
};
RoverAttitude RoverAttitudeOn(const HeightFunction& ground, const RoverOptions& rover, double x_m, double y_m,
                              double heading_rad);

/// Drives `commands` in order, starting at rest at the origin with `initial_heading_deg`,
/// integrating at 100 Hz or faster and sampling at `rate_hz`. The speed and turn rate
/// follow the commands within the acceleration limits; a straight or arc ends when its path
/// length is covered, a turn in place when its heading change is reached (the true end pose
/// differs from the commanded one by the wander and slip, as on a real vehicle).
/// @param duration_s  length of the log; std::nullopt: until the commands are done.
/// @param seed        seeds the slip and wander ("rover" stream).
/// Sample z is relative to the start pose's (z = 0 at t = 0).
RoverDrive DriveRover(const std::vector<MotionCommand>& commands, const RoverOptions& rover,
                      const HeightFunction& ground, double initial_heading_deg, double rate_hz,
                      std::optional<double> duration_s, std::uint64_t seed);
/// The same on a GroundSurface.
RoverDrive DriveRover(const std::vector<MotionCommand>& commands, const RoverOptions& rover,
                      const GroundSurface& ground, double initial_heading_deg, double rate_hz,
                      std::optional<double> duration_s, std::uint64_t seed);

}  // namespace lunarnav::sim
