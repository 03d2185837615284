#include "stereo/disparity_filters.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <opencv2/imgproc.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "stereo/ncc_options.h"
#include "util/check.h"
#include "util/small_median.h"

namespace lunarnav::stereo {

namespace {
// How far a visible surface's match advances per pixel, at least: x + d grows by 1 + dd/dx,
// which is 1 for a fronto-parallel surface or level ground, and below 0.15 only for a surface
// the other camera sees less than a seventh as wide as the reference camera (a wall at a
// grazing angle). The same figure sets how far beside a nearer object the background is
// rejected: 1 / (1 - 0.15) = 1.18 times the width the object hides. With 0.5 (twice the hidden
// width) the rule rejected correct background beside the parts of the Middlebury Motorcycle
// near its left edge (stereo_realdata_benchmark's density fell); 0.15 keeps the real-pair
// figures and still rejects every pixel seen beyond the edge in the slanted-ground tests
// (sgm_matcher_test.cc).
constexpr double kMinAdvance = 0.15;
}  // namespace

int RejectMatchesBeyondTheBorder(int x0, int step_x, int width, const std::vector<int>& reach_px, int window_half_px,
                                 double tolerance_px, cv::Mat* disparity, cv::Mat* rejection) {
  LN_CHECK(disparity != nullptr && rejection != nullptr);
  LN_CHECK(disparity->type() == CV_32FC1 && rejection->type() == CV_8UC1 &&
           disparity->size() == rejection->size());
  LN_CHECK(step_x >= 1);
  const int rows = disparity->rows, cols = disparity->cols;
  LN_CHECK(static_cast<int>(reach_px.size()) == rows);
  std::vector<int> rejected(rows, 0);
  tbb::parallel_for(0, rows, [&](int j) {
    // The first grid cell whose range is cut: x0 + i step_x + reach > width - 1.
    const int room = width - 1 - reach_px[j] - x0;
    const int first_cut = room < 0 ? 0 : std::min(cols, room / step_x + 1);
    if (first_cut >= cols) return;
    auto* d = disparity->ptr<float>(j);
    auto* reason = rejection->ptr<std::uint8_t>(j);
    // The bound on the target column: the match (x_m, M) that raises it most, advanced by
    // kMinAdvance a pixel.
    double reached = -std::numeric_limits<double>::infinity();
    int reached_x = 0;
    const double last_column = width - 1 - window_half_px;
    for (int i = 0; i < cols; ++i) {
      if (reason[i] != static_cast<std::uint8_t>(Rejection::kAccepted) || !std::isfinite(d[i])) continue;
      const int x = x0 + i * step_x;
      const double target = x + static_cast<double>(d[i]);
      const double bound = reached + kMinAdvance * (x - reached_x);
      // Judged only where the surface that set the bound, carried on at a pixel a pixel (a
      // surface facing both cameras alike), matches beyond the last column a window fits in:
      // there the true match may lie outside the image. Nearer the middle, a match left of the
      // bound is an ordinary occlusion (the background beside a thin post) and stays.
      const bool beyond = reached + (x - reached_x) > last_column;
      if (i >= first_cut && beyond && target < bound - tolerance_px) {
        d[i] = std::numeric_limits<float>::quiet_NaN();
        reason[i] = static_cast<std::uint8_t>(Rejection::kBeyondBorder);
        ++rejected[j];
        continue;
      }
      if (target >= bound) {
        reached = target;
        reached_x = x;
      }
    }
  });
  int total = 0;
  for (int r : rejected) total += r;
  return total;
}

void MedianFilterDisparityGrid(int size, cv::Mat* disparity, cv::Mat* rejection, bool reject_isolated) {
  LN_CHECK(disparity != nullptr && rejection != nullptr);
  LN_CHECK(disparity->type() == CV_32FC1 && rejection->type() == CV_8UC1 &&
           disparity->size() == rejection->size());
  if (size <= 1 || disparity->empty()) return;
  LN_CHECK(size % 2 == 1) << "median size must be odd";
  const int half = size / 2;
  const int rows = disparity->rows, cols = disparity->cols;
  const int accepted = static_cast<int>(Rejection::kAccepted);
  const int not_evaluated = static_cast<int>(Rejection::kNotEvaluated);
  const int border = static_cast<int>(Rejection::kBorder);
  const cv::Mat in_disp = disparity->clone();
  const cv::Mat accepted_mask = *rejection == accepted;
  // Fast path: where the whole neighbourhood is accepted, OpenCV's median (a SIMD sorting
  // network, k = 3 or 5 for float) is the answer, copied under a mask.
  // (A fresh matrix: assigning an expression to a header that shares accepted_mask's buffer
  // would write the result into accepted_mask, and the neighbour counts below would miss every
  // fully supported cell.)
  cv::Mat partial;
  if ((size == 3 || size == 5) && rows >= size && cols >= size) {
    cv::Mat full_support, fast_median;
    cv::erode(accepted_mask, full_support, cv::getStructuringElement(cv::MORPH_RECT, {size, size}),
              {-1, -1}, 1, cv::BORDER_CONSTANT, cv::Scalar(0));
    cv::medianBlur(in_disp, fast_median, size);
    fast_median.copyTo(*disparity, full_support);
    partial = accepted_mask & ~full_support;
  } else {
    partial = accepted_mask.clone();
  }
  // The rest: accepted pixels next to rejected or unevaluated ones.
  std::vector<cv::Point> remaining;
  cv::findNonZero(partial, remaining);
  // Per cell: 1 if accepted / evaluated (neither kNotEvaluated nor kBorder), for branch-free
  // counting below.
  cv::Mat is_accepted, is_evaluated;
  accepted_mask.convertTo(is_accepted, CV_8U, 1.0 / 255);
  cv::Mat not_eval = (*rejection == not_evaluated) | (*rejection == border);
  cv::bitwise_not(not_eval, is_evaluated);
  is_evaluated.convertTo(is_evaluated, CV_8U, 1.0 / 255);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, remaining.size(), 256),
                    [&](const tbb::blocked_range<std::size_t>& range) {
    std::vector<float> values(static_cast<std::size_t>(size) * size + 1);
    for (std::size_t p = range.begin(); p != range.end(); ++p) {
      const int r = remaining[p].y, c = remaining[p].x;
      const int c0 = std::max(0, c - half), c1 = std::min(cols - 1, c + half);
      int count = 0, evaluated = 0;
      for (int rr = std::max(0, r - half); rr <= std::min(rows - 1, r + half); ++rr) {
        const auto* acc_row = is_accepted.ptr<std::uint8_t>(rr);
        const auto* eval_row = is_evaluated.ptr<std::uint8_t>(rr);
        const auto* disp_row = in_disp.ptr<float>(rr);
        for (int cc = c0; cc <= c1; ++cc) {
          values[count] = disp_row[cc];
          count += acc_row[cc];
          evaluated += eval_row[cc];
        }
      }
      if (reject_isolated && 2 * count < evaluated) {
        disparity->at<float>(r, c) = std::numeric_limits<float>::quiet_NaN();
        rejection->at<std::uint8_t>(r, c) = static_cast<std::uint8_t>(Rejection::kMedian);
      } else {
        disparity->at<float>(r, c) = util::SmallMedian(values.data(), static_cast<std::size_t>(count));
      }
    }
  });
}

}  // namespace lunarnav::stereo
