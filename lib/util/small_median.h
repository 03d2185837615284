// Medians of a few values, as the sliding-window filters need them many millions of times.
#pragma once

#include <algorithm>
#include <cstddef>

namespace lunarnav::util {

namespace internal {
template <typename T>
inline void Order(T& a, T& b) {
  const T lo = std::min(a, b), hi = std::max(a, b);
  a = lo;
  b = hi;
}
}  // namespace internal

/// Median of exactly six values (the mean of the two middle ones), branch-free so that a loop
/// calling it can be vectorised; reorders them.
template <typename T>
inline T MedianOf6(T* a) {
  using internal::Order;
  Order(a[0], a[5]); Order(a[1], a[3]); Order(a[2], a[4]); Order(a[1], a[2]);
  Order(a[3], a[4]); Order(a[0], a[3]); Order(a[2], a[5]); Order(a[0], a[1]);
  Order(a[2], a[3]); Order(a[4], a[5]); Order(a[1], a[2]); Order(a[3], a[4]);
  return T(0.5) * (a[2] + a[3]);
}

/// Median of values[0..count) (the mean of the two middle ones for an even count); reorders
/// them. Counts 6 and 7 use branch-free optimal sorting networks (12 and 16 comparators),
/// up to 32 insertion sort, beyond std::nth_element. count >= 1.
template <typename T>
T SmallMedian(T* a, std::size_t count) {
  using internal::Order;
  if (count == 7) {
    Order(a[0], a[6]); Order(a[2], a[3]); Order(a[4], a[5]); Order(a[0], a[2]);
    Order(a[1], a[4]); Order(a[3], a[6]); Order(a[0], a[1]); Order(a[2], a[5]);
    Order(a[3], a[4]); Order(a[1], a[2]); Order(a[4], a[6]); Order(a[2], a[3]);
    Order(a[4], a[5]); Order(a[1], a[2]); Order(a[3], a[4]); Order(a[5], a[6]);
    return a[3];
  }
  if (count == 6) return MedianOf6(a);
  if (count <= 32) {
    for (std::size_t i = 1; i < count; ++i) {
      const T x = a[i];
      std::size_t j = i;
      for (; j > 0 && a[j - 1] > x; --j) a[j] = a[j - 1];
      a[j] = x;
    }
  } else {
    std::sort(a, a + count);
  }
  const std::size_t mid = count / 2;
  return count % 2 == 1 ? a[mid] : T(0.5) * (a[mid - 1] + a[mid]);
}

}  // namespace lunarnav::util
