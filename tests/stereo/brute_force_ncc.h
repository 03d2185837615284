// Test helper: the paper's correlation evaluated literally, in double, one pixel at a time.
#pragma once

#include <cmath>

#include <opencv2/core.hpp>

namespace lunarnav::stereo::testing {

/// C(x, y, d) of Krotkov & Hebert eq. (sec. 3.2) over the window of half-size (wx, wy)
/// subsampled by (dx, dy) (sec. 3.4), right image as reference: I_l(x + d, y) vs I_r(x, y).
/// Returns NaN when a window leaves an image or has zero variance.
inline double BruteForceCorrelation(const cv::Mat& left, const cv::Mat& right, int x, int y,
                                    int d, int wx, int wy, int dx, int dy) {
  const int mx = wx / dx, my = wy / dy;
  double sl = 0, sr = 0, sll = 0, srr = 0, slr = 0;
  int n = 0;
  for (int j = -my; j <= my; ++j) {
    for (int i = -mx; i <= mx; ++i) {
      const int xr = x + i * dx, yy = y + j * dy, xl = xr + d;
      if (yy < 0 || yy >= right.rows || xr < 0 || xr >= right.cols || xl < 0 || xl >= left.cols) {
        return std::nan("");
      }
      const double il = left.at<std::uint8_t>(yy, xl), ir = right.at<std::uint8_t>(yy, xr);
      sl += il;
      sr += ir;
      sll += il * il;
      srr += ir * ir;
      slr += il * ir;
      ++n;
    }
  }
  const double sigma_l = std::sqrt(sll / n - (sl / n) * (sl / n));
  const double sigma_r = std::sqrt(srr / n - (sr / n) * (sr / n));
  if (!(sigma_l > 0 && sigma_r > 0)) return std::nan("");
  return (slr / n - sl * sr / (static_cast<double>(n) * n)) / (sigma_l * sigma_r);
}

}  // namespace lunarnav::stereo::testing
