// Census cost and semi-global aggregation (Hirschmueller, "Stereo Processing by Semiglobal
// Matching and Mutual Information", PAMI 2008; census cost as in Zabih & Woodfill 1994), the
// core of the quality preset (docs/stereo-matcher.md). Internal to the stereo module.
#pragma once

#include <cstdint>
#include <cstdlib>
#include <vector>

#include <opencv2/core.hpp>

// The stereo module's integer loops (cost fill, paths, minima) are compiled for AVX2 (with
// POPCNT) and for plain x86-64, chosen at start-up; integer arithmetic, so both give the same bits.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(__SANITIZE_ADDRESS__)
#define LN_SGM_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define LN_SGM_CLONES
#endif

namespace lunarnav::stereo::internal {

/// Census transform: bit k of a pixel's code is set when the k-th neighbour of its
/// (2 half_x + 1) x (2 half_y + 1) window (row-major, centre skipped) is darker than the centre.
/// Works on any bit depth (only the order of grey levels matters). Pixels whose window leaves
/// the image compare against the nearest pixel inside (replicated border).
/// @param image  CV_8UC1 or CV_16UC1 (or CV_16SC1).
/// @param rows   the rows to transform, [begin, end); other rows of `codes` are left alone.
/// @param codes  CV_64FC1-sized matrix reinterpreted as uint64 codes (created here, image size).
void CensusTransform(const cv::Mat& image, int half_x, int half_y, const cv::Range& rows,
                     std::vector<std::uint64_t>* codes);

/// What SemiGlobalAggregate needs: census codes of both images on the full pixel grid, the
/// sample grid it matches (partial subsampling: grid pixel (i, j) is image pixel
/// (x0 + i step_x, y0 + j step_y)), and the disparities searched: reference pixel x matches
/// target pixel x + d for d in [d_min, d_min + num_disp), or, with per-row bands, grid row j
/// searches d_min + row_shift[j] + k for k in [0, row_num_disp[j]).
struct SgmInput {
  const std::uint64_t* ref_census = nullptr;
  const std::uint64_t* tgt_census = nullptr;
  int width = 0;  ///< Image width (stride of the census arrays).
  int x0 = 0, y0 = 0, step_x = 1, step_y = 1, num_cols = 0, num_rows = 0;
  int d_min = 0, num_disp = 1;
  int penalty_small = 8;   ///< P1: a disparity change of one pixel between neighbours.
  int penalty_large = 96;  ///< P2: a larger change.
  /// Edge-aware P2: with the reference image's grey levels (8-bit scale, same layout as the
  /// census arrays) and edge_levels > 0, a step between neighbours whose grey levels differ by
  /// g costs max(P1 + 1, P2 e / (e + g)) instead of P2 (depth edges usually are intensity
  /// edges). Null or 0 = a constant P2.
  const std::int16_t* ref_grey = nullptr;
  int edge_levels = 0;
  /// Gradient term of the cost (SemiGlobalOptions::gradient_weight): with both images'
  /// horizontal derivatives (in sixteenths of an 8-bit grey level, so that data of any depth
  /// gives nearly the same values; same layout as the census arrays), the cost of reference
  /// pixel x at target x + d adds (min(|g_ref(x) - g_tgt(x + d)|, cap) w16) / 256 (integer
  /// division). Null = census only. |g| <= 4080, w16 cap <= 16384.
  const std::int16_t* ref_gradient = nullptr;
  const std::int16_t* tgt_gradient = nullptr;
  int gradient_weight16 = 0;  ///< The weight in sixteenths of a census bit per level.
  int gradient_cap = 0;       ///< In sixteenths of a level.
  int num_paths = 8;       ///< 4 (horizontal and vertical) or 8 (and diagonals).
  /// Per-row bands (num_rows entries each), or null: every row searches all num_disp. A path
  /// from one row to the next carries each disparity it has in both rows; a disparity the
  /// previous row did not search is reached from its neighbours (P1) or by a jump (P2).
  const int* row_shift = nullptr;     ///< >= 0.
  const int* row_num_disp = nullptr;  ///< In [1, num_disp].
  /// The expected ground disparity of each grid row, rounded (num_rows entries), or null. A
  /// vertical or diagonal path step from row i to row j then also carries disparity d - g(j) +
  /// g(i) of row i to d at no penalty (the ground's own change of disparity between the rows),
  /// besides d itself (an upright face's): neither pays P2 where rows are far apart.
  const int* row_ground = nullptr;
  int Shift(int j) const { return row_shift ? row_shift[j] : 0; }
  /// The ground's change of disparity from row i to row j that the paths follow: 0 without
  /// row_ground, where it is one pixel or none (P1 carries that) and where it exceeds the
  /// search's range (no ground's).
  int GroundSlope(int j, int i) const {
    if (row_ground == nullptr) return 0;
    const int s = row_ground[j] - row_ground[i];
    return std::abs(s) < 2 || std::abs(s) > num_disp ? 0 : s;
  }
  int RowDisp(int j) const { return row_num_disp ? row_num_disp[j] : num_disp; }
};

/// A large array on 2 MiB pages where the kernel offers them (madvise), so that a fresh pair's
/// hundreds of megabytes cost hundreds, not hundreds of thousands, of page faults. Grows only.
template <typename T>
class LargeArray {
 public:
  LargeArray() = default;
  LargeArray(const LargeArray&) = delete;
  LargeArray& operator=(const LargeArray&) = delete;
  ~LargeArray() { Release(); }
  /// Makes room for n elements (contents undefined).
  void Reserve(std::size_t n);
  T* data() { return data_; }
  const T* data() const { return data_; }
  T& operator[](std::size_t i) { return data_[i]; }
  const T& operator[](std::size_t i) const { return data_[i]; }
  std::size_t capacity() const { return capacity_; }

