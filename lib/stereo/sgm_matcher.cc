// The quality preset's matcher: census cost, semi-global aggregation, and the paper's
// confidence and filters with the checks real scenes need (docs/stereo-matcher.md).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include "stereo/correlation_curve.h"
#include "stereo/disparity_filters.h"
#include "stereo/semi_global.h"
#include "stereo/sgm_matcher.h"
#include "util/check.h"
#include "util/timer.h"

namespace lunarnav::stereo::internal {
namespace {

// Per-thread buffers reused across the pairs of a batch.
struct SgmWorkspace {
  std::vector<std::uint64_t> ref_census, tgt_census;
  AggregatedCost cost;
};
SgmWorkspace& ThreadSgmWorkspace() {
  thread_local SgmWorkspace workspace;
  return workspace;
}

// The first k in [k_lo, k_hi] of the smallest s[k].
inline __attribute__((always_inline)) int ArgMin(const std::uint16_t* s, int k_lo, int k_hi) {
  std::uint16_t smallest = std::numeric_limits<std::uint16_t>::max();
  for (int k = k_lo; k <= k_hi; ++k) smallest = std::min(smallest, s[k]);
  int k = k_lo;
  while (s[k] != smallest) ++k;
  return k;
}

// The left-right check's view from the target image: target column shift + k keeps the
// smallest cost any reference pixel gives it, and that pixel's k (`cost` and `index` point at
// column `shift`).
inline __attribute__((always_inline)) void TargetMinimum(const std::uint16_t* s, int k_lo, int k_hi,
                                                         std::uint16_t* cost, int* index) {
  for (int k = k_lo; k <= k_hi; ++k) {
    const bool better = s[k] < cost[k];
    cost[k] = better ? s[k] : cost[k];
    index[k] = better ? k : index[k];
  }
}

int CeilToMultiple(int value, int step) { return (value + step - 1) / step * step; }

// The cross term of the paper's C over the window of half-size (mx, my) between the working
// reference at (x, y) and the working target at (x + d, y): the sum of the products of grey
// levels, in integers. The window must lie inside both images. Sum is a type that holds
// (2 mx + 1)(2 my + 1) products of grey levels exactly.
template <typename Pixel, typename Sum>
Sum WindowCrossSum(const cv::Mat& ref, const cv::Mat& tgt, int mx, int my, int x, int y, int d) {
  Sum s_ro = 0;
  for (int j = -my; j <= my; ++j) {
    const Pixel* r = ref.ptr<Pixel>(y + j) + x;
    const Pixel* o = tgt.ptr<Pixel>(y + j) + x + d;
    for (int i = -mx; i <= mx; ++i) s_ro += static_cast<Sum>(r[i]) * static_cast<Sum>(o[i]);
  }
  return s_ro;
}

// WindowCrossSum for 8-bit windows at most 7 pixels wide (mx <= 3): a row's 8 bytes at a time
// (SSE2: the pixels widened to 16 bits, multiplied and added in pairs into 32 bits), those past
// the window's width masked to 0. The same integer. Needs 8 readable bytes from the window's
// first column in both images (the caller checks).
std::int32_t WindowCrossSum8(const cv::Mat& ref, const cv::Mat& tgt, int mx, int my, int x, int y, int d) {
#if defined(__SSE2__)
  const std::uint64_t keep = (std::uint64_t{1} << (8 * (2 * mx + 1))) - 1;
  const __m128i mask = _mm_set_epi64x(0, static_cast<long long>(keep));
  const __m128i zero = _mm_setzero_si128();
  __m128i acc = zero;
  for (int j = -my; j <= my; ++j) {
    const std::uint8_t* r = ref.ptr<std::uint8_t>(y + j) + x - mx;
    const std::uint8_t* o = tgt.ptr<std::uint8_t>(y + j) + x + d - mx;
    const __m128i a = _mm_and_si128(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(r)), mask);
    const __m128i b = _mm_loadl_epi64(reinterpret_cast<const __m128i*>(o));
    acc = _mm_add_epi32(acc, _mm_madd_epi16(_mm_unpacklo_epi8(a, zero), _mm_unpacklo_epi8(b, zero)));
  }
  acc = _mm_add_epi32(acc, _mm_shuffle_epi32(acc, 0x4E));
  acc = _mm_add_epi32(acc, _mm_shuffle_epi32(acc, 0xB1));
  return _mm_cvtsi128_si32(acc);
#else
  return WindowCrossSum<std::uint8_t, std::int32_t>(ref, tgt, mx, my, x, y, d);
#endif
}

// The matcher's sample grid (partial subsampling: grid pixel (i, j) is working-image pixel
// (x0 + i dx, grid_lo + j dy)) and its search: per grid row, the first disparity and how many
// (per-row bands, or the one range). Working images: the reference pixel x matches the target
// pixel x + d (the right-reference convention; with the left image as reference both images
// are mirrored).
struct SearchGrid {
  int width = 0, height = 0, dx = 1, dy = 1;
  bool flip = false;
  int band_lo = 0, band_hi = -1;  // the rows asked for
  int grid_lo = 0, grid_hi = -1, num_rows = 0, x0 = 0, num_cols = 0;
  int d_min = 0, n = 1;
  bool banded = false;
  std::vector<int> row_shift, row_n;
  std::vector<int> row_ground;  // the ground's disparity per grid row, rounded; empty = none
  int RowDMin(int j) const { return banded ? d_min + row_shift[j] : d_min; }
  int RowNum(int j) const { return banded ? row_n[j] : n; }
  int Y(int j) const { return grid_lo + j * dy; }
  int X(int i) const { return x0 + i * dx; }
};

SearchGrid MakeSearchGrid(const NccOptions& options, int width, int height) {
  SearchGrid grid;
  grid.width = width;
  grid.height = height;
  grid.dx = options.step_x_px;
  grid.dy = options.step_y_px;
  grid.flip = options.reference == ReferenceImage::kLeft;
  grid.band_lo = std::max(0, options.min_row.value_or(0));
  grid.band_hi = std::min(height - 1, options.max_row.value_or(height - 1));
  grid.grid_lo = CeilToMultiple(grid.band_lo, grid.dy);
  grid.grid_hi = grid.band_hi >= 0 ? grid.band_hi / grid.dy * grid.dy : -1;
  grid.num_rows = grid.grid_hi >= grid.grid_lo ? (grid.grid_hi - grid.grid_lo) / grid.dy + 1 : 0;
  grid.x0 = grid.flip ? (width - 1) % grid.dx : 0;
  grid.num_cols = (width - 1 - grid.x0) / grid.dx + 1;
  grid.banded = !options.row_disparity_px.empty() && grid.num_rows > 0;
  grid.d_min = options.min_disparity_px;
  grid.n = options.max_disparity_px - options.min_disparity_px + 1;
  if (grid.banded) {
    LN_CHECK_INPUT(static_cast<int>(options.row_disparity_px.size()) == height)
        << "per-row disparity bands: " << options.row_disparity_px.size() << " bands for an image of " << height
        << " rows";
    grid.row_shift.resize(grid.num_rows);
    grid.row_n.resize(grid.num_rows);
    grid.d_min = std::numeric_limits<int>::max();
    for (int j = 0; j < grid.num_rows; ++j) grid.d_min = std::min(grid.d_min, options.row_disparity_px[grid.Y(j)].first);
    grid.n = 1;
    for (int j = 0; j < grid.num_rows; ++j) {
      const auto [lo, hi] = options.row_disparity_px[grid.Y(j)];
      grid.row_shift[j] = lo - grid.d_min;
      grid.row_n[j] = hi - lo + 1;
      grid.n = std::max(grid.n, grid.row_n[j]);
    }
    if (!options.row_ground_disparity_px.empty()) {
      // Rows that see no ground take the nearest row's value (no change of disparity there).
      std::vector<double> g(grid.num_rows, std::numeric_limits<double>::quiet_NaN());
      for (int j = 0; j < grid.num_rows; ++j) g[j] = options.row_ground_disparity_px[grid.Y(j)];
      int first = -1;
      for (int j = 0; j < grid.num_rows && first < 0; ++j) {
        if (std::isfinite(g[j])) first = j;
      }
      if (first >= 0) {
        grid.row_ground.resize(grid.num_rows);
        double last = g[first];
        for (int j = 0; j < grid.num_rows; ++j) {
          if (std::isfinite(g[j])) last = g[j];
          grid.row_ground[j] = static_cast<int>(std::lround(std::clamp(last, -1e6, 1e6)));
        }
      }
    }
  }
  return grid;
}

// What the aggregation reads besides the census codes, and the arrays they point into: the
// reference's grey levels on the 8-bit scale (edge-aware P2) and both images' horizontal
// derivatives (the cost's gradient term).
struct CostInputs {
  SgmInput in;
  cv::Mat grey8, ref_gradient, tgt_gradient;
};

void PrepareCostInputs(const SemiGlobalOptions& g, const SearchGrid& grid, const SgmWorkspace& ws,
                       const cv::Mat& ref, const cv::Mat& tgt, int bit_depth, CostInputs* out) {
  SgmInput& in = out->in;
  in.ref_census = ws.ref_census.data();
  in.tgt_census = ws.tgt_census.data();
  in.width = grid.width;
  in.x0 = grid.x0;
  in.y0 = grid.grid_lo;
  in.step_x = grid.dx;
  in.step_y = grid.dy;
  in.num_cols = grid.num_cols;
  in.num_rows = grid.num_rows;
  in.d_min = grid.d_min;
  in.num_disp = grid.n;
  if (grid.banded) {
    in.row_shift = grid.row_shift.data();
    in.row_num_disp = grid.row_n.data();
    if (!grid.row_ground.empty()) in.row_ground = grid.row_ground.data();
  }
  in.penalty_small = g.penalty_small;
  in.penalty_large = g.penalty_large;
  in.num_paths = g.num_paths;
  if (g.edge_levels > 0) {
    ref.convertTo(out->grey8, CV_16S, 255.0 / ((1u << bit_depth) - 1.0));
    in.ref_grey = out->grey8.ptr<std::int16_t>();
    in.edge_levels = g.edge_levels;
  }
  const int gradient_weight16 = static_cast<int>(std::lround(g.gradient_weight * 16));
  if (gradient_weight16 > 0 && g.gradient_cap_levels > 0) {
    // Sobel / 4 on the data's own scale, then in sixteenths of an 8-bit level (a 12-bit
    // camera's data gives nearly what its 8-bit scaling gives; rounding to whole 8-bit
    // levels first would move derivatives by a level in bright regions).
    const double to_grey8_16ths = 16.0 * 255.0 / ((1u << bit_depth) - 1.0);
    auto derivative = [&](const cv::Mat& image, cv::Mat* result) {
      cv::Mat dx;
      cv::Sobel(image, dx, CV_32F, 1, 0, 3, 0.25, 0, cv::BORDER_REPLICATE);
      dx.convertTo(*result, CV_16S, to_grey8_16ths);
    };
    tbb::parallel_invoke([&] { derivative(ref, &out->ref_gradient); }, [&] { derivative(tgt, &out->tgt_gradient); });
    in.ref_gradient = out->ref_gradient.ptr<std::int16_t>();
    in.tgt_gradient = out->tgt_gradient.ptr<std::int16_t>();
    in.gradient_weight16 = gradient_weight16;
    in.gradient_cap = 16 * g.gradient_cap_levels;
  }
}

// Filter 1's measure: the reference's mean and mean square over the census window, on the
// true bit depth's scale, and the variance below which a pixel has too little texture; with
// the aperture filter, the window's mean |Sobel x| and |Sobel y| (SemiGlobalOptions).
struct Texture {
  cv::Mat mean, mean_sq;
  float min_var = 0.0f;
  cv::Mat grad_x, grad_y;  // empty: the aperture filter is off
  float aperture_ratio = 0.0f, aperture_min_grad = 0.0f;
  bool TooLow(int x, int y) const {
    const float m = mean.at<float>(y, x), m2 = mean_sq.at<float>(y, x);
    return m2 - m * m < min_var;
  }
  bool AlongRows(int x, int y) const {
    if (grad_x.empty()) return false;
    const float gx = grad_x.at<float>(y, x);
    return gx < aperture_min_grad && gx < aperture_ratio * grad_y.at<float>(y, x);
  }
};

// `rows`: the rows matched (the aperture measure is made for those only: window selection's
// point is to do what the band needs).
Texture ComputeTexture(const NccOptions& options, const cv::Mat& ref, int bit_depth, cv::Range rows) {
  const SemiGlobalOptions& g = options.semi_global;
  Texture texture;
  cv::Mat ref_f;
  ref.convertTo(ref_f, CV_32F);
  const cv::Size window(2 * g.census_half_x_px + 1, 2 * g.census_half_y_px + 1);
  tbb::parallel_invoke(
      [&] { cv::boxFilter(ref_f, texture.mean, CV_32F, window, {-1, -1}, true, cv::BORDER_REPLICATE); },
      [&] {
        cv::boxFilter(ref_f.mul(ref_f), texture.mean_sq, CV_32F, window, {-1, -1}, true, cv::BORDER_REPLICATE);
      });
  const double sigma_min = options.min_sigma * GreyScaleFactor(bit_depth);
  texture.min_var = static_cast<float>(sigma_min * sigma_min);
  if (g.aperture_ratio > 0 && rows.size() > 0) {
    // Sobel's sum is 8 times a ramp's slope: /8 gives grey levels per pixel. The derivatives
    // over the rows the windows of `rows` reach (Sobel on a band reads the rows beyond it
    // from the whole image, OpenCV's ROI); the box filter over them replicates their first
    // and last rows only where those are the image's. So the band's values are the whole
    // image's, and nothing outside the band is computed.
    const cv::Range reach(std::max(0, rows.start - g.census_half_y_px),
                          std::min(ref_f.rows, rows.end + g.census_half_y_px));
    auto mean_abs_derivative = [&](int dx, int dy, cv::Mat* result) {
      cv::Mat d, mean;
      cv::Sobel(ref_f.rowRange(reach), d, CV_32F, dx, dy, 3, 0.125, 0, cv::BORDER_REPLICATE);
      cv::absdiff(d, cv::Scalar::all(0), d);
      cv::boxFilter(d, mean, CV_32F, window, {-1, -1}, true, cv::BORDER_REPLICATE);
      result->create(ref_f.size(), CV_32F);  // only the band's rows are read (AlongRows)
      mean.rowRange(rows.start - reach.start, rows.end - reach.start).copyTo(result->rowRange(rows));
    };
    tbb::parallel_invoke([&] { mean_abs_derivative(1, 0, &texture.grad_x); },
                         [&] { mean_abs_derivative(0, 1, &texture.grad_y); });
    texture.aperture_ratio = static_cast<float>(g.aperture_ratio);
    texture.aperture_min_grad = static_cast<float>(g.aperture_gradient * GreyScaleFactor(bit_depth));
  }
  return texture;
}

// The grid's maps as the filters leave them: disparity (NaN where rejected), the confidence C
// at the chosen disparity, the reason of each grid pixel's outcome, and for the left-right
// check the index of the best disparity seen from each target column.
struct GridMaps {
  cv::Mat disp, corr, reason, tgt_best;
};

// One row's window sums of one image (RowWindowSums) and their scratch.
struct WindowSumsRow {
  std::vector<std::int64_t> column, column_sq;
  std::vector<double> sum, sq;
};

// Selection on one grid row's aggregated costs (RowDisp(j) a pixel, pixel after pixel):
// the winner, the target image's minima for the left-right check, then the filters in order
// (texture, range edge, lobe-aware ambiguity, the paper's C at the chosen disparity), and the
// sub-pixel vertex. Rows are independent.
class RowSelector {
 public:
  RowSelector(const NccOptions& options, const SearchGrid& grid, const Texture& texture, const cv::Mat& left,
              const cv::Mat& right, const cv::Mat& ref, const cv::Mat& tgt, GridMaps* maps);
  bool LeftRightCheck() const { return options_.semi_global.left_right_max_diff_px >= 0 && grid_.dx == 1; }
  LN_SGM_CLONES void operator()(int j, const std::uint16_t* sums) const;

