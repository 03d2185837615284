#include "positioning/dead_reckoning.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "util/check.h"

namespace lunarnav::positioning {
namespace {

// The median of the first `count` values (reorders them).
double Median(std::array<double, 4>& v, int count) {
  std::sort(v.begin(), v.begin() + count);
  return count % 2 == 1 ? v[count / 2] : 0.5 * (v[count / 2 - 1] + v[count / 2]);
}

// Half the smallest left-minus-right difference of `value` when every left-right pair
// differs in the same sign, else 0 (no turn, or no wheel on one side).
double TurnShare(const std::array<double, 4>& value, const std::array<double, 4>& side, int count) {
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

DeadReckoningResult DeadReckon(const DeadReckoningInputs& in, const DeadReckoningOptions& options) {
  options.Validate();
  const std::size_t n = in.t_s.size();
  LN_CHECK(in.heading_rad.size() == n);
  LN_CHECK(in.pitch_rad.empty() || in.pitch_rad.size() == n);
  LN_CHECK(in.roll_rad.empty() || in.roll_rad.size() == n);
  for (const auto& w : in.wheel_m) LN_CHECK(w.empty() || w.size() == n);
  DeadReckoningResult out;
  out.trajectory.resize(n);
  if (n == 0) return out;
  auto pitch = [&](std::size_t k) { return in.pitch_rad.empty() ? 0.0 : in.pitch_rad[k]; };
  auto roll = [&](std::size_t k) { return in.roll_rad.empty() ? 0.0 : in.roll_rad[k]; };
  double resolution_m = 0;  // the coarsest wheel's metres per count
  for (int i = 0; i < 4; ++i) {
    if (!in.wheel_m[i].empty()) resolution_m = std::max(resolution_m, std::abs(in.wheel_resolution_m[i]));
  }
  const double resolution_tolerance = options.slip_resolution_counts * resolution_m;
  TrajectorySample pose;
  pose.t_s = in.t_s[0];
  pose.heading_rad = in.heading_rad[0];
  pose.pitch_rad = pitch(0);
  pose.roll_rad = roll(0);
  out.trajectory[0] = pose;
  // Left wheels (front left, rear left) +1, right wheels -1.
  constexpr std::array<double, 4> kSide = {1.0, -1.0, 1.0, -1.0};
  std::array<double, 4> step{}, travel{}, side{}, residual{};
  std::size_t start = 0;  // first sample of the slip window ending at k
  double pending_m = 0;   // travel not yet added to the path length
  for (std::size_t k = 1; k < n; ++k) {
    while (start + 1 < k && in.t_s[start + 1] <= in.t_s[k] - options.slip_window_s) ++start;
    const std::size_t j = std::min(start, k - 1);
    int count = 0;
    for (int i = 0; i < 4; ++i) {
      const std::vector<double>& w = in.wheel_m[i];
      if (w.empty() || std::isnan(w[k]) || std::isnan(w[k - 1])) continue;
      step[count] = w[k] - w[k - 1];
      travel[count] = std::isnan(w[j]) ? step[count] : w[k] - w[j];
      side[count] = kSide[i];
      ++count;
    }
    double d = 0;
    if (count == 0) {
      ++out.steps_without_odometry;
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
      const double tolerance = std::max({options.slip_min_m, options.slip_fraction * Median(magnitude, count),
                                         resolution_tolerance});
      // D: the weighted mean of the steps with the step's own turn share removed (it cancels
      // when the weights are equal, and keeps a down-weighted wheel from biasing D on a turn).
      const double step_turn = TurnShare(step, side, count);
      double sum = 0, total_weight = 0;
      for (int i = 0; i < count; ++i) {
        const double excess = std::abs(residual[i] - median);
        const double weight = excess <= tolerance ? 1.0 : (tolerance / excess) * (tolerance / excess);
        if (weight < 0.5) ++out.slip_events;
        sum += weight * (step[i] - side[i] * step_turn);
        total_weight += weight;
      }
      d = sum / total_weight;
    }
    const double psi = 0.5 * (in.heading_rad[k] + in.heading_rad[k - 1] +
                              2.0 * M_PI * std::round((in.heading_rad[k - 1] - in.heading_rad[k]) / (2.0 * M_PI)));
    const double phi = 0.5 * (pitch(k) + pitch(k - 1));
    pose.x_m += d * std::cos(phi) * std::sin(psi);
    pose.y_m += d * std::cos(phi) * std::cos(psi);
    pose.z_m += d * std::sin(phi);
    const double dt = in.t_s[k] - in.t_s[k - 1];
    pose.t_s = in.t_s[k];
    pose.heading_rad = in.heading_rad[k];
    pose.pitch_rad = pitch(k);
    pose.roll_rad = roll(k);
    pose.speed_mps = dt > 0 ? std::abs(d) / dt : 0.0;
    // Path length at the encoders' resolution: travel is added once it amounts to a count,
    // so the back and forth of quantisation (a turn in place, standing still) is not travel.
    pending_m += d;
    if (std::abs(pending_m) >= resolution_m) {
      out.distance_m += std::abs(pending_m);
      pending_m = 0;
    }
    out.trajectory[k] = pose;
  }
  out.distance_m += std::abs(pending_m);
  return out;
}

}  // namespace lunarnav::positioning
