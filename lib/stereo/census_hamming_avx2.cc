// The census Hamming distances for AVX2 (compiled with -mavx2; called after a run-time check).
#include <immintrin.h>

#include "stereo/census_hamming.h"

namespace lunarnav::stereo::internal::hamming {

void Avx2(const SgmInput& in, int j, int i_begin, int i_end, std::uint8_t* cost) {
  // Each byte's bits counted by a table of the 16 nibbles, summed over a code's 8 bytes.
  const __m256i table = _mm256_setr_epi8(0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4,  //
                                         0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4);
  const __m256i nibble = _mm256_set1_epi8(0x0f);
  const __m256i zero = _mm256_setzero_si256();
  for (int i = i_begin; i < i_end; ++i) {
    const Span s = SpanAt(in, j, i, i_begin, cost);
    const __m256i r = _mm256_set1_epi64x(static_cast<long long>(s.r));
    int k = s.k_lo;
    for (; k + 16 <= s.k_hi; k += 16) {
      __m256i counts[4];  // counts[q]: codes k + 4q .. k + 4q + 3, one per 64-bit lane
      for (int q = 0; q < 4; ++q) {
        const __m256i x =
            _mm256_xor_si256(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(s.t + k + 4 * q)), r);
        const __m256i low = _mm256_shuffle_epi8(table, _mm256_and_si256(x, nibble));
        const __m256i high = _mm256_shuffle_epi8(table, _mm256_and_si256(_mm256_srli_epi16(x, 4), nibble));
        counts[q] = _mm256_sad_epu8(_mm256_add_epi8(low, high), zero);
      }
      // Narrowed to bytes: per 128-bit half [0 1 4 5 8 9 12 13] and [2 3 6 7 10 11 14 15] (as
      // pairs of codes), then the halves' pairs interleaved back into order.
      const __m256i words = _mm256_packus_epi32(_mm256_packus_epi32(counts[0], counts[1]),
                                                _mm256_packus_epi32(counts[2], counts[3]));
      const __m256i bytes = _mm256_packus_epi16(words, words);
      const __m128i ordered =
          _mm_unpacklo_epi16(_mm256_castsi256_si128(bytes), _mm256_extracti128_si256(bytes, 1));
      _mm_storeu_si128(reinterpret_cast<__m128i*>(s.c + k), ordered);
    }
    for (; k < s.k_hi; ++k) s.c[k] = static_cast<std::uint8_t>(__builtin_popcountll(s.r ^ s.t[k]));
  }
}

}  // namespace lunarnav::stereo::internal::hamming