 private:
  double Confidence(int x, int y, int d_best, const WindowSumsRow& ref_sums, const WindowSumsRow& tgt_sums) const;
  const NccOptions& options_;
  NccOptions confidence_options_;
  bool small_window_ = false;
  const SearchGrid& grid_;
  const Texture& texture_;
  const cv::Mat &left_, &right_, &ref_, &tgt_;
  GridMaps& maps_;
};

RowSelector::RowSelector(const NccOptions& options, const SearchGrid& grid, const Texture& texture,
                         const cv::Mat& left, const cv::Mat& right, const cv::Mat& ref, const cv::Mat& tgt,
                         GridMaps* maps)
    : options_(options), grid_(grid), texture_(texture), left_(left), right_(right), ref_(ref), tgt_(tgt),
      maps_(*maps) {
  confidence_options_ = options;
  confidence_options_.step_x_px = confidence_options_.step_y_px = 1;
  const int mx = options.half_window_x_px, my = options.half_window_y_px;
  // 8-bit windows whose products of grey levels sum within 32 bits.
  small_window_ = (2.0 * mx + 1) * (2.0 * my + 1) * 255 * 255 < 2147483647.0;
}

// The sums of C over the window that do not depend on the disparity, along row y of a
// working image: for every column x whose window lies inside the image, its grey levels and
// their squares summed (integers, exact in double); the other columns are left alone. The
// window's rows must lie inside the image.
template <typename Pixel>
void RowWindowSums(const cv::Mat& image, int y, int mx, int my, WindowSumsRow* out) {
  const int width = image.cols;
  std::vector<std::int64_t>& column = out->column;
  std::vector<std::int64_t>& column_sq = out->column_sq;
  column.assign(width, 0);
  column_sq.assign(width, 0);
  for (int j = -my; j <= my; ++j) {
    const Pixel* p = image.ptr<Pixel>(y + j);
    for (int x = 0; x < width; ++x) {
      const std::int64_t v = p[x];
      column[x] += v;
      column_sq[x] += v * v;
    }
  }
  out->sum.resize(width);
  out->sq.resize(width);
  if (2 * mx + 1 > width) return;
  std::int64_t s = 0, q = 0;
  for (int x = 0; x < 2 * mx + 1; ++x) {
    s += column[x];
    q += column_sq[x];
  }
  for (int x = mx;; ++x) {
    out->sum[x] = static_cast<double>(s);
    out->sq[x] = static_cast<double>(q);
    if (x + mx + 1 >= width) break;
    s += column[x + mx + 1] - column[x - mx];
    q += column_sq[x + mx + 1] - column_sq[x - mx];
  }
}

// The paper's C at working-image pixel (x, y) and disparity d_best (in the images' own
// columns), over the whole window at full resolution whatever the grid's steps (a window of
// 7 x 7 subsampled by 5 x 4 would be a single pixel). Inside both images, from the window
// sums: every one a sum of integers, which Correlation's doubles hold exactly too, put through
// Correlation's own final expression (CorrelationFromSums), so C is the same value bit for
// bit (the working images are the originals mirrored for a left reference: the same pairs of
// pixels). At the images' edges, Correlation itself (NaN).
double RowSelector::Confidence(int x, int y, int d_best, const WindowSumsRow& ref_sums,
                               const WindowSumsRow& tgt_sums) const {
  const int width = grid_.width;
  const int mx = confidence_options_.half_window_x_px, my = confidence_options_.half_window_y_px;
  const bool inside = y >= my && y + my < grid_.height && x >= mx && x + mx < width && x + d_best >= mx &&
                      x + d_best + mx < width;
  if (!inside) return Correlation(left_, right_, confidence_options_, grid_.flip ? width - 1 - x : x, y, d_best);
  double s_ro;
  if (ref_.depth() == CV_8U && small_window_ && mx <= 3 && x - mx + 8 <= width && x + d_best - mx + 8 <= width) {
    s_ro = WindowCrossSum8(ref_, tgt_, mx, my, x, y, d_best);
  } else if (ref_.depth() == CV_8U && small_window_) {
    s_ro = WindowCrossSum<std::uint8_t, std::int32_t>(ref_, tgt_, mx, my, x, y, d_best);
  } else if (ref_.depth() == CV_8U) {
    s_ro = static_cast<double>(WindowCrossSum<std::uint8_t, std::int64_t>(ref_, tgt_, mx, my, x, y, d_best));
  } else {
    s_ro = static_cast<double>(WindowCrossSum<std::uint16_t, std::int64_t>(ref_, tgt_, mx, my, x, y, d_best));
  }
  const int xt = x + d_best;
  return CorrelationFromSums(ref_sums.sum[x], tgt_sums.sum[xt], ref_sums.sq[x], tgt_sums.sq[xt], s_ro,
                             (2 * mx + 1) * (2 * my + 1));
}

void RowSelector::operator()(int j, const std::uint16_t* sums) const {
  const SemiGlobalOptions& g = options_.semi_global;
  const int width = grid_.width;
  const bool lr_check = LeftRightCheck();
  std::vector<std::uint16_t> tgt_cost(lr_check ? width : 0, std::numeric_limits<std::uint16_t>::max());
  const int y = grid_.Y(j);
  auto* disp = maps_.disp.ptr<float>(j);
  auto* corr = maps_.corr.ptr<float>(j);
  auto* reason = maps_.reason.ptr<std::uint8_t>(j);
  int* tgt_k = maps_.tgt_best.ptr<int>(j);
  const int d_lo = grid_.RowDMin(j), nj = grid_.RowNum(j);
  // The confidence's window sums along this row (when its window's rows are inside).
  WindowSumsRow ref_sums, tgt_sums;
  const int my = confidence_options_.half_window_y_px, mx = confidence_options_.half_window_x_px;
  if (y >= my && y + my < grid_.height) {
    if (ref_.depth() == CV_8U) {
      RowWindowSums<std::uint8_t>(ref_, y, mx, my, &ref_sums);
      RowWindowSums<std::uint8_t>(tgt_, y, mx, my, &tgt_sums);
    } else {
      RowWindowSums<std::uint16_t>(ref_, y, mx, my, &ref_sums);
      RowWindowSums<std::uint16_t>(tgt_, y, mx, my, &tgt_sums);
    }
  }
  for (int i = 0; i < grid_.num_cols; ++i) {
    const int x = grid_.X(i);
    const int k_lo = std::clamp(-x - d_lo, 0, nj);
    const int k_hi = std::clamp(width - x - d_lo, k_lo, nj) - 1;  // inclusive
    if (k_hi < k_lo) {
      reason[i] = static_cast<std::uint8_t>(Rejection::kBorder);
      continue;
    }
    const std::uint16_t* s = sums + static_cast<std::size_t>(i) * nj;
    const int best = ArgMin(s, k_lo, k_hi);
    if (lr_check) {
      const int shift = x + d_lo;  // target column of index k: shift + k
      TargetMinimum(s, k_lo, k_hi, tgt_cost.data() + shift, tgt_k + shift);
    }
    if (texture_.TooLow(x, y)) {
      reason[i] = static_cast<std::uint8_t>(Rejection::kLowTexture);
      continue;
    }
    if (texture_.AlongRows(x, y)) {
      reason[i] = static_cast<std::uint8_t>(Rejection::kAperture);
      continue;
    }
    if (best == 0 || best == nj - 1) {
      reason[i] = static_cast<std::uint8_t>(Rejection::kRangeEdge);
      continue;
    }
    if (g.uniqueness > 0 && IsAmbiguousMinimum(s, k_lo, k_hi, best, g.uniqueness)) {
      reason[i] = static_cast<std::uint8_t>(Rejection::kAmbiguous);
      continue;
    }
    const auto c = static_cast<float>(Confidence(x, y, d_lo + best, ref_sums, tgt_sums));
    corr[i] = c;
    if (!(c >= options_.min_correlation)) {
      reason[i] = static_cast<std::uint8_t>(Rejection::kLowCorrelation);
      continue;
    }
    // Sub-pixel: the vertex of the symmetric V through the aggregated costs of the best
    // disparity and its two neighbours (equiangular fit: census costs grow linearly with the
    // shift, so a parabola would pull every estimate towards whole pixels).
    double offset = 0.0;
    if (best > k_lo && best < k_hi) {
      const double a = s[best - 1], b = s[best], e = s[best + 1];
      const double rise = std::max(a - b, e - b);
      if (rise > 0) offset = std::clamp(0.5 * (a - e) / rise, -0.5, 0.5);
    }
    disp[i] = static_cast<float>(d_lo + best + offset);
  }
}

// The left-right check: an accepted match whose target pixel's own best match (from the
// target image's minima) differs by more than the tolerance is rejected.
void CheckLeftRight(const SemiGlobalOptions& g, const SearchGrid& grid, GridMaps* maps) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  tbb::parallel_for(0, grid.num_rows, [&](int j) {
    const int* tgt_k = maps->tgt_best.ptr<int>(j);
    auto* disp = maps->disp.ptr<float>(j);
    auto* reason = maps->reason.ptr<std::uint8_t>(j);
    const int d_lo = grid.RowDMin(j);
    for (int i = 0; i < grid.num_cols; ++i) {
      if (reason[i] != static_cast<std::uint8_t>(Rejection::kAccepted)) continue;
      const int xt = static_cast<int>(std::lround(grid.x0 + i + disp[i]));
      const bool ok = xt >= 0 && xt < grid.width && tgt_k[xt] >= 0 &&
                      std::abs(d_lo + tgt_k[xt] - disp[i]) <= g.left_right_max_diff_px + 0.5f;
      if (!ok) {
        reason[i] = static_cast<std::uint8_t>(Rejection::kLeftRightMismatch);
        disp[i] = nan;
      }
    }
  });
}

