#include "stereo/semi_global.h"

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <new>
#include <type_traits>

#include <sys/mman.h>

#include <opencv2/core.hpp>
#include <tbb/parallel_for.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/partitioner.h>
#include <tbb/task_arena.h>

#include "stereo/census_hamming.h"
#include "util/check.h"

namespace lunarnav::stereo::internal {
namespace {

// Row y's codes: one pass over the row per neighbour of the window (the codes stay in L1).
template <typename T>
inline __attribute__((always_inline)) void CensusRow(const cv::Mat& padded, int half_x, int half_y, int width,
                                                     int py, std::uint64_t* out) {
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
}
LN_SGM_CLONES void CensusRow8(const cv::Mat& padded, int half_x, int half_y, int width, int py, std::uint64_t* out) {
  CensusRow<std::uint8_t>(padded, half_x, half_y, width, py, out);
}
LN_SGM_CLONES void CensusRow16(const cv::Mat& padded, int half_x, int half_y, int width, int py, std::uint64_t* out) {
  CensusRow<std::uint16_t>(padded, half_x, half_y, width, py, out);
}
LN_SGM_CLONES void CensusRow16s(const cv::Mat& padded, int half_x, int half_y, int width, int py,
                                std::uint64_t* out) {
  CensusRow<std::int16_t>(padded, half_x, half_y, width, py, out);
}

template <typename T>
void CensusRows(const cv::Mat& padded, int half_x, int half_y, int width, const cv::Range& rows,
                int pad_row0, std::uint64_t* codes) {
  tbb::parallel_for(rows.start, rows.end, [&](int y) {
    const int py = y - pad_row0 + half_y;  // row of the centre in `padded`
    std::uint64_t* out = codes + static_cast<std::size_t>(y) * width;
    if constexpr (std::is_same_v<T, std::uint8_t>) {
      CensusRow8(padded, half_x, half_y, width, py, out);
    } else if constexpr (std::is_same_v<T, std::uint16_t>) {
      CensusRow16(padded, half_x, half_y, width, py, out);
    } else {
      CensusRow16s(padded, half_x, half_y, width, py, out);
    }
  });
}

constexpr std::int16_t kSentinel = 0x3000;  // beyond any path cost; + P2 stays in int16

// One step of a path: L(p, k) = C(p, k) + min(L(q, k), L(q, k +- 1) + P1, min_k L(q) + P2)
// - min_k L(q), q the previous pixel on the path; `prev` has sentinels at [-1] and [n].
// Accumulates L into `sum` (assigns when kFirst) and returns min_k L(p, k).
// What a path step does with the sums: assign its L, add it, or leave them (the caller adds
// several paths at once, so the large array of sums is read and written once for them).
enum class SumMode { kAssign, kAdd, kNone };

template <SumMode kMode>
inline __attribute__((always_inline)) void Accumulate(std::int16_t v, std::uint16_t* sum) {
  if constexpr (kMode == SumMode::kAssign) {
    *sum = static_cast<std::uint16_t>(v);
  } else if constexpr (kMode == SumMode::kAdd) {
    *sum = static_cast<std::uint16_t>(*sum + v);
  }
}

template <SumMode kMode>
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
    Accumulate<kMode>(v, &sum[k]);
  }
  return new_min;
}

// Step with a second predecessor at no penalty: `prev2` (the previous row read at the ground's
// change of disparity), with its own neighbours at P1.
template <SumMode kMode>
inline __attribute__((always_inline)) std::int16_t Step2(const std::uint8_t* cost, const std::int16_t* prev,
                                                         const std::int16_t* prev2, std::int16_t prev_min,
                                                         std::int16_t p1, std::int16_t p2, int n, std::int16_t* out,
                                                         std::uint16_t* sum) {
  const std::int16_t jump = static_cast<std::int16_t>(prev_min + p2);
  std::int16_t new_min = kSentinel;
  for (int k = 0; k < n; ++k) {
    const std::int16_t side = static_cast<std::int16_t>(
        std::min(std::min(prev[k - 1], prev[k + 1]), std::min(prev2[k - 1], prev2[k + 1])) + p1);
    const std::int16_t best = std::min(std::min(std::min(prev[k], prev2[k]), side), jump);
    const std::int16_t v = static_cast<std::int16_t>(cost[k] + best - prev_min);
    out[k] = v;
    new_min = std::min(new_min, v);
    Accumulate<kMode>(v, &sum[k]);
  }
  return new_min;
}

