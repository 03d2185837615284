#include "positioning/dead_reckoning.h"

#include <algorithm>
#include <cmath>

#include "util/check.h"

namespace lunarnav::positioning {

DeadReckoningResult DeadReckon(const DeadReckoningInputs& in, const DeadReckoningOptions& options) {
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
  TrajectorySample pose;
  pose.t_s = in.t_s[0];
  pose.heading_rad = in.heading_rad[0];
  pose.pitch_rad = pitch(0);
  pose.roll_rad = roll(0);
  out.trajectory[0] = pose;
  std::array<double, 4> step{}, weight{};
  for (std::size_t k = 1; k < n; ++k) {
    int count = 0;
    for (const auto& w : in.wheel_m) {
      if (!w.empty() && !std::isnan(w[k]) && !std::isnan(w[k - 1])) step[count++] = w[k] - w[k - 1];
    }
    double d = 0;
    if (count == 0) {
      ++out.steps_without_odometry;
    } else {
      std::array<double, 4> sorted = step;
      std::sort(sorted.begin(), sorted.begin() + count);
      const double median = count % 2 == 1 ? sorted[count / 2]
                                            : 0.5 * (sorted[count / 2 - 1] + sorted[count / 2]);
      const double tolerance = std::max(options.slip_min_m, options.slip_fraction * std::abs(median));
      double sum = 0, total_weight = 0;
      for (int i = 0; i < count; ++i) {
        const double excess = std::abs(step[i] - median);
        weight[i] = excess <= tolerance ? 1.0 : (tolerance / excess) * (tolerance / excess);
        if (weight[i] < 0.5) ++out.slip_events;
        sum += weight[i] * step[i];
        total_weight += weight[i];
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
    out.distance_m += std::abs(d);
    out.trajectory[k] = pose;
  }
  return out;
}

}  // namespace lunarnav::positioning
