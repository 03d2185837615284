#include "stereo/ncc_matcher.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/task_arena.h>

#include "stereo/disparity_filters.h"
#include "stereo/ncc_kernel.h"
#include "stereo/sgm_matcher.h"
#include "util/check.h"
#include "util/parallel.h"
#include "util/timer.h"

namespace lunarnav::stereo {
namespace {

using internal::KernelInput;
using internal::PeakRecord;

/// The pair converted for the kernel: int16, centred on the pair's mean intensity and
/// right-shifted just enough that n * max|v|^2 fits in int32, so that every window sum of
/// products is exact. 8-bit images are never shifted.
struct WorkingPair {
  cv::Mat ref, tgt;  // CV_16SC1
  int shift = 0;
};

template <typename T>
void ConvertRows(const cv::Mat& src, int offset, int shift, bool flip, const cv::Range& rows,
                 cv::Mat* dst) {
  const int width = src.cols;
  for (int y = rows.start; y < rows.end; ++y) {
    const T* in = src.ptr<T>(y);
    auto* out = dst->ptr<std::int16_t>(y);
    for (int x = 0; x < width; ++x) {
      const int v = (static_cast<int>(in[x]) - offset) >> shift;
      out[flip ? width - 1 - x : x] = static_cast<std::int16_t>(v);
    }
  }
}

// Converts only `rows` (the rows the kernel reads); the others are left uninitialised.
WorkingPair MakeWorkingPair(const cv::Mat& ref_full, const cv::Mat& tgt_full, int n, bool flip,
                            const cv::Range& rows) {
  const cv::Mat ref = ref_full.rowRange(rows), tgt = tgt_full.rowRange(rows);
  double min_r, max_r, min_t, max_t;
  cv::minMaxLoc(ref, &min_r, &max_r);
  cv::minMaxLoc(tgt, &min_t, &max_t);
  const int offset = static_cast<int>(std::lround(0.5 * (cv::mean(ref)[0] + cv::mean(tgt)[0])));
  const long max_abs = static_cast<long>(
      std::max({max_r - offset, max_t - offset, offset - min_r, offset - min_t, 0.0}));
  WorkingPair pair;
  for (;; ++pair.shift) {
    const long m = (max_abs >> pair.shift) + 1;  // bound on |v| after the (flooring) shift
    if (m <= SHRT_MAX && static_cast<double>(n) * m * m <= INT32_MAX && 2.0 * m * m <= INT32_MAX) {
      break;
    }
  }
  pair.ref.create(ref_full.size(), CV_16SC1);
  pair.tgt.create(tgt_full.size(), CV_16SC1);
  auto convert = [&](const cv::Mat& src, cv::Mat* dst) {
    if (src.depth() == CV_8U) {
      ConvertRows<std::uint8_t>(src, offset, pair.shift, flip, rows, dst);
    } else {
      ConvertRows<std::uint16_t>(src, offset, pair.shift, flip, rows, dst);
    }
  };
  tbb::parallel_invoke([&] { convert(ref_full, &pair.ref); }, [&] { convert(tgt_full, &pair.tgt); });
  return pair;
}

int CeilToMultiple(int value, int step) {
  return value >= 0 ? (value + step - 1) / step * step : -((-value) / step * step);
}
int FloorToMultiple(int value, int step) {
  return value >= 0 ? value / step * step : -((-value + step - 1) / step * step);
}

// Filters 1-3 and the sub-pixel interpolation of one grid pixel.
Rejection Classify(const PeakRecord& rec, const NccOptions& options, int d_min, float* disparity,
                   float* correlation) {
  if (rec.status == PeakRecord::kBorder) return Rejection::kBorder;
  if (rec.status == PeakRecord::kLowTexture) return Rejection::kLowTexture;
  *correlation = rec.c_best;
  const double c = rec.c_best, c2 = rec.c_second;
  if (c < options.min_correlation) return Rejection::kLowCorrelation;
  if (options.ambiguity > 0 && std::isfinite(c2) && c > 0 && (c - c2) / c < options.ambiguity) {
    return Rejection::kAmbiguous;
  }
  if (rec.best == rec.lo || rec.best == rec.hi) return Rejection::kRangeEdge;
  *disparity = static_cast<float>(d_min + rec.best +
                                  ParabolicPeakOffset(rec.c_prev, rec.c_best, rec.c_next));
  return Rejection::kAccepted;
}

// Grid maps filled row by row by the kernel's sink.
struct GridMaps {
  const NccOptions* options;
  int d_min;
  cv::Mat disparity, correlation, rejection;
};

void ClassifyRow(void* context, int row, const PeakRecord* records) {
  auto* maps = static_cast<GridMaps*>(context);
  auto* disp = maps->disparity.ptr<float>(row);
  auto* corr = maps->correlation.ptr<float>(row);
  auto* reason = maps->rejection.ptr<std::uint8_t>(row);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int i = 0; i < maps->disparity.cols; ++i) {
    disp[i] = corr[i] = nan;
    reason[i] = static_cast<std::uint8_t>(
        Classify(records[i], *maps->options, maps->d_min, &disp[i], &corr[i]));
  }
}

// Scratch memory of the kernel, kept per thread so that a batch does not map and clear
// fresh pages for every pair.
void* ThreadWorkspace(std::size_t bytes) {
  thread_local std::vector<unsigned char> buffer;
  if (buffer.size() < bytes + 64) buffer.resize(bytes + 64);
  return reinterpret_cast<void*>((reinterpret_cast<std::uintptr_t>(buffer.data()) + 63) / 64 * 64);
}

// Runs the kernel over all output rows, split into chunks for the current arena's threads.
void RunKernelParallel(const KernelInput& in, GridMaps* maps) {
  const internal::KernelFn kernel = internal::SelectKernel();
  const std::size_t workspace_bytes = internal::KernelWorkspaceBytes(in);
  auto run_chunk = [&](int row_begin, int row_end) {
    kernel(in, row_begin, row_end, ThreadWorkspace(workspace_bytes), &ClassifyRow, maps);
  };
  const int threads = tbb::this_task_arena::max_concurrency();
  // Each chunk starts with a full window of rows (2*my+1 row updates), so chunks are kept
  // several windows tall; a multiple of the thread count keeps the threads equally busy.
  const int window_rows = 2 * in.my + 1;
  int num_chunks = 1;
  if (in.num_rows >= 2 * threads * 4 * window_rows) {
    num_chunks = 2 * threads;
  } else if (in.num_rows >= threads * window_rows) {
    num_chunks = threads;
  }
  if (num_chunks == 1) {
    run_chunk(0, in.num_rows);
    return;
  }
  tbb::parallel_for(0, num_chunks, [&](int c) {
    const int begin = static_cast<int>(static_cast<long>(in.num_rows) * c / num_chunks);
    const int end = static_cast<int>(static_cast<long>(in.num_rows) * (c + 1) / num_chunks);
    if (begin < end) run_chunk(begin, end);
  });
}


}  // namespace