// The first pixel of a path: L = C.
template <SumMode kMode>
inline __attribute__((always_inline)) std::int16_t Start(const std::uint8_t* cost, int n, std::int16_t* out,
                                                         std::uint16_t* sum) {
  std::int16_t new_min = kSentinel;
  for (int k = 0; k < n; ++k) {
    const std::int16_t v = cost[k];
    out[k] = v;
    new_min = std::min(new_min, v);
    Accumulate<kMode>(v, &sum[k]);
  }
  return new_min;
}

// Costs of the grid pixels [i_begin, i_end) of row j, n per pixel from cost[0]: the census
// distances by the CPU's kernel, then the gradient term and the edges.
inline __attribute__((always_inline)) void FillCosts(const SgmInput& in, HammingFn hamming, int j, int i_begin,
                                                     int i_end, std::uint8_t* cost) {
  hamming(in, j, i_begin, i_end, cost);
  const int n = in.RowDisp(j), width = in.width;
  const int d_min = in.d_min + in.Shift(j);
  const int y = in.y0 + j * in.step_y;
  for (int i = i_begin; i < i_end; ++i) {
    const int x = in.x0 + i * in.step_x;
    // Target x + d_min + k inside [0, width): k in [k_lo, k_hi), as the census kernel took it.
    const hamming::Span span = hamming::SpanAt(in, j, i, i_begin, cost);
    std::uint8_t* c = span.c;
    const int k_lo = span.k_lo, k_hi = span.k_hi;
    if (in.ref_gradient != nullptr) {
      // |gradient difference| <= 8160 and the term <= 64 bits: no int16 overflow.
      const std::int16_t gr = in.ref_gradient[static_cast<std::size_t>(y) * width + x];
      const std::int16_t* gt = in.tgt_gradient + static_cast<std::size_t>(y) * width + x + d_min;
      const std::int16_t cap = static_cast<std::int16_t>(in.gradient_cap);
      const int w16 = in.gradient_weight16;
      for (int k = k_lo; k < k_hi; ++k) {
        std::int16_t diff = static_cast<std::int16_t>(gr - gt[k]);
        diff = diff < 0 ? static_cast<std::int16_t>(-diff) : diff;
        diff = diff < cap ? diff : cap;
        c[k] = static_cast<std::uint8_t>(c[k] + ((diff * w16) >> 8));
      }
    }
    // Beyond the image the nearest valid cost is repeated: a fixed high cost would push the
    // paths towards the disparities that stay inside and break the ties of repeated patterns
    // in favour of the wrong period.
    const std::uint8_t first = k_lo < k_hi ? c[k_lo] : kInvalidCensusCost;
    const std::uint8_t last = k_lo < k_hi ? c[k_hi - 1] : kInvalidCensusCost;
    for (int k = 0; k < k_lo; ++k) c[k] = first;
    for (int k = k_hi; k < n; ++k) c[k] = last;
  }
}

// P2 by the grey-level step between neighbours (SgmInput::edge_levels): a table over the step
// in 8-bit levels (larger steps use the last entry), built once per pair.
struct EdgePenalties {
  std::int16_t by_step[256];
  explicit EdgePenalties(const SgmInput& in) {
    for (int g = 0; g < 256; ++g) {
      const int p = in.edge_levels > 0 ? in.penalty_large * in.edge_levels / (in.edge_levels + g) : in.penalty_large;
      by_step[g] = static_cast<std::int16_t>(std::max(p, std::min(in.penalty_small + 1, in.penalty_large)));
    }
  }
  std::int16_t operator()(int a, int b) const {
    const int g = a > b ? a - b : b - a;
    return by_step[g < 255 ? g : 255];
  }
};

