// 3-D dead reckoning of Krotkov & Hebert sec. 4.2.
#pragma once

#include <array>
#include <cmath>
#include <vector>

#include "positioning/attitude.h"

namespace lunarnav::positioning {

/// One pose of a trajectory. Frame: x east, y north, z up (ENU), origin at the start.
/// heading: compass convention, clockwise from north; pitch: nose up positive; roll: right
/// side down positive.
struct TrajectorySample {
  double t_s = 0;
  double x_m = 0, y_m = 0, z_m = 0;
  double heading_rad = 0, pitch_rad = 0, roll_rad = 0;
  double speed_mps = 0;
};

/// Inputs, one entry per time step.
struct DeadReckoningInputs {
  std::vector<double> t_s;
  std::vector<double> heading_rad;   ///< Filtered heading (continuous or wrapped).
  std::vector<double> pitch_rad;     ///< Filtered pitch (mean of left and right); empty = flat.
  std::vector<double> roll_rad;      ///< Filtered roll; empty = 0.
  /// Cumulative travel of each wheel, metres (NaN where missing); absent wheels are empty.
  std::array<std::vector<double>, 4> wheel_m;
  /// Each wheel's encoder resolution, metres per count (0 = unknown): the slip test's
  /// tolerance never falls below the quantisation of the travel it compares.
  std::array<double, 4> wheel_resolution_m{};
};

struct DeadReckoningOptions {
  /// Slip test. Each wheel's travel over the last slip_window_s (at least one step) is
  /// compared with the median of the wheels' travels over the same window; a wheel that
  /// differs by more than the tolerance max(slip_min_m, slip_fraction * |median|,
  /// slip_resolution_counts * resolution) has its step down-weighted (weight = (tolerance /
  /// excess)^2) and counted as slipping when its weight falls below one half. resolution is
  /// the coarsest wheel's metres per count: a travel read from two quantised counts is off by
  /// less than a count, so quantisation alone is (almost) never taken for slip, and because
  /// the window's travels telescope, every wheel weighted 1 gives exactly the wheels' mean
  /// travel, whatever the resolution.
  double slip_fraction = 0.2;
  double slip_min_m = 0.01;
  double slip_window_s = 1.0;
  double slip_resolution_counts = 1.0;
  void Validate() const;
};

struct DeadReckoningResult {
  std::vector<TrajectorySample> trajectory;  ///< Empty when the poses went to a sink instead.
  TrajectorySample last_pose;   ///< The final pose (when there was a sample).
  double distance_m = 0;        ///< Path length.
  long slip_events = 0;         ///< Wheel-steps down-weighted below one half.
  long steps_without_odometry = 0;
};

/// The dead reckoning sample by sample, for pipelines that stream a log instead of holding it
/// whole: DeadReckon is a loop over Step, and gives the same numbers.
class DeadReckoner {
 public:
  /// `wheels`: which of the four wheels (front left, front right, rear left, rear right) the
  /// log has; `resolution_m`: their metres per count (see DeadReckoningInputs). Validates the
  /// options.
  DeadReckoner(const DeadReckoningOptions& options, const std::array<bool, 4>& wheels,
               const std::array<double, 4>& resolution_m);

  /// The next sample, in time order; wheel_m: the wheels' cumulative travel (NaN: missing;
  /// absent wheels are not read). Returns the pose at t_s (the first sample: the origin).
  const TrajectorySample& Step(double t_s, double heading_rad, double pitch_rad, double roll_rad,
                               const std::array<double, 4>& wheel_m);

  /// The half angles of the last pose's heading and pitch (the step's mean heading and pitch
  /// are made from them and the previous pose's), for its attitude: EnuFromBody.
  const HalfAngle& half_heading() const { return half_heading_; }
  const HalfAngle& half_pitch() const { return half_pitch_; }

  double distance_m() const { return distance_m_ + std::abs(pending_m_); }  ///< Path length so far.
  long slip_events() const { return slip_events_; }
  long steps_without_odometry() const { return steps_without_odometry_; }

 private:
  struct Sample {  // what the slip window remembers of a step
    double t_s;
    std::array<double, 4> wheel_m;
  };
  DeadReckoningOptions o_;
  std::array<bool, 4> wheels_;
  double resolution_m_ = 0, resolution_tolerance_ = 0;
  TrajectorySample pose_;
  HalfAngle half_heading_, half_pitch_;  // of pose_
  HalfAngleTracker heading_half_, pitch_half_;
  bool started_ = false;
  // The samples of the slip window, oldest first: a ring of power-of-two size.
  std::vector<Sample> window_;
  std::size_t window_begin_ = 0, window_size_ = 0;
  double pending_m_ = 0;  // travel not yet added to the path length
  double distance_m_ = 0;
  long slip_events_ = 0, steps_without_odometry_ = 0;
};

/// Integrates x += D cos(phi) sin(psi), y += D cos(phi) cos(psi), z += D sin(phi) (the paper's
/// x += D cos(theta) cos(phi), y += D sin(theta) cos(phi), z += D sin(phi) with its x north and
/// y east), D the slip-weighted mean of the wheels' steps and psi, phi the mean heading and
/// pitch over the step.
DeadReckoningResult DeadReckon(const DeadReckoningInputs& inputs, const DeadReckoningOptions& options);

}  // namespace lunarnav::positioning