std::string ActiveKernelName() {
  const char* name = nullptr;
  internal::SelectKernel(&name);
  return name;
}

namespace {

void MatchWindowInCurrentArena(const NccOptions& options, const cv::Mat& left, const cv::Mat& right,
                               int bit_depth, NccResult* out) {
  util::Timer timer;
  util::StageClock clock;  // the working pair (16-bit, shifted) counts with the correlation
  const int width = left.cols, height = left.rows;
  const int dx = options.step_x_px, dy = options.step_y_px;
  const bool flip = options.reference == ReferenceImage::kLeft;

  KernelInput in;
  in.width = width;
  in.height = height;
  in.step_x = dx;
  in.step_y = dy;
  in.mx = options.half_window_x_px / dx;
  in.my = options.half_window_y_px / dy;
  const int n = (2 * in.mx + 1) * (2 * in.my + 1);
  // The grid is anchored at column 0 of the reference image; flipped, that is column W-1.
  in.x0 = flip ? (width - 1) % dx : 0;
  in.num_cols = (width - 1 - in.x0) / dx + 1;
  in.d_min = options.min_disparity_px;
  in.num_disp = options.max_disparity_px - options.min_disparity_px + 1;

  // Row band on the grid, and the part of it whose windows fit in the image.
  const int band_lo = std::max(0, options.min_row.value_or(0));
  const int band_hi = std::min(height - 1, options.max_row.value_or(height - 1));
  const int grid_lo = CeilToMultiple(band_lo, dy);
  const int grid_hi = FloorToMultiple(band_hi, dy);
  const int fit_lo = std::max(grid_lo, in.my * dy);
  const int fit_hi = std::min(grid_hi, FloorToMultiple(height - 1 - in.my * dy, dy));
  in.first_row = fit_lo;
  in.num_rows = fit_hi >= fit_lo ? (fit_hi - fit_lo) / dy + 1 : 0;
  const int band_grid_rows = grid_hi >= grid_lo ? (grid_hi - grid_lo) / dy + 1 : 0;

  // Full-size output maps. At full resolution with the right reference the grid rows are
  // rows of these maps, so the kernel writes into them directly; otherwise into grid maps
  // that are scattered afterwards.
  const float nan = std::numeric_limits<float>::quiet_NaN();
  NccResult& result = *out;
  result.summary = NccSummary{};
  result.disparity_px.create(height, width, CV_32FC1);
  result.correlation.create(height, width, CV_32FC1);
  result.rejection.create(height, width, CV_8UC1);
  const bool direct = dx == 1 && dy == 1 && !flip && in.num_rows > 0;
  WorkingPair work;
  GridMaps grid{&options, in.d_min, {}, {}, {}};
  if (direct) {
    const cv::Range grid_rows(fit_lo, fit_lo + in.num_rows);
    grid.disparity = result.disparity_px.rowRange(grid_rows);
    grid.correlation = result.correlation.rowRange(grid_rows);
    grid.rejection = result.rejection.rowRange(grid_rows);
  } else {
    grid.disparity.create(in.num_rows, in.num_cols, CV_32FC1);
    grid.correlation.create(in.num_rows, in.num_cols, CV_32FC1);
    grid.rejection.create(in.num_rows, in.num_cols, CV_8UC1);
  }
  if (in.num_rows > 0) {
    const cv::Range rows(fit_lo - in.my * dy, fit_hi + in.my * dy + 1);
    work = MakeWorkingPair(flip ? left : right, flip ? right : left, n, flip, rows);
    in.ref = work.ref.ptr<std::int16_t>();
    in.tgt = work.tgt.ptr<std::int16_t>();
    const double sigma_min_work =
        options.min_sigma * GreyScaleFactor(bit_depth) / std::ldexp(1.0, work.shift);
    in.min_var = (sigma_min_work * n) * (sigma_min_work * n);
    in.min_correlation = options.min_correlation;
    in.ambiguity = options.ambiguity;
    // Filters 1-3 and the sub-pixel interpolation run in the kernel's row sink.
    RunKernelParallel(in, &grid);
  }
  clock.Lap("correlation");  // C over the window and disparities, filters 1-3, sub-pixel
  cv::Mat& grid_disp = grid.disparity;
  cv::Mat& grid_corr = grid.correlation;
  cv::Mat& grid_reason = grid.rejection;
  MedianFilterDisparityGrid(options.median_size, &grid_disp, &grid_reason);
  if (options.border_tolerance_px >= 0) {  // after the filters: only surviving matches set its bound
    RejectMatchesBeyondTheBorder(in.x0, dx, width, std::vector<int>(grid_disp.rows, options.max_disparity_px + in.mx * dx),
                                 in.mx * dx, options.border_tolerance_px, &grid_disp, &grid_reason);
  }
  clock.Lap("filters");  // median (filter 4), border rule

  // Everything outside the grid rows, then the grid scattered into the reference image's
  // columns (unless the kernel wrote into the maps directly).
  auto clear_rows = [&](int begin, int end) {
    if (begin >= end) return;
    result.disparity_px.rowRange(begin, end).setTo(nan);
    result.correlation.rowRange(begin, end).setTo(nan);
    result.rejection.rowRange(begin, end).setTo(static_cast<int>(Rejection::kNotEvaluated));
  };
  if (direct) {
    clear_rows(0, fit_lo);
    clear_rows(fit_lo + in.num_rows, height);
  } else {
    clear_rows(0, height);
  }
  NccSummary& s = result.summary;
  tbb::parallel_for(0, band_grid_rows, [&](int row) {
    const int y = grid_lo + row * dy;
    if (direct && y >= fit_lo && y <= fit_hi) return;  // already in place
    const bool fits = y >= fit_lo && y <= fit_hi;
    const int j = fits ? (y - fit_lo) / dy : -1;
    auto* out_reason = result.rejection.ptr<std::uint8_t>(y);
    auto* out_disp = result.disparity_px.ptr<float>(y);
    auto* out_corr = result.correlation.ptr<float>(y);
    for (int i = 0; i < in.num_cols; ++i) {
      const int x_work = in.x0 + i * dx;
      const int x = flip ? width - 1 - x_work : x_work;
      if (!fits) {
        out_reason[x] = static_cast<std::uint8_t>(Rejection::kBorder);
        continue;
      }
      out_reason[x] = grid_reason.at<std::uint8_t>(j, i);
      out_disp[x] = grid_disp.at<float>(j, i);
      out_corr[x] = grid_corr.at<float>(j, i);
    }
  });
  for (int j = 0; j < in.num_rows; ++j) {
    const auto* reason = grid_reason.ptr<std::uint8_t>(j);
    for (int i = 0; i < in.num_cols; ++i) ++s.pixels_by_reason[reason[i]];
  }

  s.width = width;
  s.height = height;
  s.band_min_row = band_lo;
  s.band_max_row = band_hi;
  s.working_shift_bits = work.shift;
  s.bit_depth = bit_depth;
  s.pixels_by_reason[static_cast<int>(Rejection::kBorder)] +=
      (band_grid_rows - in.num_rows) * in.num_cols;
  s.evaluated_pixels = band_grid_rows * in.num_cols;
  s.pixels_by_reason[static_cast<int>(Rejection::kNotEvaluated)] =
      width * height - s.evaluated_pixels;
  s.accepted_pixels = s.pixels_by_reason[static_cast<int>(Rejection::kAccepted)];
  clock.Lap("scatter");
  s.stage_seconds = clock.Take();
  s.match_seconds = timer.ElapsedSeconds();
}

void MatchInCurrentArena(const NccOptions& options, const cv::Mat& left, const cv::Mat& right,
                         NccResult* out) {
  const int bit_depth = EffectiveBitDepth(options, left);
  if (options.aggregation == Aggregation::kSemiGlobal) {
    internal::MatchSemiGlobal(options, left, right, bit_depth, out);
  } else {
    MatchWindowInCurrentArena(options, left, right, bit_depth, out);
  }
}

}  // namespace

