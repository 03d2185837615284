// 3-D dead reckoning of Krotkov & Hebert sec. 4.2.
#pragma once

#include <array>
#include <vector>

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
};

struct DeadReckoningOptions {
  /// A wheel whose step differs from the median of the wheels by more than
  /// max(slip_min_m, slip_fraction * |median|) is down-weighted (weight = (tolerance /
  /// excess)^2) and counted as slipping when its weight falls below one half.
  double slip_fraction = 0.2;
  double slip_min_m = 0.01;
};

struct DeadReckoningResult {
  std::vector<TrajectorySample> trajectory;
  double distance_m = 0;        ///< Path length.
  long slip_events = 0;         ///< Wheel-steps down-weighted below one half.
  long steps_without_odometry = 0;
};

/// Integrates x += D cos(phi) sin(psi), y += D cos(phi) cos(psi), z += D sin(phi) (the paper's
/// x += D cos(theta) cos(phi), y += D sin(theta) cos(phi), z += D sin(phi) with its x north and
/// y east), D the slip-weighted mean of the wheels' steps and psi, phi the mean heading and
/// pitch over the step.
DeadReckoningResult DeadReckon(const DeadReckoningInputs& inputs, const DeadReckoningOptions& options);

}  // namespace lunarnav::positioning
