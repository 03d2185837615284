#include "util/small_median.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>
#include <vector>

namespace lunarnav::util {
namespace {

// Every permutation of 1..n (n <= 8), and random draws with ties for larger n, against a sort.
TEST(SmallMedian, EqualsTheMedianOfTheSortedValues) {
  for (std::size_t n = 1; n <= 8; ++n) {
    std::vector<double> p(n);
    std::iota(p.begin(), p.end(), 0.0);
    const double expected = n % 2 == 1 ? p[n / 2] : 0.5 * (p[n / 2 - 1] + p[n / 2]);
    do {
      std::vector<double> a = p;
      ASSERT_EQ(SmallMedian(a.data(), n), expected) << "n " << n;
    } while (std::next_permutation(p.begin(), p.end()));
  }
  std::mt19937 rng(5);
  for (std::size_t n : {9u, 31u, 32u, 33u, 100u}) {
    for (int trial = 0; trial < 50; ++trial) {
      std::vector<float> a(n);
      for (float& v : a) v = static_cast<float>(rng() % 10);  // many ties
      std::vector<float> sorted = a;
      std::sort(sorted.begin(), sorted.end());
      const float expected = n % 2 == 1 ? sorted[n / 2] : 0.5f * (sorted[n / 2 - 1] + sorted[n / 2]);
      ASSERT_EQ(SmallMedian(a.data(), n), expected) << "n " << n;
    }
  }
}

}  // namespace
}  // namespace lunarnav::util
