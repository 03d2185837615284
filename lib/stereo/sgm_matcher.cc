// The quality preset's matcher: census cost, semi-global aggregation, and the paper's
// confidence and filters with the checks real scenes need (docs/stereo-matcher.md).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <tbb/parallel_for.h>

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
LN_SGM_CLONES int ArgMin(const std::uint16_t* s, int k_lo, int k_hi) {
  std::uint16_t smallest = std::numeric_limits<std::uint16_t>::max();
  for (int k = k_lo; k <= k_hi; ++k) smallest = std::min(smallest, s[k]);
  int k = k_lo;
  while (s[k] != smallest) ++k;
  return k;
}

// The left-right check's view from the target image: target column shift + k keeps the
// smallest cost any reference pixel gives it, and that pixel's k (`cost` and `index` point at
// column `shift`).
LN_SGM_CLONES void TargetMinimum(const std::uint16_t* s, int k_lo, int k_hi, std::uint16_t* cost, int* index) {
  for (int k = k_lo; k <= k_hi; ++k) {
    const bool better = s[k] < cost[k];
    cost[k] = better ? s[k] : cost[k];
    index[k] = better ? k : index[k];
  }
}

int CeilToMultiple(int value, int step) { return (value + step - 1) / step * step; }

// The paper's C over the window of half-size (mx, my) between the working reference at (x, y)
// and the working target at (x + d, y), from integer sums; NaN without variance. Every sum is
// of integers, which Correlation's doubles hold exactly too, and the final expression is
// Correlation's own (CorrelationFromSums), so C is the same value bit for bit (the working images are the originals
// mirrored for a left reference: the same pairs of pixels). The window must lie inside both
// images. Sum is a type that holds (2 mx + 1)(2 my + 1) squared grey levels exactly.
template <typename Pixel, typename Sum>
double WindowCorrelation(const cv::Mat& ref, const cv::Mat& tgt, int mx, int my, int x, int y, int d) {
  Sum s_ref = 0, s_oth = 0, s_rr = 0, s_oo = 0, s_ro = 0;
  for (int j = -my; j <= my; ++j) {
    const Pixel* r = ref.ptr<Pixel>(y + j) + x;
    const Pixel* o = tgt.ptr<Pixel>(y + j) + x + d;
    for (int i = -mx; i <= mx; ++i) {
      const Sum a = r[i], b = o[i];
      s_ref += a;
      s_oth += b;
      s_rr += a * a;
      s_oo += b * b;
      s_ro += a * b;
    }
  }
  return CorrelationFromSums(static_cast<double>(s_ref), static_cast<double>(s_oth), static_cast<double>(s_rr),
                             static_cast<double>(s_oo), static_cast<double>(s_ro), (2 * mx + 1) * (2 * my + 1));
}


}  // namespace

