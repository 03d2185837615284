// The choice among a kernel's instruction-set variants, shared by the stereo module's kernels
// (the correlation kernel, the census Hamming distances). Internal to the stereo module.
#pragma once

#include <cstdlib>
#include <cstring>
#include <utility>
#include <vector>

namespace lunarnav::stereo::internal {

/// The widest of `kernels` (those this CPU runs, narrowest first, named "baseline", "avx2" or
/// "avx512") that LUNARNAV_SIMD allows: unset or "avx512" allows all, "avx2" up to AVX2,
/// anything else the baseline only (to measure or compare the kernels; a request the CPU
/// cannot run falls back to the widest it can). Its name in `*name` when given.
template <typename Fn>
Fn WidestAllowedKernel(const std::vector<std::pair<const char*, Fn>>& kernels, const char** name) {
  auto level = [](const char* n) { return std::strcmp(n, "avx512") == 0 ? 2 : std::strcmp(n, "avx2") == 0 ? 1 : 0; };
  const char* cap = std::getenv("LUNARNAV_SIMD");
  const int allowed = cap == nullptr ? 2 : std::strcmp(cap, "avx512") == 0 ? 2 : std::strcmp(cap, "avx2") == 0 ? 1 : 0;
  std::pair<const char*, Fn> chosen = kernels.front();
  for (const auto& kernel : kernels) {
    if (level(kernel.first) <= allowed) chosen = kernel;
  }
  if (name != nullptr) *name = chosen.first;
  return chosen.second;
}

}  // namespace lunarnav::stereo::internal
