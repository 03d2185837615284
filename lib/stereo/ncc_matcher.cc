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
#include <tbb/task_arena.h>

#include "stereo/disparity_filters.h"
#include "stereo/ncc_kernel.h"
#include "util/check.h"
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
void ConvertRows(const cv::Mat& src, int offset, int shift, bool flip, cv::Mat* dst) {
  const int width = src.cols;
  for (int y = 0; y < src.rows; ++y) {
    const T* in = src.ptr<T>(y);
    auto* out = dst->ptr<std::int16_t>(y);
    for (int x = 0; x < width; ++x) {
      const int v = (static_cast<int>(in[x]) - offset) >> shift;
      out[flip ? width - 1 - x : x] = static_cast<std::int16_t>(v);
    }
  }
}

WorkingPair MakeWorkingPair(const cv::Mat& ref, const cv::Mat& tgt, int n, bool flip) {
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
  pair.ref.create(ref.size(), CV_16SC1);
  pair.tgt.create(tgt.size(), CV_16SC1);
  if (ref.depth() == CV_8U) {
    ConvertRows<std::uint8_t>(ref, offset, pair.shift, flip, &pair.ref);
    ConvertRows<std::uint8_t>(tgt, offset, pair.shift, flip, &pair.tgt);
  } else {
    ConvertRows<std::uint16_t>(ref, offset, pair.shift, flip, &pair.ref);
    ConvertRows<std::uint16_t>(tgt, offset, pair.shift, flip, &pair.tgt);
  }
  return pair;
}

int CeilToMultiple(int value, int step) {
  return value >= 0 ? (value + step - 1) / step * step : -((-value) / step * step);
}
int FloorToMultiple(int value, int step) {
  return value >= 0 ? value / step * step : -((-value + step - 1) / step * step);
}

// Runs the kernel over all output rows, split into chunks for the worker threads.
void RunKernelParallel(const KernelInput& in, int num_threads, std::vector<PeakRecord>* records) {
  const internal::KernelFn kernel = internal::SelectKernel();
  const std::size_t workspace_bytes = internal::KernelWorkspaceBytes(in);
  auto run_chunk = [&](int row_begin, int row_end) {
    std::unique_ptr<unsigned char[]> buffer(new unsigned char[workspace_bytes + 64]);
    void* aligned = reinterpret_cast<void*>(
        (reinterpret_cast<std::uintptr_t>(buffer.get()) + 63) / 64 * 64);
    kernel(in, row_begin, row_end, aligned, records->data());
  };
  const int threads =
      num_threads > 0 ? num_threads : tbb::this_task_arena::max_concurrency();
  // Each chunk starts with a full window of rows (2*my+1 row updates), so chunks are kept
  // several windows tall; two chunks per thread balance uneven rows.
  const int min_chunk = 4 * (2 * in.my + 1);
  const int num_chunks =
      std::max(1, std::min(2 * threads, in.num_rows / std::max(1, min_chunk)));
  if (threads == 1 || num_chunks == 1) {
    run_chunk(0, in.num_rows);
    return;
  }
  auto body = [&] {
    tbb::parallel_for(0, num_chunks, [&](int c) {
      const int begin = static_cast<int>(static_cast<long>(in.num_rows) * c / num_chunks);
      const int end = static_cast<int>(static_cast<long>(in.num_rows) * (c + 1) / num_chunks);
      if (begin < end) run_chunk(begin, end);
    });
  };
  if (num_threads > 0) {
    tbb::task_arena arena(num_threads);
    arena.execute(body);
  } else {
    body();
  }
}

}  // namespace

std::string ActiveKernelName() {
  const char* name = nullptr;
  internal::SelectKernel(&name);
  return name;
}

