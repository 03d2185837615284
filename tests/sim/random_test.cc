#include "sim/random.h"

#include <gtest/gtest.h>

#include <cmath>
#include <set>

namespace lunarnav::sim {
namespace {

TEST(Random, PureFunctionsOfTheirArguments) {
  EXPECT_EQ(HashCoords(7, 1, 2, 3, 4), HashCoords(7, 1, 2, 3, 4));
  EXPECT_NE(HashCoords(7, 1, 2, 3, 4), HashCoords(8, 1, 2, 3, 4));
  EXPECT_NE(HashCoords(7, 1, 2, 3, 4), HashCoords(7, 2, 1, 3, 4));
  EXPECT_EQ(ValueNoise2(1.25, -3.5, 9), ValueNoise2(1.25, -3.5, 9));
  SplitMix64 a(5), b(5);
  for (int i = 0; i < 10; ++i) EXPECT_EQ(a.Next(), b.Next());
}

TEST(Random, UniformAndGaussianHaveTheRightMoments) {
  SplitMix64 rng(123);
  const int n = 200000;
  double su = 0, sg = 0, sg2 = 0, max_abs = 0;
  for (int i = 0; i < n; ++i) {
    const double u = rng.Uniform();
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
    su += u;
    const double g = rng.Gaussian();
    sg += g;
    sg2 += g * g;
    max_abs = std::max(max_abs, std::abs(g));
  }
  EXPECT_NEAR(su / n, 0.5, 0.005);
  EXPECT_NEAR(sg / n, 0.0, 0.01);
  EXPECT_NEAR(sg2 / n, 1.0, 0.02);
  EXPECT_LE(max_abs, 6.7);
  EXPECT_GT(max_abs, 3.5);
}

TEST(ValueNoise2, MatchesLatticeValuesAndIsContinuous) {
  // Interpolation: at lattice points the value is the lattice value, in [-1, 1); between
  // them the function changes by little over a small step.
  std::set<double> values;
  for (int i = 0; i < 50; ++i) {
    const double v = ValueNoise2(i, 2 * i, 3);
    EXPECT_GE(v, -1.0);
    EXPECT_LT(v, 1.0);
    values.insert(v);
    EXPECT_NEAR(ValueNoise2(i + 1e-7, 2 * i, 3), v, 1e-5);
  }
  EXPECT_GT(values.size(), 45u);
}

TEST(FractalNoise2, HasUnitVarianceWithAllOctaves) {
  double s = 0, s2 = 0;
  const int n = 400;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const double v = FractalNoise2(i * 0.137, j * 0.171, 11, 0.05, 4, 0.0);
      s += v;
      s2 += v * v;
    }
  }
  const double mean = s / (n * n);
  const double sd = std::sqrt(s2 / (n * n) - mean * mean);
  EXPECT_NEAR(mean, 0.0, 0.1);
  EXPECT_NEAR(sd, 1.0, 0.15);
}

TEST(FractalNoise2, LargeFootprintDropsFineOctaves) {
  // With a footprint of 1 m the 5 cm and 10 cm octaves are gone: the field varies less
  // over a 2 cm step than the unfiltered one.
  double d_full = 0, d_filtered = 0;
  for (int i = 0; i < 500; ++i) {
    const double x = i * 0.3;
    d_full += std::abs(FractalNoise2(x + 0.02, 1, 4, 0.05, 5, 0) - FractalNoise2(x, 1, 4, 0.05, 5, 0));
    d_filtered += std::abs(FractalNoise2(x + 0.02, 1, 4, 0.05, 5, 1.0) - FractalNoise2(x, 1, 4, 0.05, 5, 1.0));
  }
  EXPECT_LT(d_filtered, 0.5 * d_full);
}

}  // namespace
}  // namespace lunarnav::sim
