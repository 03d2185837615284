// Sub-pixel interpolation and the median filter of the correlation matcher.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

namespace lunarnav::stereo {

/// Offset in (-0.5, 0.5) of the vertex of the parabola through (-1, c_prev), (0, c_best),
/// (1, c_next) (Krotkov & Hebert sec. 3.2: "a parabolic interpolation that uses the
/// correlation values of the two closest disparities"). Returns 0 when the three values
/// do not form a maximum (flat or not concave).
inline double ParabolicPeakOffset(double c_prev, double c_best, double c_next) {
  const double curvature = c_prev - 2.0 * c_best + c_next;
  if (!(curvature < 0.0)) return 0.0;
  const double offset = 0.5 * (c_prev - c_next) / curvature;
  return offset < -0.5 ? -0.5 : (offset > 0.5 ? 0.5 : offset);
}

/// The border rule (both presets): matches that the other image cannot hold.
///
/// A disparity grid in the right-reference convention (working columns: the grid cell i is
/// column x0 + i step_x, its match is target column x + d). A pixel whose search range was cut
/// by the target image's right edge (x + reach_px > width - 1: some searched disparity, with
/// its window, leaves the image) chose among the disparities left inside as if the range were
/// complete; when its true match lies beyond the edge, any of them is wrong. Along a row, the
/// matches of a visible surface keep their order and advance: x + d grows by 1 + dd/dx, at
/// least 0.15 a pixel unless the other camera sees the surface less than a seventh as wide (a
/// pixel whose match lies left of a neighbour's is hidden from the other camera). So once an
/// accepted pixel x_m to the left matches target column M, a cut pixel x whose match lies
/// left of M + 0.15 (x - x_m) - tolerance_px is seen beyond the edge (or hidden), and it is set
/// to NaN and marked kBeyondBorder when, besides, that surface carried on at a pixel a pixel
/// (M + x - x_m) matches beyond the last column a target window fits in (width - 1 -
/// window_half_px): only there may its true match lie outside the image. Nearer the middle, a
/// match left of the bound is an ordinary occlusion (the background beside a thin post: on
/// real street pairs, the rule without this condition rejected hundreds of correct pixels per
/// pair) and stays. The advance carries the bound across the pixels next to the edge that
/// other filters rejected. The matchers run the rule after their median filter (the quality
/// preset before its speckle filter, which then removes what the rule leaves of a wrong
/// region). Pixels whose range is complete are never touched;
/// in the cut zone, the ground right of a rock near the edge is rejected for up to 1.18 times
/// the width it is hidden.
/// @param reach_px  per grid row: its d_max plus the half-width of the window the target is
///        compared over.
/// @param window_half_px  the half-width of that window (0 for a cost taken with replicated
///        borders).
/// @return the number of cells rejected.
int RejectMatchesBeyondTheBorder(int x0, int step_x, int width, const std::vector<int>& reach_px, int window_half_px,
                                 double tolerance_px, cv::Mat* disparity, cv::Mat* rejection);

/// The fourth filter: a k x k median filter over a disparity grid (the map on the
/// subsampling grid, one cell per evaluated pixel).
///
/// Each accepted cell (Rejection::kAccepted in `rejection`) takes the median of the accepted
/// disparities in its neighbourhood (mean of the two middle values for an even count). A cell
/// whose accepted neighbours (itself included) are fewer than half of its evaluated neighbours
/// (cells that are neither kNotEvaluated nor kBorder) is an isolated match: it is set to NaN
/// and marked kMedian.
/// @param size  odd k >= 3 (1 or 0: nothing is done).
/// @param disparity  CV_32FC1, NaN where not accepted; filtered in place.
/// @param rejection  CV_8UC1 Rejection codes, same size; updated in place.
/// @param reject_isolated  false: only smooth (the quality preset, whose speckle filter
///        removes isolated matches); no cell is rejected.
void MedianFilterDisparityGrid(int size, cv::Mat* disparity, cv::Mat* rejection, bool reject_isolated = true);

}  // namespace lunarnav::stereo