void MatchSemiGlobal(const NccOptions& options, const cv::Mat& left, const cv::Mat& right, int bit_depth,
                     NccResult* out) {
  util::Timer timer;
  util::StageClock clock;
  const SemiGlobalOptions& g = options.semi_global;
  const int width = left.cols, height = left.rows;
  const int dx = options.step_x_px, dy = options.step_y_px;
  const bool flip = options.reference == ReferenceImage::kLeft;
  // Internally the reference pixel x matches the target pixel x + d (the right-reference
  // convention); with the left image as reference both images are mirrored.
  cv::Mat ref, tgt;
  if (flip) {
    cv::flip(left, ref, 1);
    cv::flip(right, tgt, 1);
  } else {
    ref = right;
    tgt = left;
  }
  const int band_lo = std::max(0, options.min_row.value_or(0));
  const int band_hi = std::min(height - 1, options.max_row.value_or(height - 1));
  const int grid_lo = CeilToMultiple(band_lo, dy);
  const int grid_hi = band_hi >= 0 ? band_hi / dy * dy : -1;
  const int num_rows = grid_hi >= grid_lo ? (grid_hi - grid_lo) / dy + 1 : 0;
  const int x0 = flip ? (width - 1) % dx : 0;
  const int num_cols = (width - 1 - x0) / dx + 1;
  // Per grid row: the first disparity searched and how many (per-row bands, or the one range).
  std::vector<int> row_shift, row_n;
  const bool banded = !options.row_disparity_px.empty() && num_rows > 0;
  int d_min = options.min_disparity_px, n = options.max_disparity_px - options.min_disparity_px + 1;
  if (banded) {
    LN_CHECK_INPUT(static_cast<int>(options.row_disparity_px.size()) == height)
        << "per-row disparity bands: " << options.row_disparity_px.size() << " bands for an image of " << height
        << " rows";
    row_shift.resize(num_rows);
    row_n.resize(num_rows);
    d_min = std::numeric_limits<int>::max();
    for (int j = 0; j < num_rows; ++j) d_min = std::min(d_min, options.row_disparity_px[grid_lo + j * dy].first);
    n = 1;
    for (int j = 0; j < num_rows; ++j) {
      const auto [lo, hi] = options.row_disparity_px[grid_lo + j * dy];
      row_shift[j] = lo - d_min;
      row_n[j] = hi - lo + 1;
      n = std::max(n, row_n[j]);
    }
  }
  auto row_d_min = [&](int j) { return banded ? d_min + row_shift[j] : d_min; };
  auto row_num = [&](int j) { return banded ? row_n[j] : n; };

  SgmWorkspace& ws = ThreadSgmWorkspace();
  const cv::Range census_rows(num_rows > 0 ? grid_lo : 0, num_rows > 0 ? grid_hi + 1 : 0);
  CensusTransform(ref, g.census_half_x_px, g.census_half_y_px, census_rows, &ws.ref_census);
  CensusTransform(tgt, g.census_half_x_px, g.census_half_y_px, census_rows, &ws.tgt_census);
  clock.Lap("census");
  SgmInput in;
  in.ref_census = ws.ref_census.data();
  in.tgt_census = ws.tgt_census.data();
  in.width = width;
  in.x0 = x0;
  in.y0 = grid_lo;
  in.step_x = dx;
  in.step_y = dy;
  in.num_cols = num_cols;
  in.num_rows = num_rows;
  in.d_min = d_min;
  in.num_disp = n;
  if (banded) {
    in.row_shift = row_shift.data();
    in.row_num_disp = row_n.data();
  }
  in.penalty_small = g.penalty_small;
  in.penalty_large = g.penalty_large;
  in.num_paths = g.num_paths;
  cv::Mat grey8;  // the reference's grey levels on the 8-bit scale, for edge-aware P2
  if (g.edge_levels > 0) {
    ref.convertTo(grey8, CV_16S, 255.0 / ((1u << bit_depth) - 1.0));
    in.ref_grey = grey8.ptr<std::int16_t>();
    in.edge_levels = g.edge_levels;
  }
  cv::Mat ref_gradient, tgt_gradient;  // horizontal derivatives for the cost's gradient term
  const int gradient_weight16 = static_cast<int>(std::lround(g.gradient_weight * 16));
  if (gradient_weight16 > 0 && g.gradient_cap_levels > 0) {
    // Sobel / 4 on the data's own scale, then in sixteenths of an 8-bit level (a 12-bit
    // camera's data gives nearly what its 8-bit scaling gives; rounding to whole 8-bit
    // levels first would move derivatives by a level in bright regions).
    const double to_grey8_16ths = 16.0 * 255.0 / ((1u << bit_depth) - 1.0);
    auto derivative = [&](const cv::Mat& image, cv::Mat* out) {
      cv::Mat dx;
      cv::Sobel(image, dx, CV_32F, 1, 0, 3, 0.25, 0, cv::BORDER_REPLICATE);
      dx.convertTo(*out, CV_16S, to_grey8_16ths);
    };
    derivative(ref, &ref_gradient);
    derivative(tgt, &tgt_gradient);
    in.ref_gradient = ref_gradient.ptr<std::int16_t>();
    in.tgt_gradient = tgt_gradient.ptr<std::int16_t>();
    in.gradient_weight16 = gradient_weight16;
    in.gradient_cap = 16 * g.gradient_cap_levels;
  }
  SemiGlobalAggregate(in, &ws.cost);
  clock.Lap("aggregation");  // with the gradient term's derivatives and the edge-aware P2's grey levels

  // Texture (filter 1) over the census window, on the true bit depth's scale.
  cv::Mat ref_f;
  ref.convertTo(ref_f, CV_32F);
  cv::Mat mean, mean_sq;
  const cv::Size texture_window(2 * g.census_half_x_px + 1, 2 * g.census_half_y_px + 1);
  cv::boxFilter(ref_f, mean, CV_32F, texture_window, {-1, -1}, true, cv::BORDER_REPLICATE);
  cv::boxFilter(ref_f.mul(ref_f), mean_sq, CV_32F, texture_window, {-1, -1}, true, cv::BORDER_REPLICATE);
  const double sigma_min = options.min_sigma * GreyScaleFactor(bit_depth);
  const float min_var = static_cast<float>(sigma_min * sigma_min);
  clock.Lap("texture");

  NccOptions confidence_options = options;
  confidence_options.step_x_px = confidence_options.step_y_px = 1;
  // 8-bit windows whose squared grey levels sum within 32 bits.
  const bool small_window = (2.0 * options.half_window_x_px + 1) * (2.0 * options.half_window_y_px + 1) * 255 * 255 <
                            2147483647.0;
  // Winner-take-all, sub-pixel vertex, lobe-aware ambiguity and the correlation filter.
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  cv::Mat grid_disp(num_rows, num_cols, CV_32FC1, cv::Scalar(nan));
  cv::Mat grid_corr(num_rows, num_cols, CV_32FC1, cv::Scalar(nan));
  cv::Mat grid_reason(num_rows, num_cols, CV_8UC1, cv::Scalar(static_cast<int>(Rejection::kAccepted)));
  // The best disparity index seen from the target image's columns (left-right check).
  const bool lr_check = g.left_right_max_diff_px >= 0 && dx == 1;
  cv::Mat tgt_best(num_rows, lr_check ? width : 1, CV_32SC1, cv::Scalar(-1));
  tbb::parallel_for(0, num_rows, [&](int j) {
    std::vector<std::uint16_t> tgt_cost(lr_check ? width : 0, std::numeric_limits<std::uint16_t>::max());
    const int y = grid_lo + j * dy;
    auto* disp = grid_disp.ptr<float>(j);
    auto* corr = grid_corr.ptr<float>(j);
    auto* reason = grid_reason.ptr<std::uint8_t>(j);
    int* tgt_k = tgt_best.ptr<int>(j);
    const float* m = mean.ptr<float>(y);
    const float* m2 = mean_sq.ptr<float>(y);
    const int d_lo = row_d_min(j), nj = row_num(j);
    for (int i = 0; i < num_cols; ++i) {
      const int x = x0 + i * dx;
      const int k_lo = std::clamp(-x - d_lo, 0, nj);
      const int k_hi = std::clamp(width - x - d_lo, k_lo, nj) - 1;  // inclusive
      if (k_hi < k_lo) {
        reason[i] = static_cast<std::uint8_t>(Rejection::kBorder);
        continue;
      }
      const std::uint16_t* s = ws.cost.sum(i, j);
      const int best = ArgMin(s, k_lo, k_hi);
      if (lr_check) {
        const int shift = x + d_lo;  // target column of index k: shift + k
        TargetMinimum(s, k_lo, k_hi, tgt_cost.data() + shift, tgt_k + shift);
      }
      if (m2[x] - m[x] * m[x] < min_var) {
        reason[i] = static_cast<std::uint8_t>(Rejection::kLowTexture);
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
      const int d_best = d_lo + best;
      // The paper's C at the chosen disparity (in the images' own columns), over the whole
      // window at full resolution whatever the grid's steps (a window of 7 x 7 subsampled by
      // 5 x 4 would be a single pixel).
      // Inside both images, from integer sums (the same value); at their edges, Correlation
      // itself (NaN).
      const int mx = confidence_options.half_window_x_px, my = confidence_options.half_window_y_px;
      const bool inside = y >= my && y + my < height && x >= mx && x + mx < width && x + d_best >= mx &&
                          x + d_best + mx < width;
      double c_value;
      if (!inside) {
        c_value = Correlation(left, right, confidence_options, flip ? width - 1 - x : x, y, d_best);
      } else if (ref.depth() == CV_8U && small_window) {
        c_value = WindowCorrelation<std::uint8_t, std::int32_t>(ref, tgt, mx, my, x, y, d_best);
      } else if (ref.depth() == CV_8U) {
        c_value = WindowCorrelation<std::uint8_t, std::int64_t>(ref, tgt, mx, my, x, y, d_best);
      } else {
        c_value = WindowCorrelation<std::uint16_t, std::int64_t>(ref, tgt, mx, my, x, y, d_best);
      }
      const auto c = static_cast<float>(c_value);
      corr[i] = c;
      if (!(c >= options.min_correlation)) {
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
  });
  clock.Lap("selection");  // winner-take-all, ambiguity, confidence C, sub-pixel
  if (lr_check) {
    tbb::parallel_for(0, num_rows, [&](int j) {
      const int* tgt_k = tgt_best.ptr<int>(j);
      auto* disp = grid_disp.ptr<float>(j);
      auto* reason = grid_reason.ptr<std::uint8_t>(j);
      const int d_lo = row_d_min(j);
      for (int i = 0; i < num_cols; ++i) {
        if (reason[i] != static_cast<std::uint8_t>(Rejection::kAccepted)) continue;
        const int xt = static_cast<int>(std::lround(x0 + i + disp[i]));
        const bool ok = xt >= 0 && xt < width && tgt_k[xt] >= 0 &&
                        std::abs(d_lo + tgt_k[xt] - disp[i]) <= g.left_right_max_diff_px + 0.5f;
        if (!ok) {
          reason[i] = static_cast<std::uint8_t>(Rejection::kLeftRightMismatch);
          disp[i] = nan;
        }
      }
    });
  }
  clock.Lap("left_right");
  if (banded && (!options.row_accept_min_px.empty() || !options.row_accept_max_px.empty())) {
    // Matches in the guard below a row's accepted disparities lie beyond the far limit; in the
    // guard above them, nearer than the near limit.
    for (int j = 0; j < num_rows; ++j) {
      const int y = grid_lo + j * dy;
      const float accept_min =
          options.row_accept_min_px.empty() ? -inf : static_cast<float>(options.row_accept_min_px[y]);
      const float accept_max =
          options.row_accept_max_px.empty() ? inf : static_cast<float>(options.row_accept_max_px[y]);
      float* d = grid_disp.ptr<float>(j);
      auto* reason = grid_reason.ptr<std::uint8_t>(j);
      for (int i = 0; i < num_cols; ++i) {
        if (d[i] < accept_min || d[i] > accept_max) {  // false for NaN
          reason[i] = static_cast<std::uint8_t>(d[i] < accept_min ? Rejection::kBeyondFar : Rejection::kBeyondNear);
          d[i] = nan;
        }
      }
    }
  }
  MedianFilterDisparityGrid(options.median_size, &grid_disp, &grid_reason, /*reject_isolated=*/false);
  if (options.border_tolerance_px >= 0) {
    // After the median, before the speckle filter: what the rule leaves of a wrong region near
    // the edge is then small enough for the speckle filter (run after it, 2 of 8 simulated
    // traverses kept cells 35 cm off).
    // The census at the target is taken with replicated borders: a range is cut where x + d_max
    // leaves the image.
    std::vector<int> reach(num_rows);
    for (int j = 0; j < num_rows; ++j) reach[j] = row_d_min(j) + row_num(j) - 1;
    RejectMatchesBeyondTheBorder(x0, dx, width, reach, 0, options.border_tolerance_px, &grid_disp, &grid_reason);
  }
  if (g.speckle_max_size_px > 0 && num_rows > 0) {
    // OpenCV's speckle filter on 1/16-pixel fixed point; a removed region gets `invalid`.
    constexpr int kInvalid = std::numeric_limits<std::int16_t>::min();
    cv::Mat fixed(num_rows, num_cols, CV_16SC1);
    for (int j = 0; j < num_rows; ++j) {
      const float* d = grid_disp.ptr<float>(j);
      auto* f = fixed.ptr<std::int16_t>(j);
      for (int i = 0; i < num_cols; ++i) {
        f[i] = std::isfinite(d[i]) ? cv::saturate_cast<std::int16_t>(std::lround(16.0 * (d[i] - d_min)))
                                   : static_cast<std::int16_t>(kInvalid);
      }
    }
    // The size is given in pixels of the image; on the subsampling grid a cell stands for dx dy.
    const int max_cells = std::max(1, g.speckle_max_size_px / (dx * dy));
    cv::filterSpeckles(fixed, kInvalid, max_cells, 16.0 * g.speckle_range_px);
    for (int j = 0; j < num_rows; ++j) {
      const auto* f = fixed.ptr<std::int16_t>(j);
      auto* d = grid_disp.ptr<float>(j);
      auto* reason = grid_reason.ptr<std::uint8_t>(j);
      for (int i = 0; i < num_cols; ++i) {
        if (f[i] == kInvalid && std::isfinite(d[i])) {
          d[i] = nan;
          reason[i] = static_cast<std::uint8_t>(Rejection::kSpeckle);
        }
      }
    }
  }

  clock.Lap("filters");  // guard band, median, border rule, speckle
  // Full-size maps: the grid scattered into the reference image's columns.
  NccResult& result = *out;
  result.summary = NccSummary{};
  result.disparity_px.create(height, width, CV_32FC1);
  result.correlation.create(height, width, CV_32FC1);
  result.rejection.create(height, width, CV_8UC1);
  result.disparity_px.setTo(nan);
  result.correlation.setTo(nan);
  result.rejection.setTo(static_cast<int>(Rejection::kNotEvaluated));
  NccSummary& sum = result.summary;
  for (int j = 0; j < num_rows; ++j) {
    const int y = grid_lo + j * dy;
    const auto* reason = grid_reason.ptr<std::uint8_t>(j);
    const auto* disp = grid_disp.ptr<float>(j);
    const auto* corr = grid_corr.ptr<float>(j);
    auto* out_reason = result.rejection.ptr<std::uint8_t>(y);
    auto* out_disp = result.disparity_px.ptr<float>(y);
    auto* out_corr = result.correlation.ptr<float>(y);
    for (int i = 0; i < num_cols; ++i) {
      const int x_work = x0 + i * dx;
      const int x = flip ? width - 1 - x_work : x_work;
      out_reason[x] = reason[i];
      out_disp[x] = disp[i];
      out_corr[x] = corr[i];
      ++sum.pixels_by_reason[reason[i]];
    }
  }
  sum.width = width;
  sum.height = height;
  sum.band_min_row = band_lo;
  sum.band_max_row = band_hi;
  sum.bit_depth = bit_depth;
  sum.evaluated_pixels = num_rows * num_cols;
  sum.pixels_by_reason[static_cast<int>(Rejection::kNotEvaluated)] = width * height - sum.evaluated_pixels;
  sum.accepted_pixels = sum.pixels_by_reason[static_cast<int>(Rejection::kAccepted)];
  clock.Lap("scatter");
  sum.stage_seconds = clock.Take();
  sum.match_seconds = timer.ElapsedSeconds();
}

}  // namespace lunarnav::stereo::internal
