#include "positioning/baseline.h"

#include <cmath>

#include "util/check.h"

namespace lunarnav::positioning {

using telemetry::Channel;

PlainDeadReckoner::PlainDeadReckoner(const telemetry::SensorModel& model, const std::array<bool, 4>& wheels,
                                     bool gyro, double initial_heading_rad, double stationary_min_s)
    : wheels_(wheels), gyro_(gyro), stationary_min_s_(stationary_min_s) {
  LN_CHECK_ARG(stationary_min_s > 0) << "stationary time: must be > 0";
  const Channel channels[4] = {Channel::kEncoderFrontLeft, Channel::kEncoderFrontRight, Channel::kEncoderRearLeft,
                               Channel::kEncoderRearRight};
  for (int w = 0; w < 4; ++w) {
    if (!wheels_[w]) continue;
    ++wheel_count_;
    metres_per_count_[w] = model[channels[w]].MetresPerCount();
    period_[w] = std::ldexp(1.0, model[channels[w]].counter_bits);
  }
  if (wheel_count_ > 0) inverse_wheel_count_ = 1.0 / wheel_count_;
  if (gyro_) {
    gyro_radians_at_zero_ = model[Channel::kGyroZ].ToRadians(0.0);
    gyro_radians_per_count_ = model[Channel::kGyroZ].ToRadians(1.0) - gyro_radians_at_zero_;
  }
  pose_.heading_rad = initial_heading_rad;
  dir_x_ = std::sin(initial_heading_rad);
  dir_y_ = std::cos(initial_heading_rad);
  prev_dir_x_ = dir_x_;
  prev_dir_y_ = dir_y_;
}

// Turns the heading by d (rad). Inlined into Step.
[[gnu::always_inline]] inline void PlainDeadReckoner::Turn(double d) {
  pose_.heading_rad += d;
  if (std::abs(d) < 0.05) [[likely]] {  // rotate the direction by d: cos d, sin d to 1e-9
    const double d2 = d * d;
    const double c = 1.0 - d2 * (0.5 - d2 * (1.0 / 24.0)), s = d * (1.0 - d2 * (1.0 / 6.0));
    const double x = dir_x_ * c + dir_y_ * s, y = dir_y_ * c - dir_x_ * s;
    dir_x_ = x;
    dir_y_ = y;
    if (++rotations_ % 64 == 0) {  // back onto the unit circle (each rotation errs by < 1e-12)
      const double renorm = 1.5 - 0.5 * (x * x + y * y);
      dir_x_ = x * renorm;
      dir_y_ = y * renorm;
    }
  } else {
    dir_x_ = std::sin(pose_.heading_rad);
    dir_y_ = std::cos(pose_.heading_rad);
  }
}

// Called for every gyro sample once the rover has moved: inlined into Step.
[[gnu::always_inline]] inline void PlainDeadReckoner::UpdateHeading(double t_s, double rate_radps) {
  if (have_rate_ && t_s > last_gyro_t_) Turn(0.5 * (last_rate_ + rate_radps - 2.0 * bias_) * (t_s - last_gyro_t_));
  have_rate_ = true;
  last_rate_ = rate_radps;
  last_gyro_t_ = t_s;
}

// The first encoder sample that shows the wheels moving, the log having started at rest: the
// bias is the rest's mean reading (when the rest lasted stationary_min_s up to the last
// still sample), and the heading takes the readings held since that sample (the motion's
// start), from the rest's rate at the last reading at rest.
void PlainDeadReckoner::StartMoving() {
  moved_ever_ = true;
  const double rest_rate = bias_count_ > 0 ? bias_sum_ / static_cast<double>(bias_count_) : 0.0;
  if (bias_count_ > 0 && last_still_t_ - pose_start_t_ >= stationary_min_s_) {
    bias_ = rest_rate;
    bias_frozen_ = true;
  } else {  // too short a rest to tell the bias
    bias_sum_ = 0;
    bias_count_ = 0;
  }
  if (!gyro_) return;
  if (held_.count > 0) {
    double d = held_.integral - bias_ * (held_.last_t - held_.first_t);
    if (rest_gyro_seen_) {
      d += 0.5 * (rest_rate + held_.first_rate - 2.0 * bias_) * (held_.first_t - last_rest_gyro_t_);
    }
    Turn(d);
    last_rate_ = held_.last_rate;
    last_gyro_t_ = held_.last_t;
  } else {
    last_rate_ = rest_rate;
    last_gyro_t_ = last_rest_gyro_t_;
  }
  have_rate_ = held_.count > 0 || rest_gyro_seen_;
}

void PlainDeadReckoner::Step(double t_s, const std::array<double, 4>& encoder_counts, double gyro_count) {
  if (!started_) [[unlikely]] {
    started_ = true;
    pose_start_t_ = t_s;
    still_since_t_ = t_s;
    last_still_t_ = t_s;
  }
  // Wheels: unwrapped travel (a step of more than half the counter is a wrap); whether any
  // count changed.
  // (The sum in a local: the counts might alias a member sum, which the compiler would then
  // chain from wheel to wheel through a store and a load.)
  bool moved = false, sampled = false;
  double travel_sum = travel_sum_m_;
  for (int w = 0; w < 4; ++w) {
    const double count = encoder_counts[w];
    if (!wheels_[w] || std::isnan(count)) continue;
    sampled = true;
    if (have_count_[w]) [[likely]] {
      double d = count - last_count_[w];
      moved = moved || d != 0;
      const double half = 0.5 * period_[w];
      d -= period_[w] * (static_cast<double>(d > half) - static_cast<double>(d < -half));
      travel_sum += d * metres_per_count_[w];
    }
    have_count_[w] = true;
    last_count_[w] = count;
  }
  travel_sum_m_ = travel_sum;
  // While the bias is learnt, gyro readings since the last encoder sample are held until the
  // next one: the wheels were still up to a sample that shows no change, and started moving
  // after the last such sample when one shows a change. A turn from rest shows in the gyro up
  // to an encoder interval before the counts change; taken as rest it would enter the bias
  // and leave the heading.
  if (!bias_frozen_ && sampled) [[unlikely]] {
    if (moved) {
      if (!moved_ever_) StartMoving();
      held_ = HeldReadings();
    } else {  // still until now: the held readings were at rest
      bias_sum_ += held_.bias_sum;
      bias_count_ += held_.bias_count;
      if (!moved_ever_) {
        last_still_t_ = t_s;
        if (held_.count > 0) {
          last_rest_gyro_t_ = held_.last_t;
          rest_gyro_seen_ = true;
        }
      }
      held_ = HeldReadings();
    }
  }
  if (moved) {
    still_since_t_ = t_s;
    if (in_period_ && !bias_frozen_) [[unlikely]] {  // the end of the first stationary period
      in_period_ = false;
      if (bias_count_ > 0) {
        bias_ = bias_sum_ / static_cast<double>(bias_count_);
        bias_frozen_ = true;
      }
    }
  }
  // Gyro: the bias learnt while still (from the start, or the first stationary period).
  if (gyro_ && !std::isnan(gyro_count)) {
    const double rate = gyro_radians_at_zero_ + gyro_radians_per_count_ * gyro_count;
    if (bias_frozen_) [[likely]] {
      UpdateHeading(t_s, rate);
    } else {
      const bool known_still = wheel_count_ == 0 || (sampled && !moved);  // still at this very time
      const bool stationary = !moved && t_s - still_since_t_ >= stationary_min_s_;
      if (!moved_ever_ || stationary) {
        if (moved_ever_) in_period_ = true;
        if (known_still) {
          bias_sum_ += rate;
          ++bias_count_;
          if (!moved_ever_) {
            last_rest_gyro_t_ = t_s;
            rest_gyro_seen_ = true;
          }
        } else {  // the next encoder sample tells whether this was rest
          held_.bias_sum += rate;
          ++held_.bias_count;
        }
      }
      if (moved_ever_) {
        UpdateHeading(t_s, rate);
      } else if (!known_still) {  // kept for the heading, should it be the motion's start
        if (held_.count > 0) {
          held_.integral += 0.5 * (held_.last_rate + rate) * (t_s - held_.last_t);
        } else {
          held_.first_t = t_s;
          held_.first_rate = rate;
        }
        ++held_.count;
        held_.last_t = t_s;
        held_.last_rate = rate;
      }
    }
  }
  // Position: at rows with encoder samples, the wheels' mean travel since the last update
  // along the mean of the last and this direction.
  if (sampled && wheel_count_ > 0) {
    // (Scalars throughout: pairs read back whole after being stored apart cannot be
    // forwarded from the store buffer, which cost more than the rest of the step.)
    const double mean = travel_sum * inverse_wheel_count_;
    const double d = mean - mean_travel_m_;
    const double half_d = 0.5 * d;
    pose_.x_m += half_d * prev_dir_x_ + half_d * dir_x_;
    pose_.y_m += half_d * prev_dir_y_ + half_d * dir_y_;
    distance_m_ += std::abs(d);
    mean_travel_m_ = mean;
    prev_dir_x_ = dir_x_;
    prev_dir_y_ = dir_y_;
  }
  pose_.t_s = t_s;
}

}  // namespace lunarnav::positioning