// The grey levels of grid row j (read at i * step_x), or null without edge-aware penalties.
inline const std::int16_t* GreyRow(const SgmInput& in, int j) {
  if (in.ref_grey == nullptr || in.edge_levels <= 0) return nullptr;
  return in.ref_grey + static_cast<std::size_t>(in.y0 + j * in.step_y) * in.width + in.x0;
}

// Per-thread scratch: one row's costs and each horizontal path's last two pixels.
struct RowScratch {
  std::vector<std::uint8_t> cost;
  std::vector<std::int16_t> line[4];
  void Init(int cols, int n) {
    if (cost.size() < static_cast<std::size_t>(cols) * n) cost.resize(static_cast<std::size_t>(cols) * n);
    for (auto& l : line) l.assign(n + 2, kSentinel);
  }
};

// How far ahead (in pixels) the path loops ask for the sums they will read or write: the
// paths' steps take long enough for them to arrive, where the processor's own prefetching left
// the sums' loop waiting on memory.
constexpr int kSumsAhead = 3;

// One horizontal path along a row: its last two pixels' L (with sentinels) and minimum.
struct HorizontalChain {
  std::int16_t* line[2];
  std::int16_t m = 0;
};

// The path's t-th pixel, column i (its predecessor in column `from`).
template <SumMode kMode>
inline __attribute__((always_inline)) void HorizontalStep(const std::uint8_t* cost, const std::int16_t* grey,
                                                          const EdgePenalties& edge, int sx, int n, int t, int i,
                                                          int from, std::int16_t p1, std::int16_t p2,
                                                          HorizontalChain* chain, std::uint16_t* row_sum) {
  const std::uint8_t* c = cost + static_cast<std::size_t>(i) * n;
  std::uint16_t* s = row_sum + static_cast<std::size_t>(i) * n;
  std::int16_t* out = chain->line[t & 1];
  if (t == 0) {
    chain->m = Start<kMode>(c, n, out, s);
  } else {
    const std::int16_t p2_here = grey == nullptr ? p2 : edge(grey[i * sx], grey[from * sx]);
    chain->m = Step<kMode>(c, chain->line[(t & 1) ^ 1], chain->m, p1, p2_here, n, out, s);
  }
}

// Both horizontal paths of row j, from the left and from the right, a pixel of each per step:
// each path's step waits for its predecessor's minimum, so two independent chains keep the
// processor busy where one left it waiting. A pixel's sums are assigned by the first path to
// reach it and added to by the second (the same sums as one path after the other).
LN_SGM_CLONES void HorizontalRow(const SgmInput& in, HammingFn hamming, const EdgePenalties& edge, int j,
                                 RowScratch* scratch, std::uint16_t* sum) {
  const int n = in.RowDisp(j), cols = in.num_cols;
  const auto p1 = static_cast<std::int16_t>(in.penalty_small);
  const auto p2 = static_cast<std::int16_t>(in.penalty_large);
  const std::uint8_t* cost = scratch->cost.data();
  FillCosts(in, hamming, j, 0, cols, scratch->cost.data());
  const std::int16_t* grey = GreyRow(in, j);
  const int sx = in.step_x;
  std::uint16_t* row_sum = sum;  // row j's sums (the caller's offset)
  HorizontalChain left{{scratch->line[0].data() + 1, scratch->line[1].data() + 1}};
  HorizontalChain right{{scratch->line[2].data() + 1, scratch->line[3].data() + 1}};
  // Steps t < half: both paths on pixels the other has not reached; with an odd width they
  // meet on the middle pixel at t = half; after it both add.
  const int half = cols / 2;
  int t = 0;
  for (; t < half; ++t) {
    if (t + kSumsAhead < half) {  // the sums about to be assigned, asked for ahead (as in VerticalChunk)
      const char* ahead_left = reinterpret_cast<const char*>(row_sum + static_cast<std::size_t>(t + kSumsAhead) * n);
      const char* ahead_right =
          reinterpret_cast<const char*>(row_sum + static_cast<std::size_t>(cols - 1 - t - kSumsAhead) * n);
      for (int line = 0; line < n * 2; line += 64) {
        __builtin_prefetch(ahead_left + line, 1);
        __builtin_prefetch(ahead_right + line, 1);
      }
    }
    HorizontalStep<SumMode::kAssign>(cost, grey, edge, sx, n, t, t, t - 1, p1, p2, &left, row_sum);
    HorizontalStep<SumMode::kAssign>(cost, grey, edge, sx, n, t, cols - 1 - t, cols - t, p1, p2, &right, row_sum);
  }
  if (cols % 2 == 1) {
    HorizontalStep<SumMode::kAssign>(cost, grey, edge, sx, n, t, t, t - 1, p1, p2, &left, row_sum);
    HorizontalStep<SumMode::kAdd>(cost, grey, edge, sx, n, t, cols - 1 - t, cols - t, p1, p2, &right, row_sum);
    ++t;
  }
  for (; t < cols; ++t) {
    HorizontalStep<SumMode::kAdd>(cost, grey, edge, sx, n, t, t, t - 1, p1, p2, &left, row_sum);
    HorizontalStep<SumMode::kAdd>(cost, grey, edge, sx, n, t, cols - 1 - t, cols - t, p1, p2, &right, row_sum);
  }
}

