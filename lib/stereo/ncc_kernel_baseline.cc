// The correlation kernel for the baseline instruction set (SSE2 on x86-64, NEON on ARM).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include <opencv2/core/hal/intrin.hpp>

#include "stereo/ncc_kernel.h"
#include "stereo/simd_select.h"

namespace lunarnav::stereo::internal {
namespace baseline {
#include "stereo/ncc_kernel_impl.h"
}  // namespace baseline

#if defined(LUNARNAV_HAVE_AVX2_KERNEL)
namespace avx2 {
void RunKernel(const KernelInput& in, int row_begin, int row_end, void* workspace, RowSink sink,
               void* sink_context);
}  // namespace avx2
#endif
#if defined(LUNARNAV_HAVE_AVX512_KERNEL)
namespace avx512 {
void RunKernel(const KernelInput& in, int row_begin, int row_end, void* workspace, RowSink sink,
               void* sink_context);
}  // namespace avx512
#endif

std::size_t KernelWorkspaceBytes(const KernelInput& in) {
  baseline::Workspace ws;
  return baseline::LayoutWorkspace(in, baseline::MakeGeometry(in), nullptr, &ws);
}

KernelFn BaselineKernel() { return &baseline::RunKernelImpl; }

KernelFn SelectKernel(const char** name) { return WidestAllowedKernel(RunnableKernels(), name); }

std::vector<std::pair<const char*, KernelFn>> RunnableKernels() {
  std::vector<std::pair<const char*, KernelFn>> kernels = {{"baseline", &baseline::RunKernelImpl}};
#if defined(LUNARNAV_HAVE_AVX2_KERNEL)
  if (__builtin_cpu_supports("avx2")) kernels.emplace_back("avx2", &avx2::RunKernel);
#endif
#if defined(LUNARNAV_HAVE_AVX512_KERNEL)
  if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512dq") &&
      __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512cd")) {
    kernels.emplace_back("avx512", &avx512::RunKernel);
  }
#endif
  return kernels;
}

}  // namespace lunarnav::stereo::internal
