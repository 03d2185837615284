#include "stereo/disparity_filters.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "stereo/ncc_options.h"
#include "util/check.h"

namespace lunarnav::stereo {

double ParabolicPeakOffset(double c_prev, double c_best, double c_next) {
  const double curvature = c_prev - 2.0 * c_best + c_next;
  if (!(curvature < 0.0)) return 0.0;
  const double offset = 0.5 * (c_prev - c_next) / curvature;
  return std::clamp(offset, -0.5, 0.5);
}

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
  std::vector<float> values;
  values.reserve(static_cast<std::size_t>(size) * size);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      if (in_reason.at<std::uint8_t>(r, c) != accepted) continue;
      values.clear();
      int evaluated = 0;
      for (int rr = std::max(0, r - half); rr <= std::min(rows - 1, r + half); ++rr) {
        const auto* reason_row = in_reason.ptr<std::uint8_t>(rr);
        const auto* disp_row = in_disp.ptr<float>(rr);
        for (int cc = std::max(0, c - half); cc <= std::min(cols - 1, c + half); ++cc) {
          const std::uint8_t code = reason_row[cc];
          if (code == not_evaluated || code == border) continue;
          ++evaluated;
          if (code == accepted) values.push_back(disp_row[cc]);
        }
      }
      if (2 * static_cast<int>(values.size()) < evaluated) {
        disparity->at<float>(r, c) = std::numeric_limits<float>::quiet_NaN();
        rejection->at<std::uint8_t>(r, c) = static_cast<std::uint8_t>(Rejection::kMedian);
        continue;
      }
      const std::size_t mid = values.size() / 2;
      std::nth_element(values.begin(), values.begin() + mid, values.end());
      float median = values[mid];
      if (values.size() % 2 == 0) {
        const float below = *std::max_element(values.begin(), values.begin() + mid);
        median = 0.5f * (below + median);
      }
      disparity->at<float>(r, c) = median;
    }
  }
}

}  // namespace lunarnav::stereo
