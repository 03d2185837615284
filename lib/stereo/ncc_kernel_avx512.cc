// The correlation kernel compiled for AVX-512 (F, BW, DQ, VL, CD: the "Skylake-X" set that
// OpenCV's universal intrinsics use for 512-bit vectors; no FMA contraction, so results match
// the other kernels bit for bit). Only called after a run-time check of the CPU.
#define CV_CPU_DISPATCH_MODE AVX512_SKX
#include <cstddef>
#include <cstdint>

#include <opencv2/core/simd_intrinsics.hpp>

#include "stereo/ncc_kernel.h"

namespace lunarnav::stereo::internal::avx512 {
#include "stereo/ncc_kernel_impl.h"

void RunKernel(const KernelInput& in, int row_begin, int row_end, void* workspace, RowSink sink,
               void* sink_context) {
  static_assert(kLanes == 16, "the AVX-512 kernel must use 512-bit vectors");
  RunKernelImpl(in, row_begin, row_end, workspace, sink, sink_context);
}
}  // namespace lunarnav::stereo::internal::avx512