// Matches in the guard below a row's accepted disparities lie beyond the far limit; in the
// guard above them, nearer than the near limit.
void RejectGuardBands(const NccOptions& options, const SearchGrid& grid, GridMaps* maps) {
  if (!grid.banded || (options.row_accept_min_px.empty() && options.row_accept_max_px.empty())) return;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  for (int j = 0; j < grid.num_rows; ++j) {
    const int y = grid.Y(j);
    const float accept_min = options.row_accept_min_px.empty() ? -inf : static_cast<float>(options.row_accept_min_px[y]);
    const float accept_max = options.row_accept_max_px.empty() ? inf : static_cast<float>(options.row_accept_max_px[y]);
    float* d = maps->disp.ptr<float>(j);
    auto* reason = maps->reason.ptr<std::uint8_t>(j);
    for (int i = 0; i < grid.num_cols; ++i) {
      if (d[i] < accept_min || d[i] > accept_max) {  // false for NaN
        reason[i] = static_cast<std::uint8_t>(d[i] < accept_min ? Rejection::kBeyondFar : Rejection::kBeyondNear);
        d[i] = nan;
      }
    }
  }
}

// OpenCV's speckle filter on 1/16-pixel fixed point; a removed region gets kSpeckle.
void RejectSpeckles(const SemiGlobalOptions& g, const SearchGrid& grid, GridMaps* maps) {
  if (g.speckle_max_size_px <= 0 || grid.num_rows == 0) return;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  constexpr int kInvalid = std::numeric_limits<std::int16_t>::min();
  cv::Mat fixed(grid.num_rows, grid.num_cols, CV_16SC1);
  tbb::parallel_for(0, grid.num_rows, [&](int j) {
    const float* d = maps->disp.ptr<float>(j);
    auto* f = fixed.ptr<std::int16_t>(j);
    for (int i = 0; i < grid.num_cols; ++i) {
      f[i] = std::isfinite(d[i]) ? cv::saturate_cast<std::int16_t>(std::lround(16.0 * (d[i] - grid.d_min)))
                                 : static_cast<std::int16_t>(kInvalid);
    }
  });
  // The size is given in pixels of the image; on the subsampling grid a cell stands for dx dy.
  const int max_cells = std::max(1, g.speckle_max_size_px / (grid.dx * grid.dy));
  cv::filterSpeckles(fixed, kInvalid, max_cells, 16.0 * g.speckle_range_px);
  tbb::parallel_for(0, grid.num_rows, [&](int j) {
    const auto* f = fixed.ptr<std::int16_t>(j);
    auto* d = maps->disp.ptr<float>(j);
    auto* reason = maps->reason.ptr<std::uint8_t>(j);
    for (int i = 0; i < grid.num_cols; ++i) {
      if (f[i] == kInvalid && std::isfinite(d[i])) {
        d[i] = nan;
        reason[i] = static_cast<std::uint8_t>(Rejection::kSpeckle);
      }
    }
  });
}

