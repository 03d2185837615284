#include "stereo/disparity_filters.h"

#include <algorithm>
#include <cmath>
#include <cstring>
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

namespace {

// One accepted cell (r, c) by the filter's definition, from the unfiltered grids: the median
// of the accepted disparities in its (2 half + 1)^2 neighbourhood, or, with reject_isolated,
// rejected when they are fewer than half of the evaluated cells there. `values` holds
// (2 half + 1)^2 + 1 floats.
void FilterCell(const cv::Mat& in_disp, const cv::Mat& in_reason, int half, int r, int c, bool reject_isolated,
                float* values, cv::Mat* disparity, cv::Mat* rejection) {
  const auto accepted = static_cast<std::uint8_t>(Rejection::kAccepted);
  const auto not_evaluated = static_cast<std::uint8_t>(Rejection::kNotEvaluated);
  const auto border = static_cast<std::uint8_t>(Rejection::kBorder);
  const int rows = in_disp.rows, cols = in_disp.cols;
  const int c0 = std::max(0, c - half), c1 = std::min(cols - 1, c + half);
  int count = 0, evaluated = 0;
  for (int rr = std::max(0, r - half); rr <= std::min(rows - 1, r + half); ++rr) {
    const auto* reason_row = in_reason.ptr<std::uint8_t>(rr);
    const auto* disp_row = in_disp.ptr<float>(rr);
    for (int cc = c0; cc <= c1; ++cc) {
      values[count] = disp_row[cc];
      count += reason_row[cc] == accepted;
      evaluated += reason_row[cc] != not_evaluated && reason_row[cc] != border;
    }
  }
  if (reject_isolated && 2 * count < evaluated) {
    disparity->at<float>(r, c) = std::numeric_limits<float>::quiet_NaN();
    rejection->at<std::uint8_t>(r, c) = static_cast<std::uint8_t>(Rejection::kMedian);
  } else {
    disparity->at<float>(r, c) = util::SmallMedian(values, static_cast<std::size_t>(count));
  }
}

// Sorts nine values (floats, or vectors of floats lane by lane) by Bert Dobbelaere's
// 25-comparator network for 9 inputs: min and max only, no branch (the values hold no NaN).
template <typename V>
inline __attribute__((always_inline)) void Sort9(V* x) {
  auto order = [](V& p, V& q) {
    const V lo = q < p ? q : p, hi = q < p ? p : q;
    p = lo;
    q = hi;
  };
  order(x[0], x[3]); order(x[1], x[7]); order(x[2], x[5]); order(x[4], x[8]);
  order(x[0], x[7]); order(x[2], x[4]); order(x[3], x[8]); order(x[5], x[6]);
  order(x[0], x[2]); order(x[1], x[3]); order(x[4], x[5]); order(x[7], x[8]);
  order(x[1], x[4]); order(x[3], x[6]); order(x[5], x[7]);
  order(x[0], x[1]); order(x[2], x[4]); order(x[3], x[5]); order(x[6], x[8]);
  order(x[2], x[3]); order(x[4], x[5]); order(x[6], x[7]);
  order(x[1], x[2]); order(x[3], x[4]); order(x[5], x[6]);
}

// Sorts the n columns of nine rows of values in place, column by column, eight columns at a time
// in vector registers.
__attribute__((target_clones("avx2", "default"))) void NetworkSort9(std::vector<float> (&rows)[9], int n) {
  typedef float Float8 __attribute__((vector_size(32)));
  int c = 0;
  for (; c + 8 <= n; c += 8) {
    Float8 x[9];
    for (int k = 0; k < 9; ++k) std::memcpy(&x[k], rows[k].data() + c, sizeof(Float8));
    Sort9(x);
    for (int k = 0; k < 9; ++k) std::memcpy(rows[k].data() + c, &x[k], sizeof(Float8));
  }
  for (; c < n; ++c) {
    float x[9];
    for (int k = 0; k < 9; ++k) x[k] = rows[k][c];
    Sort9(x);
    for (int k = 0; k < 9; ++k) rows[k][c] = x[k];
  }
}

// The 3 x 3 filter of MedianFilterDisparityGrid, one row pass per grid row: every cell's nine
// neighbours (a neighbour that is outside the grid or not accepted reads +inf) sorted by a
// 25-comparator network, across the row's cells at once (vector min/max), then each accepted
// cell takes the median of its first `count` sorted values, its accepted neighbours: the same
// values SmallMedian picks from the same set, by the same expression. When an accepted cell of
// the three rows holds NaN (which min and max would not order), the row's accepted cells are left
// to FilterCell (`done` 0 for them).
void Median3x3Row(const cv::Mat& in_disp, const cv::Mat& in_reason, int r, bool reject_isolated,
                  std::vector<float> (&sorted)[9], std::vector<int>& acc_cols, std::vector<int>& eval_cols,
                  float* out_disp, std::uint8_t* out_reason, std::uint8_t* done) {
  constexpr float kInf = std::numeric_limits<float>::infinity();
  const int rows = in_disp.rows, cols = in_disp.cols;
  const auto accepted = static_cast<std::uint8_t>(Rejection::kAccepted);
  const auto not_evaluated = static_cast<std::uint8_t>(Rejection::kNotEvaluated);
  const auto border = static_cast<std::uint8_t>(Rejection::kBorder);
  for (auto& v : sorted) v.resize(cols);
  acc_cols.assign(cols + 2, 0);
  eval_cols.assign(cols + 2, 0);
  bool nan_accepted = false;
  // The three rows' values (+inf where not accepted), column sums of the accepted and
  // evaluated flags (index c + 1 for column c).
  for (int dr = -1; dr <= 1; ++dr) {
    const int rr = r + dr;
    for (int dc = -1; dc <= 1; ++dc) {
      float* __restrict v = sorted[(dr + 1) * 3 + dc + 1].data();
      if (rr < 0 || rr >= rows) {
        std::fill(v, v + cols, kInf);
        continue;
      }
      const float* __restrict d = in_disp.ptr<float>(rr);
      const std::uint8_t* __restrict reason = in_reason.ptr<std::uint8_t>(rr);
      // The columns whose neighbour c + dc is inside, without a test (a vector select).
      const int lo = std::max(0, -dc), hi = std::min(cols, cols - dc);
      for (int c = 0; c < lo; ++c) v[c] = kInf;
      for (int c = lo; c < hi; ++c) {
        const float x = d[c + dc];
        v[c] = reason[c + dc] == accepted ? x : kInf;
      }
      for (int c = std::max(lo, hi); c < cols; ++c) v[c] = kInf;
    }
    if (rr < 0 || rr >= rows) continue;
    const float* __restrict d = in_disp.ptr<float>(rr);
    const std::uint8_t* __restrict reason = in_reason.ptr<std::uint8_t>(rr);
    int* __restrict acc = acc_cols.data() + 1;
    int* __restrict eval = eval_cols.data() + 1;
    int nan_count = 0;
    for (int c = 0; c < cols; ++c) {
      const int is_acc = reason[c] == accepted;
      acc[c] += is_acc;
      eval[c] += reason[c] != not_evaluated && reason[c] != border;
      nan_count += is_acc & (d[c] != d[c]);
    }
    nan_accepted |= nan_count > 0;
  }
  NetworkSort9(sorted, cols);
  const std::uint8_t* reason = in_reason.ptr<std::uint8_t>(r);
  for (int c = 0; c < cols; ++c) {
    done[c] = 1;
    if (reason[c] != accepted) continue;
    if (nan_accepted) {
      done[c] = 0;
      continue;
    }
    const int count = acc_cols[c] + acc_cols[c + 1] + acc_cols[c + 2];
    const int evaluated = eval_cols[c] + eval_cols[c + 1] + eval_cols[c + 2];
    if (reject_isolated && 2 * count < evaluated) {
      out_disp[c] = std::numeric_limits<float>::quiet_NaN();
      out_reason[c] = static_cast<std::uint8_t>(Rejection::kMedian);
    } else {
      const int mid = count / 2;
      out_disp[c] = count % 2 == 1 ? sorted[mid][c] : 0.5f * (sorted[mid - 1][c] + sorted[mid][c]);
    }
  }
}

}  // namespace

