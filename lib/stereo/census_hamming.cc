#include "stereo/census_hamming.h"

#include <cstdlib>
#include <cstring>

namespace lunarnav::stereo::internal {
namespace hamming {

void Baseline(const SgmInput& in, int j, int i_begin, int i_end, std::uint8_t* cost) {
  for (int i = i_begin; i < i_end; ++i) {
    const Span s = SpanAt(in, j, i, i_begin, cost);
    for (int k = s.k_lo; k < s.k_hi; ++k) s.c[k] = static_cast<std::uint8_t>(__builtin_popcountll(s.r ^ s.t[k]));
  }
}

}  // namespace hamming

HammingFn SelectHammingKernel(const char** name) {
  const char* cap = std::getenv("LUNARNAV_SIMD");
  const bool allow_avx512 = cap == nullptr || std::strcmp(cap, "avx512") == 0;
  const bool allow_avx2 = allow_avx512 || std::strcmp(cap, "avx2") == 0;
#if defined(LUNARNAV_HAVE_HAMMING_AVX512)
  if (allow_avx512 && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vpopcntdq")) {
    if (name != nullptr) *name = "avx512";
    return &hamming::Avx512;
  }
#endif
#if defined(LUNARNAV_HAVE_AVX2_KERNEL)
  if (allow_avx2 && __builtin_cpu_supports("avx2")) {
    if (name != nullptr) *name = "avx2";
    return &hamming::Avx2;
  }
#endif
  (void)allow_avx2;
  if (name != nullptr) *name = "baseline";
  return &hamming::Baseline;
}

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