// The occlusion margin (SemiGlobalOptions::occlusion_margin_px): in the working orientation
// the other image's match lies at x + d, so the background beside a nearer surface is
// half-occluded on the surface's right (larger x). A match followed, within the margin to its
// right, by one more than speckle_range_px lower is rejected; the matches are judged as
// selection left them (a rejection does not move the next one's test).
void RejectOccludedEdges(const SemiGlobalOptions& g, const SearchGrid& grid, GridMaps* maps) {
  if (g.occlusion_margin_px <= 0) return;
  // On a subsampled grid the margin is counted in image pixels.
  const int reach = std::max(1, g.occlusion_margin_px / grid.dx);
  const float drop = static_cast<float>(g.speckle_range_px);
  tbb::parallel_for(0, grid.num_rows, [&](int j) {
    float* d = maps->disp.ptr<float>(j);
    std::uint8_t* reason = maps->reason.ptr<std::uint8_t>(j);
    const std::vector<float> original(d, d + grid.num_cols);  // as selection left them
    for (int i = 0; i < grid.num_cols; ++i) {
      if (!std::isfinite(original[i])) continue;
      const int end = std::min(grid.num_cols, i + reach + 1);
      for (int k = i + 1; k < end; ++k) {
        if (original[k] < original[i] - drop) {  // NaN compares false
          d[i] = std::numeric_limits<float>::quiet_NaN();
          reason[i] = static_cast<std::uint8_t>(Rejection::kOccludedEdge);
          break;
        }
      }
    }
  });
}