// The previous and the current row of the vertical and diagonal paths of one direction of
// travel (down or up): L with sentinels at both ends of each pixel's n values, and minima.
// With per-row bands a pixel's n values are read shifted by the change of band between the
// rows (Step reads prev[k - 1 .. k + 1] at prev + shift): `pad` sentinels on each side of the
// widest band keep every read outside the previous row's own band on a sentinel.
struct VerticalRows {
  int n = 0, cols = 0, stride = 0, pad = 1;
  std::vector<std::int16_t> rows[3][2];  // [from i - 1, from i, from i + 1][previous/current]
  std::vector<std::int16_t> mins[3][2];
  void Init(int num_cols, int num_disp, int padding) {
    n = num_disp;
    cols = num_cols;
    pad = padding;
    stride = num_disp + 2 * pad;
    for (auto& dir : rows) {
      for (auto& r : dir) r.assign(static_cast<std::size_t>(stride) * cols, kSentinel);
    }
    for (auto& dir : mins) {
      for (auto& m : dir) m.assign(cols, 0);
    }
  }
  std::int16_t* Row(int dir, int which, int i) {
    return rows[dir][which].data() + static_cast<std::size_t>(i) * stride + pad;
  }
};

// The vertical path (and with 8 paths the two diagonals) of the grid pixels [i_begin, i_end)
// of row j, from the previous row of the direction of travel (none when first); adds to the
// sums. Columns are independent given the previous row, so chunks of a row run in parallel.
LN_SGM_CLONES void VerticalChunk(const SgmInput& in, HammingFn hamming, const EdgePenalties& edge, int j, bool down,
                                 bool first, int cur,
                                 int i_begin, int i_end,
                                 std::uint8_t* cost, VerticalRows* b, std::uint16_t* sum) {
  const int n = in.RowDisp(j), cols = in.num_cols;
  const auto p1 = static_cast<std::int16_t>(in.penalty_small);
  const bool diagonals = in.num_paths == 8;
  const int prev = cur ^ 1;
  // Index k of this row is index k + shift of the previous row of the direction of travel.
  const int shift = first ? 0 : in.Shift(j) - in.Shift(down ? j - 1 : j + 1);
  // The ground's change of disparity from the previous row: its index k + shift - slope. A
  // change of one pixel P1 already carries; only a larger one takes the second predecessor
  // (SgmInput::GroundSlope).
  const int slope = first ? 0 : in.GroundSlope(j, down ? j - 1 : j + 1);
  const bool banded = in.row_num_disp != nullptr;
  FillCosts(in, hamming, j, i_begin, i_end, cost);
  const auto p2 = static_cast<std::int16_t>(in.penalty_large);
  const std::int16_t* grey = GreyRow(in, j);
  const std::int16_t* grey_from = first ? nullptr : GreyRow(in, down ? j - 1 : j + 1);
  const int sx = in.step_x;
  for (int i = i_begin; i < i_end; ++i) {
    const std::uint8_t* c = cost + static_cast<std::size_t>(i - i_begin) * n;
    std::uint16_t* s = sum + static_cast<std::size_t>(i) * n;  // row j's sums (the caller's offset)
    // The sums of a pixel a few ahead asked for now (kSumsAhead).
    if (i + kSumsAhead < i_end) {
      const char* ahead = reinterpret_cast<const char*>(s + static_cast<std::size_t>(kSumsAhead) * n);
      for (int line = 0; line < n * 2; line += 64) __builtin_prefetch(ahead + line, 1);
    }
    for (int dir = diagonals ? 0 : 1; dir < (diagonals ? 3 : 2); ++dir) {
      const int from = i + dir - 1;  // column of the predecessor in the previous row
      std::int16_t* out = b->Row(dir, cur, i);
      if (!first && from >= 0 && from < cols) {
        const std::int16_t p2_here = grey == nullptr ? p2 : edge(grey[i * sx], grey_from[from * sx]);
        const std::int16_t* from_row = b->Row(dir, prev, from);
        b->mins[dir][cur][i] = slope == 0 ? Step<SumMode::kNone>(c, from_row + shift, b->mins[dir][prev][from], p1,
                                                                 p2_here, n, out, s)
                                          : Step2<SumMode::kNone>(c, from_row + shift, from_row + shift - slope,
                                                                  b->mins[dir][prev][from], p1, p2_here, n, out, s);
      } else {
        b->mins[dir][cur][i] = Start<SumMode::kNone>(c, n, out, s);
      }
      // What lies past this row's band in the buffer is read as "not searched" by the next row.
      if (banded) std::fill(out + n, out + std::min(b->n + b->pad, n + b->pad), kSentinel);
    }
    // The sums read and written once for the pixel's paths.
    const std::int16_t* v = b->Row(1, cur, i);
    if (diagonals) {
      const std::int16_t* a = b->Row(0, cur, i);
      const std::int16_t* d = b->Row(2, cur, i);
      for (int k = 0; k < n; ++k) s[k] = static_cast<std::uint16_t>(s[k] + a[k] + v[k] + d[k]);
    } else {
      for (int k = 0; k < n; ++k) s[k] = static_cast<std::uint16_t>(s[k] + v[k]);
    }
  }
}

}  // namespace

