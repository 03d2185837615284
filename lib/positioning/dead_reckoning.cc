#include "positioning/dead_reckoning.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "util/check.h"

namespace lunarnav::positioning {
namespace {

// The median of the first `count` values (reorders them).
double Median(std::array<double, 4>& v, int count) {
  if (count == 4) {  // the usual case, by a sorting network: the two middle values
    const double lo01 = std::min(v[0], v[1]), hi01 = std::max(v[0], v[1]);
    const double lo23 = std::min(v[2], v[3]), hi23 = std::max(v[2], v[3]);
    return 0.5 * (std::max(lo01, lo23) + std::min(hi01, hi23));
  }
  std::sort(v.begin(), v.begin() + count);
  return count % 2 == 1 ? v[count / 2] : 0.5 * (v[count / 2 - 1] + v[count / 2]);
}

// Half the smallest left-minus-right difference of `value` when every left-right pair
// differs in the same sign, else 0 (no turn, or no wheel on one side).
double TurnShare(const std::array<double, 4>& value, const std::array<double, 4>& side, int count) {
  if (count == 4 && side[0] > 0 && side[1] < 0 && side[2] > 0 && side[3] < 0) {
    // All four wheels (left, right, left, right), the usual case: the four left-right pairs
    // at once, the same result as the loop below.
    const double d[4] = {value[0] - value[1], value[0] - value[3], value[2] - value[1], value[2] - value[3]};
    const bool positive = d[0] > 0 && d[1] > 0 && d[2] > 0 && d[3] > 0;
    const bool negative = d[0] < 0 && d[1] < 0 && d[2] < 0 && d[3] < 0;
    if (!positive && !negative) return 0.0;
    const double smallest =
        std::min(std::min(std::abs(d[0]), std::abs(d[1])), std::min(std::abs(d[2]), std::abs(d[3])));
    return 0.5 * (positive ? 1 : -1) * smallest;
  }
  double smallest = std::numeric_limits<double>::infinity();
  int sign = 0;
  for (int a = 0; a < count; ++a) {
    if (side[a] < 0) continue;
    for (int b = 0; b < count; ++b) {
      if (side[b] > 0) continue;
      const double diff = value[a] - value[b];
      const int s = diff > 0 ? 1 : diff < 0 ? -1 : 0;
      if (s == 0 || (sign != 0 && s != sign)) return 0.0;
      sign = s;
      smallest = std::min(smallest, std::abs(diff));
    }
  }
  return sign == 0 ? 0.0 : 0.5 * sign * smallest;
}

}  // namespace

void DeadReckoningOptions::Validate() const {
  LN_CHECK_ARG(slip_fraction > 0 && slip_min_m > 0) << "slip tolerances: must be > 0";
  LN_CHECK_ARG(slip_window_s >= 0 && std::isfinite(slip_window_s)) << "slip window: must be >= 0 s";
  LN_CHECK_ARG(slip_resolution_counts >= 0 && std::isfinite(slip_resolution_counts))
      << "slip resolution: must be >= 0 counts";
}

DeadReckoner::DeadReckoner(const DeadReckoningOptions& options, const std::array<bool, 4>& wheels,
                           const std::array<double, 4>& resolution_m)
    : o_(options), wheels_(wheels), window_(16) {
  o_.Validate();
  for (int i = 0; i < 4; ++i) {
    if (wheels_[i]) resolution_m_ = std::max(resolution_m_, std::abs(resolution_m[i]));  // the coarsest
  }
  resolution_tolerance_ = o_.slip_resolution_counts * resolution_m_;
}

const TrajectorySample& DeadReckoner::Step(double t_s, double heading_rad, double pitch_rad, double roll_rad,
                                           const std::array<double, 4>& wheel_m) {
  const std::size_t mask = window_.size() - 1;
  auto remember = [&] {  // this sample joins the slip window
    if (window_size_ == window_.size()) {  // full: twice the room, oldest first
      std::vector<Sample> grown(2 * window_.size());
      for (std::size_t i = 0; i < window_size_; ++i) grown[i] = window_[(window_begin_ + i) & mask];
      window_ = std::move(grown);
      window_begin_ = 0;
    }
    window_[(window_begin_ + window_size_) & (window_.size() - 1)] = {t_s, wheel_m};
    ++window_size_;
  };
  if (!started_) {
    started_ = true;
    pose_.t_s = t_s;
    pose_.heading_rad = heading_rad;
    pose_.pitch_rad = pitch_rad;
    pose_.roll_rad = roll_rad;
    half_heading_ = heading_half_(heading_rad);
    half_pitch_ = pitch_half_(pitch_rad);
    remember();
    return pose_;
  }
  // The window: from the last sample at least slip_window_s before this one (or the previous
  // sample) to the previous sample.
  while (window_size_ >= 2 && window_[(window_begin_ + 1) & mask].t_s <= t_s - o_.slip_window_s) {
    window_begin_ = (window_begin_ + 1) & mask;
    --window_size_;
  }
  const std::array<double, 4>& first = window_[window_begin_].wheel_m;
  const Sample& previous = window_[(window_begin_ + window_size_ - 1) & mask];
  // Left wheels (front left, rear left) +1, right wheels -1.
  constexpr std::array<double, 4> kSide = {1.0, -1.0, 1.0, -1.0};
  std::array<double, 4> step{}, travel{}, side{}, residual{};
  int count = 0;
  for (int i = 0; i < 4; ++i) {
    if (!wheels_[i] || std::isnan(wheel_m[i]) || std::isnan(previous.wheel_m[i])) continue;
    step[count] = wheel_m[i] - previous.wheel_m[i];
    travel[count] = std::isnan(first[i]) ? step[count] : wheel_m[i] - first[i];
    side[count] = kSide[i];
    ++count;
  }
  double d = 0;
  if (count == 0) {
    ++steps_without_odometry_;
  } else {
    // Remove the turn: a skid-steered rover's left and right wheels differ by the turn, not
    // by slip. The turn's share of each wheel is half the smallest left-right difference
    // when all of them agree in sign (a single slipping wheel leaves some pair equal).
    const double turn = TurnShare(travel, side, count);
    std::array<double, 4> sorted{}, magnitude{};
    for (int i = 0; i < count; ++i) {
      residual[i] = travel[i] - side[i] * turn;
      sorted[i] = residual[i];
      magnitude[i] = std::abs(travel[i]);
    }
    const double median = Median(sorted, count);
    const double tolerance =
        std::max({o_.slip_min_m, o_.slip_fraction * Median(magnitude, count), resolution_tolerance_});
    // D: the weighted mean of the steps with the step's own turn share removed (it cancels
    // when the weights are equal, and keeps a down-weighted wheel from biasing D on a turn).
    const double step_turn = TurnShare(step, side, count);
    double sum = 0, total_weight = 0;
    for (int i = 0; i < count; ++i) {
      const double excess = std::abs(residual[i] - median);
      const double weight = excess <= tolerance ? 1.0 : (tolerance / excess) * (tolerance / excess);
      if (weight < 0.5) ++slip_events_;
      sum += weight * (step[i] - side[i] * step_turn);
      total_weight += weight;
    }
    d = sum / total_weight;
  }
  // psi, phi: the mean heading (the short way round: headings a turn apart add pi to the
  // half sum, which flips the sign of its sine and cosine) and pitch over the step. Their
  // sines and cosines come from the half angles of this pose and the last by the sum
  // formulas; the half angles' own sines and cosines follow the slowly changing angles
  // (HalfAngleTracker), and the pose's attitude uses them too.
  const HalfAngle heading = heading_half_(heading_rad), pitch = pitch_half_(pitch_rad);
  // (Headings less than 3 rad apart, the usual step, are no turn apart: the quotient is
  // below 1/2 and rounds to zero.)
  const double change = pose_.heading_rad - heading_rad;
  const double turns = std::abs(change) < 3.0 ? 0.0 : std::round(change / (2.0 * M_PI));
  const double flip = turns == 0.0 || std::fmod(turns, 2.0) == 0.0 ? 1.0 : -1.0;  // (-1)^turns
  const double sin_psi = flip * (heading.sin * half_heading_.cos + heading.cos * half_heading_.sin);
  const double cos_psi = flip * (heading.cos * half_heading_.cos - heading.sin * half_heading_.sin);
  const double sin_phi = pitch.sin * half_pitch_.cos + pitch.cos * half_pitch_.sin;
  const double cos_phi = pitch.cos * half_pitch_.cos - pitch.sin * half_pitch_.sin;
  pose_.x_m += d * cos_phi * sin_psi;
  pose_.y_m += d * cos_phi * cos_psi;
  pose_.z_m += d * sin_phi;
  half_heading_ = heading;
  half_pitch_ = pitch;
  const double dt = t_s - pose_.t_s;
  pose_.t_s = t_s;
  pose_.heading_rad = heading_rad;
  pose_.pitch_rad = pitch_rad;
  pose_.roll_rad = roll_rad;
  pose_.speed_mps = dt > 0 ? std::abs(d) / dt : 0.0;
  // Path length at the encoders' resolution: travel is added once it amounts to a count,
  // so the back and forth of quantisation (a turn in place, standing still) is not travel.
  pending_m_ += d;
  if (std::abs(pending_m_) >= resolution_m_) {
    distance_m_ += std::abs(pending_m_);
    pending_m_ = 0;
  }
  remember();
  return pose_;
}

DeadReckoningResult DeadReckon(const DeadReckoningInputs& in, const DeadReckoningOptions& options) {
  const std::size_t n = in.t_s.size();
  LN_CHECK(in.heading_rad.size() == n);
  LN_CHECK(in.pitch_rad.empty() || in.pitch_rad.size() == n);
  LN_CHECK(in.roll_rad.empty() || in.roll_rad.size() == n);
  std::array<bool, 4> wheels{};
  for (int i = 0; i < 4; ++i) {
    LN_CHECK(in.wheel_m[i].empty() || in.wheel_m[i].size() == n);
    wheels[i] = !in.wheel_m[i].empty();
  }
  DeadReckoner reckoner(options, wheels, in.wheel_resolution_m);
  DeadReckoningResult out;
  out.trajectory.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    std::array<double, 4> wheel_m{};
    for (int i = 0; i < 4; ++i) wheel_m[i] = wheels[i] ? in.wheel_m[i][k] : 0.0;
    out.trajectory[k] = reckoner.Step(in.t_s[k], in.heading_rad[k], in.pitch_rad.empty() ? 0.0 : in.pitch_rad[k],
                                      in.roll_rad.empty() ? 0.0 : in.roll_rad[k], wheel_m);
  }
  if (n > 0) out.last_pose = out.trajectory.back();
  out.distance_m = reckoner.distance_m();
  out.slip_events = reckoner.slip_events();
  out.steps_without_odometry = reckoner.steps_without_odometry();
  return out;
}

}  // namespace lunarnav::positioning