// The filters after selection, in order: occlusion margin, guard band, median, border rule,
// speckle.
void ApplyFilters(const NccOptions& options, const SearchGrid& grid, GridMaps* maps) {
  RejectOccludedEdges(options.semi_global, grid, maps);
  RejectGuardBands(options, grid, maps);
  MedianFilterDisparityGrid(options.median_size, &maps->disp, &maps->reason, /*reject_isolated=*/false);
  if (options.border_tolerance_px >= 0) {
    // After the median, before the speckle filter: what the rule leaves of a wrong region near
    // the edge is then small enough for the speckle filter (run after it, 2 of 8 simulated
    // traverses kept cells 35 cm off).
    // The census at the target is taken with replicated borders: a range is cut where x + d_max
    // leaves the image.
    std::vector<int> reach(grid.num_rows);
    for (int j = 0; j < grid.num_rows; ++j) reach[j] = grid.RowDMin(j) + grid.RowNum(j) - 1;
    RejectMatchesBeyondTheBorder(grid.x0, grid.dx, grid.width, reach, 0, options.border_tolerance_px, &maps->disp,
                                 &maps->reason);
  }
  RejectSpeckles(options.semi_global, grid, maps);
}

// Full-size maps: the grid scattered into the reference image's columns; the counts.
void ScatterToImage(const SearchGrid& grid, const GridMaps& maps, int bit_depth, NccResult* out) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const int width = grid.width, height = grid.height;
  NccResult& result = *out;
  result.summary = NccSummary{};
  result.disparity_px.create(height, width, CV_32FC1);
  result.correlation.create(height, width, CV_32FC1);
  result.rejection.create(height, width, CV_8UC1);
  result.disparity_px.setTo(nan);
  result.correlation.setTo(nan);
  result.rejection.setTo(static_cast<int>(Rejection::kNotEvaluated));
  NccSummary& sum = result.summary;
  for (int j = 0; j < grid.num_rows; ++j) {
    const int y = grid.Y(j);
    const auto* reason = maps.reason.ptr<std::uint8_t>(j);
    const auto* disp = maps.disp.ptr<float>(j);
    const auto* corr = maps.corr.ptr<float>(j);
    auto* out_reason = result.rejection.ptr<std::uint8_t>(y);
    auto* out_disp = result.disparity_px.ptr<float>(y);
    auto* out_corr = result.correlation.ptr<float>(y);
    for (int i = 0; i < grid.num_cols; ++i) {
      const int x_work = grid.X(i);
      const int x = grid.flip ? width - 1 - x_work : x_work;
      out_reason[x] = reason[i];
      out_disp[x] = disp[i];
      out_corr[x] = corr[i];
      ++sum.pixels_by_reason[reason[i]];
    }
  }
  sum.width = width;
  sum.height = height;
  sum.band_min_row = grid.band_lo;
  sum.band_max_row = grid.band_hi;
  sum.bit_depth = bit_depth;
  sum.evaluated_pixels = grid.num_rows * grid.num_cols;
  sum.pixels_by_reason[static_cast<int>(Rejection::kNotEvaluated)] = width * height - sum.evaluated_pixels;
  sum.accepted_pixels = sum.pixels_by_reason[static_cast<int>(Rejection::kAccepted)];
}

}  // namespace

