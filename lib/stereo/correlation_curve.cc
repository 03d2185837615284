#include "stereo/correlation_curve.h"

#include <cmath>

#include <opencv2/imgproc.hpp>

#include "stereo/disparity_filters.h"
#include "util/check.h"

namespace lunarnav::stereo {
namespace {

void CheckImages(const cv::Mat& left, const cv::Mat& right) {
  LN_CHECK_ARG((left.type() == CV_8UC1 || left.type() == CV_16UC1) && right.type() == left.type())
      << "correlation: 8- or 16-bit grey images of one type expected";
  LN_CHECK_ARG(left.size() == right.size()) << "correlation: the images differ in size";
}

// The argmax and its parabolic refinement.
void FindPeak(CorrelationCurve* curve) {
  const auto& c = curve->values;
  int best = -1;
  for (int i = 0; i < static_cast<int>(c.size()); ++i) {
    if (std::isfinite(c[i]) && (best < 0 || c[i] > c[best])) best = i;
  }
  if (best < 0) return;
  curve->best_disparity_px = curve->min_disparity_px + best;
  curve->best_correlation = c[best];
  if (best > 0 && best + 1 < static_cast<int>(c.size()) && std::isfinite(c[best - 1]) && std::isfinite(c[best + 1])) {
    curve->subpixel_disparity_px = curve->best_disparity_px + ParabolicPeakOffset(c[best - 1], c[best], c[best + 1]);
  }
}

}  // namespace

namespace {

template <typename Pixel>
double CorrelationOf(const cv::Mat& left, const cv::Mat& right, const NccOptions& options, int x, int y, int d) {
  const int dx = options.step_x_px, dy = options.step_y_px;
  const int mx = options.half_window_x_px / dx, my = options.half_window_y_px / dy;
  const bool right_ref = options.reference == ReferenceImage::kRight;
  const cv::Mat& ref = right_ref ? right : left;
  const cv::Mat& other = right_ref ? left : right;
  const int shift = right_ref ? d : -d;
  double s_ref = 0, s_oth = 0, s_rr = 0, s_oo = 0, s_ro = 0;
  int n = 0;
  for (int j = -my; j <= my; ++j) {
    const int yy = y + j * dy;
    if (yy < 0 || yy >= ref.rows) return NAN;
    const Pixel* r_row = ref.ptr<Pixel>(yy);
    const Pixel* o_row = other.ptr<Pixel>(yy);
    for (int i = -mx; i <= mx; ++i) {
      const int xr = x + i * dx, xo = xr + shift;
      if (xr < 0 || xr >= ref.cols || xo < 0 || xo >= other.cols) return NAN;
      const double a = r_row[xr], b = o_row[xo];
      s_ref += a;
      s_oth += b;
      s_rr += a * a;
      s_oo += b * b;
      s_ro += a * b;
      ++n;
    }
  }
  return CorrelationFromSums(s_ref, s_oth, s_rr, s_oo, s_ro, n);
}

}  // namespace

double Correlation(const cv::Mat& left, const cv::Mat& right, const NccOptions& options, int x, int y, int d) {
  return left.depth() == CV_16U ? CorrelationOf<std::uint16_t>(left, right, options, x, y, d)
                                : CorrelationOf<std::uint8_t>(left, right, options, x, y, d);
}

CorrelationCurve ComputeCorrelationCurve(const cv::Mat& left, const cv::Mat& right, const NccOptions& options,
                                         int x, int y) {
  options.Validate();
  CheckImages(left, right);
  LN_CHECK_ARG(x >= 0 && x < left.cols && y >= 0 && y < left.rows)
      << "correlation: pixel (" << x << ", " << y << ") is outside the " << left.cols << " x " << left.rows
      << " image";
  CorrelationCurve curve;
  curve.min_disparity_px = options.min_disparity_px;
  for (int d = options.min_disparity_px; d <= options.max_disparity_px; ++d) {
    curve.values.push_back(Correlation(left, right, options, x, y, d));
  }
  FindPeak(&curve);
  return curve;
}

CorrelationCurve ComputeConventionalCurve(const cv::Mat& left, const cv::Mat& right, const NccOptions& options,
                                          int x, int y) {
  options.Validate();
  CheckImages(left, right);
  const int dx = options.step_x_px, dy = options.step_y_px;
  cv::Mat small_left, small_right;
  const cv::Size small(left.cols / dx, left.rows / dy);
  cv::resize(left, small_left, small, 0, 0, cv::INTER_AREA);
  cv::resize(right, small_right, small, 0, 0, cv::INTER_AREA);
  NccOptions reduced = options;
  reduced.step_x_px = reduced.step_y_px = 1;
  reduced.half_window_x_px = options.half_window_x_px / dx;
  reduced.half_window_y_px = options.half_window_y_px / dy;
  reduced.min_disparity_px = static_cast<int>(std::ceil(static_cast<double>(options.min_disparity_px) / dx));
  reduced.max_disparity_px = options.max_disparity_px / dx;
  LN_CHECK_ARG(reduced.min_disparity_px <= reduced.max_disparity_px)
      << "conventional subsampling: the disparity range holds no multiple of the column step";
  CorrelationCurve curve = ComputeCorrelationCurve(small_left, small_right, reduced, std::min(x / dx, small.width - 1),
                                                   std::min(y / dy, small.height - 1));
  curve.min_disparity_px *= dx;
  if (curve.best_disparity_px >= 0) curve.best_disparity_px *= dx;
  curve.subpixel_disparity_px *= dx;
  return curve;
}

}  // namespace lunarnav::stereo
