#include "stereo/disparity_filters.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <opencv2/imgproc.hpp>
#include <tbb/parallel_for.h>

#include "stereo/ncc_options.h"
#include "util/check.h"

namespace lunarnav::stereo {

double ParabolicPeakOffset(double c_prev, double c_best, double c_next) {
  const double curvature = c_prev - 2.0 * c_best + c_next;
  if (!(curvature < 0.0)) return 0.0;
  const double offset = 0.5 * (c_prev - c_next) / curvature;
  return std::clamp(offset, -0.5, 0.5);
}

namespace {
// Median of values[0..count) (mean of the two middle ones for an even count); reorders them.
float SmallMedian(float* values, int count) {
  if (count <= 25) {  // insertion sort: fastest for the usual 3x3 and 5x5 neighbourhoods
    for (int a = 1; a < count; ++a) {
      const float v = values[a];
      int b = a - 1;
      for (; b >= 0 && values[b] > v; --b) values[b + 1] = values[b];
      values[b + 1] = v;
    }
  } else {
    std::sort(values, values + count);
  }
  const int mid = count / 2;
  return count % 2 == 1 ? values[mid] : 0.5f * (values[mid - 1] + values[mid]);
}
}  // namespace

void MedianFilterDisparityGrid(int size, cv::Mat* disparity, cv::Mat* rejection) {
  LN_CHECK(disparity != nullptr && rejection != nullptr);
  LN_CHECK(disparity->type() == CV_32FC1 && rejection->type() == CV_8UC1 &&
           disparity->size() == rejection->size());
  if (size <= 1) return;
  LN_CHECK(size % 2 == 1) << "median size must be odd";
  const int half = size / 2;
  const int rows = disparity->rows, cols = disparity->cols;
  const cv::Mat in_disp = disparity->clone();
  const cv::Mat in_reason = rejection->clone();
  const auto accepted = static_cast<std::uint8_t>(Rejection::kAccepted);
  const auto not_evaluated = static_cast<std::uint8_t>(Rejection::kNotEvaluated);
  const auto border = static_cast<std::uint8_t>(Rejection::kBorder);
  // Fast path: where the whole neighbourhood is accepted, OpenCV's median (a SIMD sorting
  // network, k = 3 or 5 for float) gives the answer; the loop below handles the rest.
  cv::Mat full_support, fast_median;
  if ((size == 3 || size == 5) && rows >= size && cols >= size) {
    const cv::Mat accepted_mask = in_reason == accepted;
    cv::erode(accepted_mask, full_support, cv::getStructuringElement(cv::MORPH_RECT, {size, size}),
              {-1, -1}, 1, cv::BORDER_CONSTANT, cv::Scalar(0));
    cv::medianBlur(in_disp, fast_median, size);
  }
  tbb::parallel_for(0, rows, [&](int r) {
    std::vector<float> values(static_cast<std::size_t>(size) * size);
    auto* out_disp = disparity->ptr<float>(r);
    auto* out_reason = rejection->ptr<std::uint8_t>(r);
    const std::uint8_t* full = full_support.empty() ? nullptr : full_support.ptr<std::uint8_t>(r);
    for (int c = 0; c < cols; ++c) {
      if (in_reason.at<std::uint8_t>(r, c) != accepted) continue;
      if (full != nullptr && full[c] != 0) {
        out_disp[c] = fast_median.at<float>(r, c);
        continue;
      }
      int count = 0, evaluated = 0;
      for (int rr = std::max(0, r - half); rr <= std::min(rows - 1, r + half); ++rr) {
        const auto* reason_row = in_reason.ptr<std::uint8_t>(rr);
        const auto* disp_row = in_disp.ptr<float>(rr);
        for (int cc = std::max(0, c - half); cc <= std::min(cols - 1, c + half); ++cc) {
          const std::uint8_t code = reason_row[cc];
          if (code == not_evaluated || code == border) continue;
          ++evaluated;
          if (code == accepted) values[count++] = disp_row[cc];
        }
      }
      if (2 * count < evaluated) {
        out_disp[c] = std::numeric_limits<float>::quiet_NaN();
        out_reason[c] = static_cast<std::uint8_t>(Rejection::kMedian);
      } else {
        out_disp[c] = SmallMedian(values.data(), count);
      }
    }
  });
}

}  // namespace lunarnav::stereo