NccResult MatchStereoPair(const NccOptions& options, const cv::Mat& left, const cv::Mat& right) {
  options.Validate();
  LN_CHECK_INPUT(!left.empty() && !right.empty()) << "empty image";
  LN_CHECK_INPUT(left.size() == right.size())
      << "image sizes differ: left " << left.cols << "x" << left.rows << ", right " << right.cols
      << "x" << right.rows;
  LN_CHECK_INPUT(left.type() == right.type())
      << "image types differ (one is 8-bit, the other 16-bit)";
  LN_CHECK_INPUT(left.type() == CV_8UC1 || left.type() == CV_16UC1)
      << "images must be 8- or 16-bit single-channel";
  util::Timer timer;
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

  const WorkingPair work = MakeWorkingPair(flip ? left : right, flip ? right : left, n, flip);
  in.ref = work.ref.ptr<std::int16_t>();
  in.tgt = work.tgt.ptr<std::int16_t>();
  const double full_scale = left.depth() == CV_8U ? 255.0 : 65535.0;
  const double sigma_min_work = options.min_sigma * (full_scale / 255.0) / std::ldexp(1.0, work.shift);
  in.min_var = (sigma_min_work * n) * (sigma_min_work * n);

  std::vector<PeakRecord> records(static_cast<std::size_t>(in.num_rows) * in.num_cols);
  if (in.num_rows > 0) RunKernelParallel(in, options.num_threads, &records);

  // Filters 1-3 and sub-pixel interpolation, on the grid.
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cv::Mat grid_disp(in.num_rows, in.num_cols, CV_32FC1, cv::Scalar(nan));
  cv::Mat grid_corr(in.num_rows, in.num_cols, CV_32FC1, cv::Scalar(nan));
  cv::Mat grid_reason(in.num_rows, in.num_cols, CV_8UC1);
  for (int j = 0; j < in.num_rows; ++j) {
    for (int i = 0; i < in.num_cols; ++i) {
      const PeakRecord& rec = records[static_cast<std::size_t>(j) * in.num_cols + i];
      Rejection reason = Rejection::kAccepted;
      if (rec.status == PeakRecord::kBorder) {
        reason = Rejection::kBorder;
      } else if (rec.status == PeakRecord::kLowTexture) {
        reason = Rejection::kLowTexture;
      } else {
        grid_corr.at<float>(j, i) = rec.c_best;
        const double c = rec.c_best, c2 = rec.c_second;
        if (c < options.min_correlation) {
          reason = Rejection::kLowCorrelation;
        } else if (options.ambiguity > 0 && std::isfinite(c2) && c > 0 &&
                   (c - c2) / c < options.ambiguity) {
          reason = Rejection::kAmbiguous;
        } else if (rec.best == rec.lo || rec.best == rec.hi) {
          reason = Rejection::kRangeEdge;
        } else {
          grid_disp.at<float>(j, i) = static_cast<float>(
              in.d_min + rec.best + ParabolicPeakOffset(rec.c_prev, rec.c_best, rec.c_next));
        }
      }
      grid_reason.at<std::uint8_t>(j, i) = static_cast<std::uint8_t>(reason);
    }
  }
  MedianFilterDisparityGrid(options.median_size, &grid_disp, &grid_reason);

  // Scatter the grid into full-size maps in the reference image's columns.
  NccResult result;
  result.disparity_px.create(height, width, CV_32FC1);
  result.disparity_px.setTo(nan);
  result.correlation.create(height, width, CV_32FC1);
  result.correlation.setTo(nan);
  result.rejection.create(height, width, CV_8UC1);
  result.rejection.setTo(static_cast<int>(Rejection::kNotEvaluated));
  for (int y = grid_lo; y <= grid_hi; y += dy) {
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
  }

  NccSummary& s = result.summary;
  s.width = width;
  s.height = height;
  s.band_min_row = band_lo;
  s.band_max_row = band_hi;
  s.working_shift_bits = work.shift;
  for (int y = 0; y < height; ++y) {
    const auto* row = result.rejection.ptr<std::uint8_t>(y);
    for (int x = 0; x < width; ++x) ++s.pixels_by_reason[row[x]];
  }
  s.accepted_pixels = s.pixels_by_reason[static_cast<int>(Rejection::kAccepted)];
  s.evaluated_pixels =
      width * height - s.pixels_by_reason[static_cast<int>(Rejection::kNotEvaluated)];
  s.match_seconds = timer.ElapsedSeconds();
  return result;
}

}  // namespace lunarnav::stereo
