// The plain dead-reckoning baseline posfilter computes beside its filtered trajectory: the
// same decoded counts integrated as simply as they can be, to show what screening and
// filtering add (docs/posfilter.md, "Baseline").
#pragma once

#include <array>

#include "positioning/dead_reckoning.h"
#include "telemetry/sensor_model.h"

namespace lunarnav::positioning {

/// Plain 2-D dead reckoning from raw counts: no screening, no filtering. D is the mean of the
/// wheels' travel (encoder counters unwrapped), the heading the gyro integrated at its own
/// rate (trapezoids between its samples) minus its bias, the bias being the mean reading over
/// the first stationary period (the wheels still for stationary_min_s or more, from the start
/// when the log starts so; a period ends at the last encoder sample that shows the wheels
/// still: gyro readings after it are held until the next encoder sample says whether they
/// were rest or the motion's start); x += D sin(psi), y += D cos(psi) with psi the mean
/// heading over the step, z = 0. Without a gyro the heading stays at the start's.
/// Cheap: a few additions a row and no trigonometric call for small heading changes.
class PlainDeadReckoner {
 public:
  /// `wheels`: which encoders (front left, front right, rear left, rear right) are used;
  /// `gyro`: whether the gyro is; `initial_heading_rad`: the start heading (the filtered
  /// trajectory's, so the two can be compared).
  PlainDeadReckoner(const telemetry::SensorModel& model, const std::array<bool, 4>& wheels, bool gyro,
                    double initial_heading_rad, double stationary_min_s);

  /// One row, in time order: its time stamp and raw counts (NaN: no sample in this row).
  void Step(double t_s, const std::array<double, 4>& encoder_counts, double gyro_count);

  const TrajectorySample& pose() const { return pose_; }
  double distance_m() const { return distance_m_; }
  /// The bias used (rad/s) and whether a stationary period gave it (else 0 was used).
  double gyro_bias_radps() const { return bias_; }
  bool gyro_bias_known() const { return bias_frozen_; }

 private:
  void Turn(double d_rad);
  void UpdateHeading(double t_s, double rate_radps);
  void StartMoving();
  // Gyro readings since the last encoder sample, while the bias is learnt: rest or motion,
  // as the next encoder sample tells.
  struct HeldReadings {
    double bias_sum = 0;   // of those that count for the bias if they were at rest
    long bias_count = 0;
    long count = 0;        // before the first motion: all of them, for the heading
    double first_t = 0, first_rate = 0, last_t = 0, last_rate = 0;
    double integral = 0;   // trapezoids between them (rad)
  };
  HeldReadings held_;
  std::array<bool, 4> wheels_;
  bool gyro_;
  int wheel_count_ = 0;
  double inverse_wheel_count_ = 0;
  std::array<double, 4> metres_per_count_{}, period_{}, last_count_{};
  double travel_sum_m_ = 0;  // the wheels' travel, summed
  std::array<bool, 4> have_count_{};
  double gyro_radians_at_zero_ = 0, gyro_radians_per_count_ = 0;
  double stationary_min_s_;
  TrajectorySample pose_;
  bool started_ = false;
  double pose_start_t_ = 0;
  double mean_travel_m_ = 0;        // at the last position update
  double dir_x_ = 0, dir_y_ = 1;    // sin and cos of pose_.heading_rad
  double prev_dir_x_ = 0, prev_dir_y_ = 1;  // at the last row with encoder samples
  unsigned rotations_ = 0;
  double still_since_t_ = 0;        // wheels unchanged since
  double last_still_t_ = 0;         // before the first motion: the last encoder sample still
  double last_rest_gyro_t_ = 0;     // before the first motion: the last gyro reading at rest
  bool rest_gyro_seen_ = false;
  bool moved_ever_ = false;
  double bias_sum_ = 0;
  long bias_count_ = 0;
  bool bias_frozen_ = false, in_period_ = false;
  double bias_ = 0;
  bool have_rate_ = false;
  double last_rate_ = 0, last_gyro_t_ = 0;
  double distance_m_ = 0;
};

}  // namespace lunarnav::positioning