 private:
  void Release();
  T* data_ = nullptr;
  std::size_t capacity_ = 0;
  std::size_t bytes_ = 0;
};

/// The aggregated costs of a pair: for every grid pixel, num_disp sums over the paths.
class AggregatedCost {
 public:
  int num_cols() const { return num_cols_; }
  int num_rows() const { return num_rows_; }
  int num_disp() const { return num_disp_; }
  /// The sums of grid pixel (i, j): SgmInput::RowDisp(j) of them.
  const std::uint16_t* sum(int i, int j) const { return &sum_[Index(i, j)]; }

 private:
  friend void SemiGlobalAggregate(const SgmInput& in, AggregatedCost* out);
  std::size_t Index(int i, int j) const {
    return row_start_.empty() ? (static_cast<std::size_t>(j) * num_cols_ + i) * num_disp_
                              : row_start_[j] + static_cast<std::size_t>(i) * row_disp_[j];
  }
  int num_cols_ = 0, num_rows_ = 0, num_disp_ = 0;
  std::vector<std::size_t> row_start_;  // per-row bands: where row j's sums start
  std::vector<int> row_disp_;
  LargeArray<std::uint16_t> sum_;
};

/// The quality preset's ambiguity test on a pixel's aggregated costs s[k_lo .. k_hi] with its
/// minimum at `best`: the minimum's lobe is the run of disparities on either side over which s
/// does not fall again; the rival is the lowest cost outside the lobe. True when
/// rival < (1 + uniqueness) s[best]. A single minimum, however broad or rippled its flanks
/// are near the top, has no rival; a repeated pattern has one at its period.
/// (Inline: it runs inside the selection's loop, compiled for the same instruction sets.)
inline __attribute__((always_inline)) bool IsAmbiguousMinimum(const std::uint16_t* s, int k_lo, int k_hi, int best,
                                                              double uniqueness) {
  int lo = best;
  while (lo > k_lo && s[lo - 1] >= s[lo]) --lo;
  int hi = best;
  while (hi < k_hi && s[hi + 1] >= s[hi]) ++hi;
  if (lo == k_lo && hi == k_hi) return false;  // no disparity outside the lobe
  std::uint16_t rival = 0xffff;
  for (int k = k_lo; k < lo; ++k) rival = s[k] < rival ? s[k] : rival;
  for (int k = hi + 1; k <= k_hi; ++k) rival = s[k] < rival ? s[k] : rival;
  return static_cast<double>(rival) < (1.0 + uniqueness) * s[best];
}

/// Matching cost of the disparities of a pixel none of whose targets is inside the image (a
/// pixel with some inside repeats the nearest inside cost for the others).
inline constexpr int kInvalidCensusCost = 64;

/// Aggregates the census costs along num_paths directions: the horizontal paths row by row
/// (rows in parallel), then the vertical and diagonal paths downwards and upwards (each row's
/// columns in parallel), computing the costs as they are needed (no cost volume). Runs in the
/// current TBB arena; the sums' array in `out` is reused when large enough.
void SemiGlobalAggregate(const SgmInput& in, AggregatedCost* out);

}  // namespace lunarnav::stereo::internal
