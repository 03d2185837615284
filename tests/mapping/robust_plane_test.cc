#include "mapping/robust_plane.h"

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace lunarnav::mapping {
namespace {

constexpr double kNoPrior = std::numeric_limits<double>::infinity();

// A plane under 40 % of samples standing 0.2-1.5 m on it (a car, a walker): the fit is the
// plane, not a compromise, and the residuals name the samples that stand. (From a level start
// the robust fit alone settles 19 cm up, between the two.)
TEST(FitDominantPlane, FindsTheGroundUnderWhatStandsOnIt) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> across(-6.0, 6.0), ahead(-2.0, 2.0), up(0.2, 1.5);
  std::normal_distribution<double> noise(0.0, 0.01);
  const double c = 0.05, sx = 0.03, sy = -0.02;  // height, slope along x, slope along y
  std::vector<PlaneSample> samples;
  std::vector<bool> standing;
  for (int k = 0; k < 2000; ++k) {
    const double dx = across(rng), dy = ahead(rng);
    const bool stands = k % 5 < 2;
    samples.push_back({dx, dy, c + sx * dx + sy * dy + noise(rng) + (stands ? up(rng) : 0.0)});
    standing.push_back(stands);
  }
  std::vector<double> residuals;
  const auto p = FitDominantPlane(samples, 0.05, 0.5, 0.03, &residuals);
  ASSERT_TRUE(p.has_value());
  EXPECT_NEAR((*p)[0], c, 0.003);
  EXPECT_NEAR((*p)[1], sx, 0.001);
  EXPECT_NEAR((*p)[2], sy, 0.002);
  ASSERT_EQ(residuals.size(), samples.size());
  for (std::size_t k = 0; k < samples.size(); ++k) {
    if (standing[k]) EXPECT_GT(residuals[k], 0.15);
    else EXPECT_LT(residuals[k], 0.05);
  }
  // From a level start the robust fit alone does not find it.
  const auto level = FitRobustPlane(samples, 0.03, kNoPrior);
  ASSERT_TRUE(level.has_value());
  EXPECT_GT((*level)[0] - c, 0.1);
  // Far more standing than lying (a view filled by a car's flank: 80 % at one height 0.8 m up):
  // the largest flat part is the flank; the caller judges it (terrain-map: against the
  // vehicle's own ground).
  std::vector<PlaneSample> flank;
  for (int k = 0; k < 1000; ++k) {
    const double dx = across(rng), dy = ahead(rng);
    flank.push_back({dx, dy, k % 5 == 0 ? noise(rng) : 0.8 + noise(rng)});
  }
  const auto f = FitDominantPlane(flank, 0.05, 0.5, 0.03);
  ASSERT_TRUE(f.has_value());
  EXPECT_NEAR((*f)[0], 0.8, 0.01);
  // Too few samples, or only steep planes (a wall: z rising 2 m per m): none.
  EXPECT_FALSE(FitDominantPlane({{0, 0, 0}, {1, 0, 0}}, 0.05, 0.5, 0.03).has_value());
  std::vector<PlaneSample> wall;
  for (int k = 0; k < 100; ++k) wall.push_back({0.01 * k, 0.013 * (k % 7), 2.0 * 0.01 * k});
  EXPECT_FALSE(FitDominantPlane(wall, 0.05, 0.5, 0.03).has_value());
}

// Samples along one line (a band of one distance) fix the plane's height but not its slope
// across the line: without a prior the equations are singular; the prior takes the least slope.
TEST(FitRobustPlane, APriorOnTheSlopesFixesWhatTheSamplesDoNot) {
  std::vector<PlaneSample> samples;
  for (int k = 0; k < 50; ++k) samples.push_back({-3.0 + 0.12 * k, 0.0, 0.1 + 0.01 * (-3.0 + 0.12 * k)});
  EXPECT_FALSE(FitRobustPlane(samples, 0.03, kNoPrior).has_value());
  const auto p = FitRobustPlane(samples, 0.03, 0.035);
  ASSERT_TRUE(p.has_value());
  EXPECT_NEAR((*p)[0], 0.1, 1e-3);
  EXPECT_NEAR((*p)[1], 0.01, 1e-3);
  EXPECT_NEAR((*p)[2], 0.0, 1e-12);
}

TEST(MedianInPlace, IsTheMiddleValueAndZeroWhenEmpty) {
  std::vector<double> v = {5, 1, 4, 2, 3};
  EXPECT_EQ(MedianInPlace(v), 3);
  std::vector<double> none;
  EXPECT_EQ(MedianInPlace(none), 0);
}

}  // namespace
}  // namespace lunarnav::mapping