void MedianFilterDisparityGrid(int size, cv::Mat* disparity, cv::Mat* rejection, bool reject_isolated) {
  LN_CHECK(disparity != nullptr && rejection != nullptr);
  LN_CHECK(disparity->type() == CV_32FC1 && rejection->type() == CV_8UC1 &&
           disparity->size() == rejection->size());
  if (size <= 1 || disparity->empty()) return;
  LN_CHECK(size % 2 == 1) << "median size must be odd";
  const int half = size / 2;
  const int rows = disparity->rows, cols = disparity->cols;
  const cv::Mat in_disp = disparity->clone(), in_reason = rejection->clone();
  if (size == 3) {
    tbb::parallel_for(tbb::blocked_range<int>(0, rows, 8), [&](const tbb::blocked_range<int>& range) {
      std::vector<float> sorted[9];
      std::vector<int> acc_cols, eval_cols;
      std::vector<std::uint8_t> done(cols);
      float values[10];
      for (int r = range.begin(); r != range.end(); ++r) {
        Median3x3Row(in_disp, in_reason, r, reject_isolated, sorted, acc_cols, eval_cols, disparity->ptr<float>(r),
                     rejection->ptr<std::uint8_t>(r), done.data());
        for (int c = 0; c < cols; ++c) {
          if (!done[c]) FilterCell(in_disp, in_reason, half, r, c, reject_isolated, values, disparity, rejection);
        }
      }
    });
    return;
  }
  const cv::Mat accepted_mask = in_reason == static_cast<int>(Rejection::kAccepted);
  // Fast path: where the whole neighbourhood is accepted, OpenCV's median (a SIMD sorting
  // network, k = 5 for float) is the answer, copied under a mask.
  // (A fresh matrix: assigning an expression to a header that shares accepted_mask's buffer
  // would write the result into accepted_mask.)
  cv::Mat partial;
  if (size == 5 && rows >= size && cols >= size) {
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
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, remaining.size(), 256),
                    [&](const tbb::blocked_range<std::size_t>& range) {
    std::vector<float> values(static_cast<std::size_t>(size) * size + 1);
    for (std::size_t p = range.begin(); p != range.end(); ++p) {
      FilterCell(in_disp, in_reason, half, remaining[p].y, remaining[p].x, reject_isolated, values.data(), disparity,
                 rejection);
    }
  });
}

}  // namespace lunarnav::stereo
