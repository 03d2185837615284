// The census part of the quality preset's matching cost: Hamming distances between a
// reference pixel's census code and the target codes of its disparities, compiled for the
// baseline instruction set, AVX2 (a nibble-table popcount, 16 codes a step) and AVX-512 with
// VPOPCNTDQ (8 codes an instruction); the CPU picks the widest it runs. Integer counts: every
// kernel gives the same bytes. Internal to the stereo module.
#pragma once

#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

#include "stereo/semi_global.h"

namespace lunarnav::stereo::internal {

/// Writes the census Hamming distances of the grid pixels [i_begin, i_end) of row j: for grid
/// pixel i (image column x), cost[(i - i_begin) n + k] = popcount(ref(x) ^ tgt(x + d + k)) for
/// the k whose target column lies inside the image, n = in.RowDisp(j), d the row's first
/// disparity. The other entries are left alone.
using HammingFn = void (*)(const SgmInput& in, int j, int i_begin, int i_end, std::uint8_t* cost);

/// The kernel this CPU runs: "avx512", "avx2" or "baseline" (LUNARNAV_SIMD=baseline|avx2|avx512
/// caps it, as for the correlation kernels).
HammingFn SelectHammingKernel(const char** name = nullptr);

/// Every kernel this CPU can run, by name (tests compare them).
std::vector<std::pair<const char*, HammingFn>> RunnableHammingKernels();

namespace hamming {

/// Where grid pixel i's distances go and which targets are inside the image: the codes
/// t[k_lo .. k_hi) against r, into c[k_lo .. k_hi). Internal linkage: each kernel's file
/// compiles its own copy for its instruction set.
struct Span {
  std::uint64_t r = 0;
  const std::uint64_t* t = nullptr;
  std::uint8_t* c = nullptr;
  int k_lo = 0, k_hi = 0;
};
static inline Span SpanAt(const SgmInput& in, int j, int i, int i_begin, std::uint8_t* cost) {
  const int n = in.RowDisp(j), width = in.width;
  const int d_min = in.d_min + in.Shift(j);
  const int y = in.y0 + j * in.step_y;
  const int x = in.x0 + i * in.step_x;
  Span span;
  span.k_lo = std::clamp(-x - d_min, 0, n);
  span.k_hi = std::clamp(width - x - d_min, span.k_lo, n);
  span.r = in.ref_census[static_cast<std::size_t>(y) * width + x];
  span.t = in.tgt_census + static_cast<std::size_t>(y) * width + x + d_min;
  span.c = cost + static_cast<std::size_t>(i - i_begin) * n;
  return span;
}

void Baseline(const SgmInput& in, int j, int i_begin, int i_end, std::uint8_t* cost);
void Avx2(const SgmInput& in, int j, int i_begin, int i_end, std::uint8_t* cost);
void Avx512(const SgmInput& in, int j, int i_begin, int i_end, std::uint8_t* cost);

}  // namespace hamming
}  // namespace lunarnav::stereo::internal
