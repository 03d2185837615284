// The census Hamming distances for AVX-512 with VPOPCNTDQ (compiled with those flags; called
// after a run-time check): 8 codes counted by one instruction.
#include <immintrin.h>

#include "stereo/census_hamming.h"

namespace lunarnav::stereo::internal::hamming {

void Avx512(const SgmInput& in, int j, int i_begin, int i_end, std::uint8_t* cost) {
  for (int i = i_begin; i < i_end; ++i) {
    const Span s = SpanAt(in, j, i, i_begin, cost);
    const __m512i r = _mm512_set1_epi64(static_cast<long long>(s.r));
    int k = s.k_lo;
    for (; k + 8 <= s.k_hi; k += 8) {
      const __m512i x = _mm512_xor_si512(_mm512_loadu_si512(s.t + k), r);
      _mm_storel_epi64(reinterpret_cast<__m128i*>(s.c + k), _mm512_cvtepi64_epi8(_mm512_popcnt_epi64(x)));
    }
    if (k < s.k_hi) {
      const auto mask = static_cast<__mmask8>((1u << (s.k_hi - k)) - 1);
      const __m512i x = _mm512_xor_si512(_mm512_maskz_loadu_epi64(mask, s.t + k), r);
      _mm512_mask_cvtepi64_storeu_epi8(s.c + k, mask, _mm512_popcnt_epi64(x));
    }
  }
}

}  // namespace lunarnav::stereo::internal::hamming