template <typename T>
void LargeArray<T>::Reserve(std::size_t n) {
  if (n <= capacity_) return;
  Release();
  constexpr std::size_t kHugePage = std::size_t{2} << 20;
  bytes_ = (n * sizeof(T) + kHugePage - 1) / kHugePage * kHugePage;
  void* p = std::aligned_alloc(kHugePage, bytes_);
  if (p == nullptr) throw std::bad_alloc();
#ifdef MADV_HUGEPAGE
  madvise(p, bytes_, MADV_HUGEPAGE);  // a hint: without huge pages the array works the same
#endif
  data_ = static_cast<T*>(p);
  capacity_ = bytes_ / sizeof(T);
}

template <typename T>
void LargeArray<T>::Release() {
  std::free(data_);
  data_ = nullptr;
  capacity_ = bytes_ = 0;
}

template class LargeArray<std::uint8_t>;
template class LargeArray<std::uint16_t>;

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

void SemiGlobalAggregate(const SgmInput& in, AggregatedCost* out) {
  LN_CHECK(in.num_paths == 4 || in.num_paths == 8);
  LN_CHECK(in.num_disp >= 1 && in.num_cols >= 0 && in.num_rows >= 0);
  // Every path cost is at most the largest matching cost plus P2: 8 paths fit 16 bits.
  LN_CHECK(in.penalty_small >= 0 && in.penalty_large >= in.penalty_small && in.penalty_large <= 2000);
  out->num_cols_ = in.num_cols;
  out->num_rows_ = in.num_rows;
  out->num_disp_ = in.num_disp;
  out->row_start_.clear();
  out->row_disp_.clear();
  std::size_t cells = static_cast<std::size_t>(in.num_cols) * in.num_rows * in.num_disp;
  int pad = 1;  // sentinels each side of a pixel's values in the vertical paths' rows
  if (in.row_num_disp != nullptr) {
    LN_CHECK(in.row_shift != nullptr);
    out->row_start_.resize(in.num_rows);
    out->row_disp_.assign(in.row_num_disp, in.row_num_disp + in.num_rows);
    cells = 0;
    for (int j = 0; j < in.num_rows; ++j) {
      LN_CHECK(in.row_num_disp[j] >= 1 && in.row_num_disp[j] <= in.num_disp && in.row_shift[j] >= 0);
      out->row_start_[j] = cells;
      cells += static_cast<std::size_t>(in.num_cols) * in.row_num_disp[j];
      if (j > 0) {
        // Reads run from shift - 1 to n + shift in the previous row's buffer (both directions).
        const int up = in.row_shift[j] - in.row_shift[j - 1], down = -up;
        pad = std::max({pad, 1 - up, 1 - down, in.row_num_disp[j] + up - in.num_disp + 1,
                        in.row_num_disp[j - 1] + down - in.num_disp + 1, in.row_num_disp[j] + up - in.row_num_disp[j - 1] + 1,
                        in.row_num_disp[j - 1] + down - in.row_num_disp[j] + 1});
      }
    }
  }
  // The ground's reads lie |slope| further from the band's ends than the band's own.
  if (in.row_ground != nullptr) {
    int widest = 0;
    for (int j = 1; j < in.num_rows; ++j) widest = std::max(widest, std::abs(in.GroundSlope(j, j - 1)));
    pad += widest;
  }
  out->sum_.Reserve(cells);
  if (cells == 0) return;
  std::uint16_t* sum = out->sum_.data();
  auto row_sum = [&](int j) { return sum + out->Index(0, j); };
  const EdgePenalties edge(in);
  static const HammingFn hamming = SelectHammingKernel();
  // The horizontal paths: rows are independent.
  tbb::enumerable_thread_specific<RowScratch> scratch;
  tbb::parallel_for(0, in.num_rows, [&](int j) {
    RowScratch& s = scratch.local();
    s.Init(in.num_cols, in.num_disp);
    HorizontalRow(in, hamming, edge, j, &s, row_sum(j));
  });
  // The vertical and diagonal paths, down then up: row after row, each row's columns in as
  // many chunks as the arena has threads.
  const int chunks = std::max(1, std::min(tbb::this_task_arena::max_concurrency(), in.num_cols / 64));
  VerticalRows rows;
  for (const bool down : {true, false}) {
    rows.Init(in.num_cols, in.num_disp, pad);
    int cur = 0;
    for (int jj = 0; jj < in.num_rows; ++jj) {
      const int j = down ? jj : in.num_rows - 1 - jj;
      auto run = [&](int chunk) {
        const int begin = static_cast<int>(static_cast<long>(in.num_cols) * chunk / chunks);
        const int end = static_cast<int>(static_cast<long>(in.num_cols) * (chunk + 1) / chunks);
        RowScratch& s = scratch.local();
        s.Init(in.num_cols, in.num_disp);
        VerticalChunk(in, hamming, edge, j, down, jj == 0, cur, begin, end, s.cost.data(), &rows, row_sum(j));
      };
      if (chunks == 1) {
        run(0);
      } else {
        tbb::parallel_for(0, chunks, run, tbb::static_partitioner());
      }
      cur ^= 1;
    }
  }
}

}  // namespace lunarnav::stereo::internal
