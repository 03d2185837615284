#include "stereo/census_hamming.h"

#include "stereo/simd_select.h"

namespace lunarnav::stereo::internal {
namespace hamming {

void Baseline(const SgmInput& in, int j, int i_begin, int i_end, std::uint8_t* cost) {
  for (int i = i_begin; i < i_end; ++i) {
    const Span s = SpanAt(in, j, i, i_begin, cost);
    for (int k = s.k_lo; k < s.k_hi; ++k) s.c[k] = static_cast<std::uint8_t>(__builtin_popcountll(s.r ^ s.t[k]));
  }
}

}  // namespace hamming

HammingFn SelectHammingKernel(const char** name) { return WidestAllowedKernel(RunnableHammingKernels(), name); }

std::vector<std::pair<const char*, HammingFn>> RunnableHammingKernels() {
  std::vector<std::pair<const char*, HammingFn>> kernels = {{"baseline", &hamming::Baseline}};
#if defined(LUNARNAV_HAVE_AVX2_KERNEL)
  if (__builtin_cpu_supports("avx2")) kernels.emplace_back("avx2", &hamming::Avx2);
#endif
#if defined(LUNARNAV_HAVE_HAMMING_AVX512)
  if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vpopcntdq")) {
    kernels.emplace_back("avx512", &hamming::Avx512);
  }
#endif
  return kernels;
}

}  // namespace lunarnav::stereo::internal
