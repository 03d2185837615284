#include "mapping/robust_plane.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include <Eigen/Dense>

namespace lunarnav::mapping {

double MedianInPlace(std::vector<double>& values) {
  if (values.empty()) return 0;
  const std::size_t m = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(m), values.end());
  return values[m];
}

std::optional<Eigen::Vector3d> FitRobustPlane(const std::vector<PlaneSample>& samples, double scale_floor,
                                              double slope_prior, std::vector<double>* abs_residuals,
                                              const Eigen::Vector3d& initial) {
  const std::size_t n = samples.size();
  std::vector<double> w(n, 1.0), abs_res(n), scratch;
  auto residuals = [&](const Eigen::Vector3d& p) {
    for (std::size_t i = 0; i < n; ++i) {
      abs_res[i] = std::abs(samples[i].z - (p[0] + p[1] * samples[i].dx + p[2] * samples[i].dy));
    }
  };
  auto scale = [&] {
    scratch = abs_res;
    return std::max(scale_floor, 1.4826 * MedianInPlace(scratch));
  };
  Eigen::Vector3d p = initial;
  residuals(p);
  for (int iteration = 0; iteration < 8; ++iteration) {
    const double s = scale();
    for (std::size_t i = 0; i < n; ++i) {
      const double u = abs_res[i] / s;
      if (iteration < 3) {
        w[i] = u <= 1.345 ? 1.0 : 1.345 / u;  // Huber
      } else {
        const double t = u / 4.685;  // Tukey
        w[i] = t < 1 ? (1 - t * t) * (1 - t * t) : 0.0;
      }
    }
    Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
    Eigen::Vector3d b = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Vector3d j(1.0, samples[i].dx, samples[i].dy);
      a += w[i] * j * j.transpose();
      b += w[i] * samples[i].z * j;
    }
    if (std::isfinite(slope_prior)) {
      const double prior = (s / slope_prior) * (s / slope_prior);
      a(1, 1) += prior;
      a(2, 2) += prior;
    }
    if (!(a.determinant() > 0)) return std::nullopt;
    p = a.ldlt().solve(b);
    residuals(p);
  }
  if (abs_residuals != nullptr) *abs_residuals = abs_res;
  return p;
}

std::optional<Eigen::Vector3d> FitDominantPlane(const std::vector<PlaneSample>& samples, double inlier_m,
                                                double max_slope, double scale_floor,
                                                std::vector<double>* abs_residuals) {
  const std::size_t n = samples.size();
  if (n < 3) return std::nullopt;
  std::mt19937 rng(20261206);
  std::uniform_int_distribution<std::size_t> pick(0, n - 1);
  const double cap2 = inlier_m * inlier_m;
  const std::size_t step = std::max<std::size_t>(1, n / kDominantPlaneScored);  // the trials are scored on a subset
  std::optional<Eigen::Vector3d> best;
  double best_cost = std::numeric_limits<double>::infinity();
  for (int trial = 0; trial < kDominantPlaneTrials; ++trial) {
    const PlaneSample& a = samples[pick(rng)];
    const PlaneSample& b = samples[pick(rng)];
    const PlaneSample& c = samples[pick(rng)];
    Eigen::Matrix3d m;
    m << 1, a.dx, a.dy, 1, b.dx, b.dy, 1, c.dx, c.dy;
    const Eigen::FullPivLU<Eigen::Matrix3d> lu(m);
    if (!lu.isInvertible()) continue;
    const Eigen::Vector3d p = lu.solve(Eigen::Vector3d(a.z, b.z, c.z));
    if (!(std::hypot(p[1], p[2]) <= max_slope)) continue;
    double cost = 0;
    for (std::size_t k = 0; k < n; k += step) {
      const PlaneSample& s = samples[k];
      const double r = s.z - (p[0] + p[1] * s.dx + p[2] * s.dy);
      cost += std::min(r * r, cap2);
    }
    if (cost < best_cost) {
      best_cost = cost;
      best = p;
    }
  }
  if (!best) return std::nullopt;
  return FitRobustPlane(samples, scale_floor, std::numeric_limits<double>::infinity(), abs_residuals, *best);
}

}  // namespace lunarnav::mapping