int EffectiveBitDepth(const NccOptions& options, const cv::Mat& image) {
  const int type_bits = image.depth() == CV_8U ? 8 : 16;
  return options.bit_depth > 0 ? std::min(options.bit_depth, type_bits) : type_bits;
}

NccResult MatchStereoPair(const NccOptions& options, const cv::Mat& left, const cv::Mat& right) {
  NccResult result;
  MatchStereoPair(options, left, right, &result);
  return result;
}

void MatchStereoPair(const NccOptions& options, const cv::Mat& left, const cv::Mat& right,
                     NccResult* result) {
  LN_CHECK(result != nullptr);
  options.Validate();
  LN_CHECK_INPUT(!left.empty() && !right.empty()) << "empty image";
  LN_CHECK_INPUT(left.size() == right.size())
      << "image sizes differ: left " << left.cols << "x" << left.rows << ", right " << right.cols
      << "x" << right.rows;
  LN_CHECK_INPUT(left.type() == right.type())
      << "image types differ (one is 8-bit, the other 16-bit)";
  LN_CHECK_INPUT(left.type() == CV_8UC1 || left.type() == CV_16UC1)
      << "images must be 8- or 16-bit single-channel";
  // Isolated: while this pair's parallel loops wait, the thread runs only their tasks, never
  // another pair's match, which would take over the per-thread workspace this one is using.
  auto match = [&] { tbb::this_task_arena::isolate([&] { MatchInCurrentArena(options, left, right, result); }); };
  if (options.num_threads == 0) {
    match();
    return;
  }
  tbb::task_arena arena(util::EffectiveThreadCount(options.num_threads));
  arena.execute(match);
}

}  // namespace lunarnav::stereo
