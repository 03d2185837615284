// Internal interface between the matcher and its SIMD correlation kernels.
//
// The kernel works on "working" images: int16, centred on the pair's mean and right-shifted
// so that every window sum of products fits exactly in int32 (see ncc_matcher.cc). It is
// written once (ncc_kernel_impl.h) with OpenCV's universal intrinsics and compiled twice:
// for the baseline instruction set and, on x86-64, for AVX2, chosen at run time.
//
// Conventions: the reference image R and the target image T are matched as
// T(x + d_min + k, y) <-> R(x, y), k = 0 .. num_disp-1 (the matcher flips both images
// horizontally for a left reference, so this one form covers both conventions).
#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace lunarnav::stereo::internal {

/// What one kernel call processes.
struct KernelInput {
  const std::int16_t* ref = nullptr;  ///< R, height x width, row-major, centred working values.
  const std::int16_t* tgt = nullptr;  ///< T, same size.
  int width = 0, height = 0;
  int step_x = 1, step_y = 1;  ///< Subsampling steps dx, dy.
  int mx = 0, my = 0;          ///< Half-window in grid steps: floor(w_x/dx), floor(w_y/dy).
  int x0 = 0;                  ///< Column of grid column 0; grid column i is x0 + i*dx.
  int num_cols = 0;            ///< Number of grid columns (x0 + i*dx < width).
  int first_row = 0;           ///< Row of output row 0; output row j is first_row + j*dy.
  int num_rows = 0;            ///< Output rows; every one has its whole window inside the image.
  int d_min = 0;               ///< First disparity searched.
  int num_disp = 1;            ///< Number of disparities searched (d_min .. d_min+num_disp-1).
  /// Low-texture threshold on V_r = n*sum(r^2) - (sum r)^2 (= n^2 sigma_r^2): a window with
  /// V_r < min_var is not searched (filter 1).
  double min_var = 0;
  /// Filters 2 and 3, used only to skip work: the second peak is looked for only when the
  /// best C >= min_correlation, and only among peaks above C * (1 - ambiguity).
  double min_correlation = -1.0;
  double ambiguity = 0.0;
};

/// What the kernel found at one grid pixel.
struct PeakRecord {
  enum Status : std::int8_t { kSearched = 0, kBorder = 1, kLowTexture = 2 };
  std::int8_t status = kBorder;
  std::int16_t best = -1;    ///< Index k of the best disparity (disparity d_min + k).
  std::int16_t lo = 0;       ///< Searchable index range [lo, hi]: the target window is inside.
  std::int16_t hi = -1;
  float c_best = 0;          ///< C at best, evaluated exactly (in double) from the integer sums.
  float c_prev = 0;          ///< C at best-1 (exact); meaningless when best == lo.
  float c_next = 0;          ///< C at best+1 (exact); meaningless when best == hi.
  /// Second-highest peak of C over [lo, hi] when it exceeds c_best * (1 - ambiguity) and
  /// c_best >= min_correlation > 0 (the only case where filter 3 needs it); -inf otherwise.
  float c_second = 0;
};

/// Disparities padded to a multiple of the widest vector (16 int32 lanes).
static inline int PaddedDisparities(int num_disp) { return (num_disp + 15) / 16 * 16; }

/// Bytes of scratch memory one kernel call needs (allocated by the caller, 64-byte aligned).
std::size_t KernelWorkspaceBytes(const KernelInput& in);

/// Receives each finished output row j: records[i] for grid columns i = 0 .. num_cols-1.
using RowSink = void (*)(void* context, int row, const PeakRecord* records);

/// Computes output rows [row_begin, row_end), handing each to `sink` as soon as it is done.
using KernelFn = void (*)(const KernelInput& in, int row_begin, int row_end, void* workspace,
                          RowSink sink, void* sink_context);

/// The fastest kernel this CPU runs, and its name ("avx512", "avx2" or "baseline").
KernelFn SelectKernel(const char** name = nullptr);
/// The portable kernel (for tests that compare both).
KernelFn BaselineKernel();

/// Every kernel this build has and this CPU runs, by name, the baseline first (for tests that
/// check they all agree).
std::vector<std::pair<const char*, KernelFn>> RunnableKernels();

}  // namespace lunarnav::stereo::internal
