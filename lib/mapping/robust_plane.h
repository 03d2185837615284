// A plane fitted robustly to samples of a surface: the ground under what stands on it.
#pragma once

#include <cstddef>
#include <optional>
#include <vector>

#include <Eigen/Core>

namespace lunarnav::mapping {

/// One sample of a surface: its value z at (dx, dy) from a point of reference.
struct PlaneSample {
  double dx = 0, dy = 0, z = 0;
};

/// The plane z = p[0] + p[1] dx + p[2] dy that fits `samples` robustly: iteratively reweighted
/// least squares from `initial`, Huber's weights for three iterations, then Tukey's biweight
/// (4.685 scales) for five, the scale being 1.4826 times the residuals' median absolute value,
/// but at least `scale_floor`. It settles near its start: differences expected near zero (the
/// ground alignment's) start well at 0; with a large share of the samples off the plane, a
/// level start ends between the two (FitDominantPlane starts it on the plane instead).
/// `slope_prior` (the slopes' RMS prior; infinity: none)
/// adds (scale / slope_prior)^2 to the normal equations' slope terms: where the samples do not
/// spread, the least slope that explains them is taken. nullopt when the normal equations are
/// singular. `abs_residuals`, when given, receives the samples' absolute residuals under the
/// returned plane.
std::optional<Eigen::Vector3d> FitRobustPlane(const std::vector<PlaneSample>& samples, double scale_floor,
                                              double slope_prior, std::vector<double>* abs_residuals = nullptr,
                                              const Eigen::Vector3d& initial = Eigen::Vector3d::Zero());

/// The dominant plane of `samples`, as FitRobustPlane's p: of kDominantPlaneTrials planes through
/// three samples (drawn with a fixed seed: the same samples give the same plane) whose slopes are
/// at most `max_slope`, the one most samples lie within `inlier_m` of (MSAC: the squared
/// residuals, capped at inlier_m^2, summed), refined by FitRobustPlane from there. The ground
/// under what stands on it (cars, walkers, walls) need not be most of the samples, only the
/// largest flat part of them, where a fit from a level start would settle between the two.
/// nullopt with fewer than 3 samples, or when no trial plane is flat enough.
std::optional<Eigen::Vector3d> FitDominantPlane(const std::vector<PlaneSample>& samples, double inlier_m,
                                                double max_slope, double scale_floor,
                                                std::vector<double>* abs_residuals = nullptr);

/// Trial planes of FitDominantPlane: with 40 % of the samples on the plane, a draw of three
/// finds it with probability 0.064 and 100 draws miss it with probability 0.001; with half of
/// them, 2e-6.
inline constexpr int kDominantPlaneTrials = 100;
/// The trial planes are scored on about this many of the samples (every k-th); the refinement
/// uses them all.
inline constexpr std::size_t kDominantPlaneScored = 256;

/// The median of `values` (0 when empty); reorders them.
double MedianInPlace(std::vector<double>& values);

}  // namespace lunarnav::mapping
