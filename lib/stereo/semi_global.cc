#include "stereo/semi_global.h"

#include <algorithm>
#include <cstring>

#include <opencv2/core.hpp>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include "util/check.h"

// The cost fill and the two passes are compiled for AVX2 (with POPCNT) and for plain x86-64,
// chosen at start-up; the arithmetic is integer, so both give the same bits.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(__SANITIZE_ADDRESS__)
#define LN_SGM_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define LN_SGM_CLONES
#endif

namespace lunarnav::stereo::internal {
namespace {

template <typename T>
void CensusRows(const cv::Mat& padded, int half_x, int half_y, int width, const cv::Range& rows,
                int pad_row0, std::uint64_t* codes) {
  tbb::parallel_for(rows.start, rows.end, [&](int y) {
    const int py = y - pad_row0 + half_y;  // row of the centre in `padded`
    std::uint64_t* out = codes + static_cast<std::size_t>(y) * width;
    std::fill(out, out + width, std::uint64_t{0});
    for (int wy = -half_y; wy <= half_y; ++wy) {
      const T* centre = padded.ptr<T>(py) + half_x;
      const T* row = padded.ptr<T>(py + wy) + half_x;
      for (int wx = -half_x; wx <= half_x; ++wx) {
        if (wx == 0 && wy == 0) continue;
        for (int x = 0; x < width; ++x) {
          out[x] = (out[x] << 1) | static_cast<std::uint64_t>(row[x + wx] < centre[x]);
        }
      }
    }
  });
}

constexpr std::int16_t kSentinel = 0x3000;  // beyond any path cost; + P2 stays in int16

// One step of a path: L(p, k) = C(p, k) + min(L(q, k), L(q, k +- 1) + P1, min_k L(q) + P2)
// - min_k L(q), q the previous pixel on the path; `prev` has sentinels at [-1] and [n].
// Accumulates L into `sum` (assigns when kFirst) and returns min_k L(p, k).
template <bool kFirst>
inline __attribute__((always_inline)) std::int16_t Step(const std::uint8_t* cost, const std::int16_t* prev,
                                                        std::int16_t prev_min, std::int16_t p1,
                                                        std::int16_t p2, int n, std::int16_t* out,
                                                        std::uint16_t* sum) {
  const std::int16_t jump = static_cast<std::int16_t>(prev_min + p2);
  std::int16_t new_min = kSentinel;
  for (int k = 0; k < n; ++k) {
    const std::int16_t side = static_cast<std::int16_t>(std::min(prev[k - 1], prev[k + 1]) + p1);
    const std::int16_t best = std::min(std::min(prev[k], side), jump);
    const std::int16_t v = static_cast<std::int16_t>(cost[k] + best - prev_min);
    out[k] = v;
    new_min = std::min(new_min, v);
    if constexpr (kFirst) {
      sum[k] = static_cast<std::uint16_t>(v);
    } else {
      sum[k] = static_cast<std::uint16_t>(sum[k] + v);
    }
  }
  return new_min;
}

// The first pixel of a path: L = C.
template <bool kFirst>
inline __attribute__((always_inline)) std::int16_t Start(const std::uint8_t* cost, int n, std::int16_t* out,
                                                         std::uint16_t* sum) {
  std::int16_t new_min = kSentinel;
  for (int k = 0; k < n; ++k) {
    const std::int16_t v = cost[k];
    out[k] = v;
    new_min = std::min(new_min, v);
    if constexpr (kFirst) {
      sum[k] = static_cast<std::uint16_t>(v);
    } else {
      sum[k] = static_cast<std::uint16_t>(sum[k] + v);
    }
  }
  return new_min;
}

// Path buffers of one pass: for each direction with a vertical component, the previous and
// the current row of L (n + 2 entries a pixel, sentinels at both ends) and their minima;
// for the horizontal direction, the previous pixel's.
struct PassBuffers {
  int n = 0, cols = 0, stride = 0;
  std::vector<std::int16_t> rows[3][2];  // [direction: diagonal a, vertical, diagonal b][prev/cur]
  std::vector<std::int16_t> mins[3][2];
  std::vector<std::int16_t> horizontal[2];
  void Init(int num_cols, int num_disp) {
    n = num_disp;
    cols = num_cols;
    stride = num_disp + 2;
    for (auto& dir : rows) {
      for (auto& r : dir) r.assign(static_cast<std::size_t>(stride) * cols, kSentinel);
    }
    for (auto& dir : mins) {
      for (auto& m : dir) m.assign(cols, 0);
    }
    for (auto& h : horizontal) h.assign(stride, kSentinel);
  }
  std::int16_t* Row(int dir, int which, int i) { return rows[dir][which].data() + static_cast<std::size_t>(i) * stride + 1; }
};

// One pass over the grid. kForward: rows top to bottom, columns left to right, paths from
// the left, top-left, top and top-right; otherwise the mirror image. With four paths only the
// horizontal and the vertical one.
template <bool kForward>
inline __attribute__((always_inline)) void Pass(const SgmInput& in, const std::uint8_t* cost, std::uint16_t* sum, PassBuffers* b) {
  const int n = in.num_disp, cols = in.num_cols, rows = in.num_rows;
  const auto p1 = static_cast<std::int16_t>(in.penalty_small);
  const auto p2 = static_cast<std::int16_t>(in.penalty_large);
  const bool diagonals = in.num_paths == 8;
  const int di = kForward ? 1 : -1;
  int cur = 0;
  for (int jj = 0; jj < rows; ++jj) {
    const int j = kForward ? jj : rows - 1 - jj;
    const int prev = cur ^ 1;
    const bool has_prev_row = jj > 0;
    std::int16_t h_min = 0;
    int h_cur = 0;
    for (int ii = 0; ii < cols; ++ii) {
      const int i = kForward ? ii : cols - 1 - ii;
      const std::size_t at = (static_cast<std::size_t>(j) * cols + i) * n;
      const std::uint8_t* c = cost + at;
      std::uint16_t* s = sum + at;
      // Horizontal path (from the left in the forward pass).
      std::int16_t* h_out = b->horizontal[h_cur].data() + 1;
      if (ii == 0) {
        h_min = Start<true>(c, n, h_out, s);
      } else {
        h_min = Step<true>(c, b->horizontal[h_cur ^ 1].data() + 1, h_min, p1, p2, n, h_out, s);
      }
      h_cur ^= 1;
      // Vertical path (from the top in the forward pass).
      std::int16_t* v_out = b->Row(1, cur, i);
      b->mins[1][cur][i] = has_prev_row ? Step<false>(c, b->Row(1, prev, i), b->mins[1][prev][i], p1, p2, n, v_out, s)
                                        : Start<false>(c, n, v_out, s);
      if (!diagonals) continue;
      // Diagonals: from (i - di, j - dj) and from (i + di, j - dj).
      const int ia = i - di, ib = i + di;
      std::int16_t* a_out = b->Row(0, cur, i);
      b->mins[0][cur][i] = has_prev_row && ia >= 0 && ia < cols
                               ? Step<false>(c, b->Row(0, prev, ia), b->mins[0][prev][ia], p1, p2, n, a_out, s)
                               : Start<false>(c, n, a_out, s);
      std::int16_t* b_out = b->Row(2, cur, i);
      b->mins[2][cur][i] = has_prev_row && ib >= 0 && ib < cols
                               ? Step<false>(c, b->Row(2, prev, ib), b->mins[2][prev][ib], p1, p2, n, b_out, s)
                               : Start<false>(c, n, b_out, s);
    }
    cur ^= 1;
  }
}

LN_SGM_CLONES void ForwardPass(const SgmInput& in, const std::uint8_t* cost, std::uint16_t* sum, PassBuffers* b) {
  Pass<true>(in, cost, sum, b);
}
LN_SGM_CLONES void BackwardPass(const SgmInput& in, const std::uint8_t* cost, std::uint16_t* sum, PassBuffers* b) {
  Pass<false>(in, cost, sum, b);
}

LN_SGM_CLONES void FillCostRow(const SgmInput& in, int j, std::uint8_t* cost) {
  const int n = in.num_disp, width = in.width;
  const int y = in.y0 + j * in.step_y;
  const std::uint64_t* ref = in.ref_census + static_cast<std::size_t>(y) * width;
  const std::uint64_t* tgt = in.tgt_census + static_cast<std::size_t>(y) * width;
  for (int i = 0; i < in.num_cols; ++i) {
    const int x = in.x0 + i * in.step_x;
    std::uint8_t* c = cost + (static_cast<std::size_t>(j) * in.num_cols + i) * n;
    // Target x + d_min + k inside [0, width): k in [k_lo, k_hi).
    const int k_lo = std::clamp(-x - in.d_min, 0, n);
    const int k_hi = std::clamp(width - x - in.d_min, k_lo, n);
    const std::uint64_t r = ref[x];
    const std::uint64_t* t = tgt + x + in.d_min;
    for (int k = k_lo; k < k_hi; ++k) c[k] = static_cast<std::uint8_t>(__builtin_popcountll(r ^ t[k]));
    // Beyond the image the nearest valid cost is repeated: a fixed high cost would push the
    // paths towards the disparities that stay inside and break the ties of repeated patterns
    // in favour of the wrong period.
    const std::uint8_t first = k_lo < k_hi ? c[k_lo] : kInvalidCensusCost;
    const std::uint8_t last = k_lo < k_hi ? c[k_hi - 1] : kInvalidCensusCost;
    for (int k = 0; k < k_lo; ++k) c[k] = first;
    for (int k = k_hi; k < n; ++k) c[k] = last;
  }
}

}  // namespace

void CensusTransform(const cv::Mat& image, int half_x, int half_y, const cv::Range& rows,
                     std::vector<std::uint64_t>* codes) {
  LN_CHECK((2 * half_x + 1) * (2 * half_y + 1) - 1 <= 64) << "census window too large";
  LN_CHECK(rows.start >= 0 && rows.end <= image.rows && rows.start <= rows.end);
  codes->resize(static_cast<std::size_t>(image.rows) * image.cols);
  if (rows.empty()) return;
  // The rows needed, replicated at the image's edges.
  const int src_lo = std::max(0, rows.start - half_y), src_hi = std::min(image.rows, rows.end + half_y);
  cv::Mat padded;
  cv::copyMakeBorder(image.rowRange(src_lo, src_hi), padded, half_y - (rows.start - src_lo),
                     half_y - (src_hi - rows.end), half_x, half_x, cv::BORDER_REPLICATE);
  switch (image.depth()) {
    case CV_8U: CensusRows<std::uint8_t>(padded, half_x, half_y, image.cols, rows, rows.start, codes->data()); break;
    case CV_16U: CensusRows<std::uint16_t>(padded, half_x, half_y, image.cols, rows, rows.start, codes->data()); break;
    case CV_16S: CensusRows<std::int16_t>(padded, half_x, half_y, image.cols, rows, rows.start, codes->data()); break;
    default: LN_CHECK(false) << "census: unsupported image depth";
  }
}

bool IsAmbiguousMinimum(const std::uint16_t* s, int k_lo, int k_hi, int best, double uniqueness) {
  int lo = best;
  while (lo > k_lo && s[lo - 1] >= s[lo]) --lo;
  int hi = best;
  while (hi < k_hi && s[hi + 1] >= s[hi]) ++hi;
  int rival = -1;
  for (int k = k_lo; k < lo; ++k) {
    if (rival < 0 || s[k] < s[rival]) rival = k;
  }
  for (int k = hi + 1; k <= k_hi; ++k) {
    if (rival < 0 || s[k] < s[rival]) rival = k;
  }
  return rival >= 0 && static_cast<double>(s[rival]) < (1.0 + uniqueness) * s[best];
}

void AggregatedCost::Costs(int i, int j, std::uint32_t* out) const {
  const std::size_t at = Index(i, j);
  for (int k = 0; k < num_disp_; ++k) out[k] = static_cast<std::uint32_t>(forward_[at + k]) + backward_[at + k];
}

void SemiGlobalAggregate(const SgmInput& in, AggregatedCost* out) {
  LN_CHECK(in.num_paths == 4 || in.num_paths == 8);
  LN_CHECK(in.num_disp >= 1 && in.num_cols >= 0 && in.num_rows >= 0);
  // Every path cost is at most the largest matching cost plus P2, and a pass sums 4 paths.
  LN_CHECK(in.penalty_small >= 0 && in.penalty_large >= in.penalty_small && in.penalty_large <= 2000);
  out->num_cols_ = in.num_cols;
  out->num_rows_ = in.num_rows;
  out->num_disp_ = in.num_disp;
  const std::size_t cells = static_cast<std::size_t>(in.num_cols) * in.num_rows * in.num_disp;
  if (out->cost_.size() < cells) {
    out->cost_.resize(cells);
    out->forward_.resize(cells);
    out->backward_.resize(cells);
  }
  if (cells == 0) return;
  tbb::parallel_for(0, in.num_rows, [&](int j) { FillCostRow(in, j, out->cost_.data()); });
  PassBuffers forward_buffers, backward_buffers;
  tbb::parallel_invoke(
      [&] {
        forward_buffers.Init(in.num_cols, in.num_disp);
        ForwardPass(in, out->cost_.data(), out->forward_.data(), &forward_buffers);
      },
      [&] {
        backward_buffers.Init(in.num_cols, in.num_disp);
        BackwardPass(in, out->cost_.data(), out->backward_.data(), &backward_buffers);
      });
}

}  // namespace lunarnav::stereo::internal
