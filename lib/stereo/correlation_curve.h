// The correlation curve C(d) at one pixel, evaluated literally (in double, one disparity at
// a time): the reference for the fast matcher and the data of the paper's Figure 5.
#pragma once

#include <cmath>
#include <limits>
#include <vector>

#include <opencv2/core.hpp>

#include "stereo/ncc_options.h"

namespace lunarnav::stereo {

/// C(x, y, d) of Krotkov & Hebert (sec. 3.2) over the window of half-size
/// (half_window_x_px, half_window_y_px) sampled every (step_x_px, step_y_px) pixels (partial
/// subsampling, sec. 3.4: the window's pixels are (x + i dx, y + j dy), |i| <= w_x / dx,
/// |j| <= w_y / dy), at the reference image's pixel (x, y): right reference compares
/// I_r(x, y) with I_l(x + d, y), left reference I_l(x, y) with I_r(x - d, y).
/// @param left, right  rectified grey images of one size and type (8- or 16-bit).
/// @return C, or NaN when the window leaves an image or has zero variance in either image.
double Correlation(const cv::Mat& left, const cv::Mat& right, const NccOptions& options, int x, int y, int d);

/// C from a window's sums over its n pixel pairs (reference a, other b: sums of a, b, a^2, b^2,
/// a b): the one expression Correlation and the quality preset's integer sums share, so that
/// exact sums give the same C bit for bit. NaN when either window has no variance.
inline double CorrelationFromSums(double s_ref, double s_oth, double s_rr, double s_oo, double s_ro, int n) {
  const double mean_r = s_ref / n, mean_o = s_oth / n;
  const double var_r = s_rr / n - mean_r * mean_r, var_o = s_oo / n - mean_o * mean_o;
  if (!(var_r > 0 && var_o > 0)) return std::numeric_limits<double>::quiet_NaN();
  return (s_ro / n - mean_r * mean_o) / std::sqrt(var_r * var_o);
}

/// One correlation curve and its peak.
struct CorrelationCurve {
  int min_disparity_px = 0;
  std::vector<double> values;     ///< C(d) for d = min_disparity_px, min + 1, ... (NaN: undefined).
  int best_disparity_px = -1;     ///< The argmax (ties: the smaller d); -1 if every C is NaN.
  double best_correlation = NAN;  ///< C at the argmax.
  /// The argmax refined by the parabola through it and its neighbours (the matcher's
  /// sub-pixel step); NaN at an end of the range or without a maximum.
  double subpixel_disparity_px = NAN;
};

/// C(d) at (x, y) for every integer d of [options.min_disparity_px, options.max_disparity_px].
CorrelationCurve ComputeCorrelationCurve(const cv::Mat& left, const cv::Mat& right, const NccOptions& options,
                                         int x, int y);

/// Conventional subsampling, the contrast of sec. 3.4: both images decimated by (dx, dy)
/// (area averaging), the window shrunk to (w_x / dx, w_y / dy), disparities searched in
/// steps of dx full-resolution pixels. Returns the curve over the reduced disparities
/// d' = ceil(min / dx) ... floor(max / dx), with `min_disparity_px` the first of them times dx
/// and the peak (integer and sub-pixel) scaled back to full-resolution pixels.
CorrelationCurve ComputeConventionalCurve(const cv::Mat& left, const cv::Mat& right, const NccOptions& options,
                                          int x, int y);

}  // namespace lunarnav::stereo
