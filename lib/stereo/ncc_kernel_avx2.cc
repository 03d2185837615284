// The correlation kernel compiled for AVX2 (-mavx2, no FMA so results match the baseline
// kernel bit for bit). Only called after a run-time check of the CPU.
#define CV_CPU_DISPATCH_MODE AVX2
#include <cstddef>
#include <cstdint>

#include <opencv2/core/simd_intrinsics.hpp>

#include "stereo/ncc_kernel.h"

namespace lunarnav::stereo::internal::avx2 {
#include "stereo/ncc_kernel_impl.h"

void RunKernel(const KernelInput& in, int row_begin, int row_end, void* workspace, RowSink sink,
               void* sink_context) {
  static_assert(kLanes == 8, "the AVX2 kernel must use 256-bit vectors");
  RunKernelImpl(in, row_begin, row_end, workspace, sink, sink_context);
}
}  // namespace lunarnav::stereo::internal::avx2