void MatchSemiGlobal(const NccOptions& options, const cv::Mat& left, const cv::Mat& right, int bit_depth,
                     NccResult* out) {
  util::Timer timer;
  util::StageClock clock;
  const SemiGlobalOptions& g = options.semi_global;
  const SearchGrid grid = MakeSearchGrid(options, left.cols, left.rows);
  cv::Mat ref, tgt;  // the working images
  if (grid.flip) {
    cv::flip(left, ref, 1);
    cv::flip(right, tgt, 1);
  } else {
    ref = right;
    tgt = left;
  }
  SgmWorkspace& ws = ThreadSgmWorkspace();
  const cv::Range census_rows(grid.num_rows > 0 ? grid.grid_lo : 0, grid.num_rows > 0 ? grid.grid_hi + 1 : 0);
  CensusTransform(ref, g.census_half_x_px, g.census_half_y_px, census_rows, &ws.ref_census);
  CensusTransform(tgt, g.census_half_x_px, g.census_half_y_px, census_rows, &ws.tgt_census);
  clock.Lap("census");

  CostInputs cost_inputs;
  PrepareCostInputs(g, grid, ws, ref, tgt, bit_depth, &cost_inputs);
  GridMaps maps;
  maps.disp.create(grid.num_rows, grid.num_cols, CV_32FC1);
  maps.disp.setTo(std::numeric_limits<float>::quiet_NaN());
  maps.corr.create(grid.num_rows, grid.num_cols, CV_32FC1);
  maps.corr.setTo(std::numeric_limits<float>::quiet_NaN());
  maps.reason.create(grid.num_rows, grid.num_cols, CV_8UC1);
  maps.reason.setTo(static_cast<int>(Rejection::kAccepted));
  SemiGlobalAggregate(cost_inputs.in, &ws.cost);
  clock.Lap("aggregation");  // with the gradient term's derivatives and the edge-aware P2's grey levels
  const Texture texture = ComputeTexture(options, ref, bit_depth, census_rows);
  clock.Lap("texture");
  const RowSelector select(options, grid, texture, left, right, ref, tgt, &maps);
  maps.tgt_best.create(grid.num_rows, select.LeftRightCheck() ? grid.width : 1, CV_32SC1);
  maps.tgt_best.setTo(-1);
  tbb::parallel_for(0, grid.num_rows, [&](int j) { select(j, ws.cost.sum(0, j)); });
  clock.Lap("selection");  // winner-take-all, ambiguity, confidence C, sub-pixel
  if (select.LeftRightCheck()) CheckLeftRight(g, grid, &maps);
  clock.Lap("left_right");
  ApplyFilters(options, grid, &maps);
  clock.Lap("filters");  // occlusion margin, guard band, median, border rule, speckle
  ScatterToImage(grid, maps, bit_depth, out);
  clock.Lap("scatter");
  for (int j = 1; j < grid.num_rows; ++j) out->summary.ground_following_row_steps += cost_inputs.in.GroundSlope(j, j - 1) != 0;
  out->summary.stage_seconds = clock.Take();
  out->summary.match_seconds = timer.ElapsedSeconds();
}

}  // namespace lunarnav::stereo::internal
