#include "sim/ground_surface.h"

#include <gtest/gtest.h>

#include <cmath>

namespace lunarnav::sim {
namespace {

constexpr double kDeg = M_PI / 180.0;

TEST(GroundSurface, FlatByDefaultAndAPlaneWithOnlyASlope) {
  const GroundSurface flat({}, 1);
  EXPECT_EQ(flat.HeightAt(12.3, -4.5), 0.0);
  GroundSurfaceOptions o;
  o.slope_deg = 10;
  o.slope_azimuth_deg = 90;  // rising to the east
  const GroundSurface plane(o, 1);
  EXPECT_NEAR(plane.HeightAt(1.0, 0.0), std::tan(10 * kDeg), 1e-12);
  EXPECT_NEAR(plane.HeightAt(0.0, 5.0), 0.0, 1e-12);
  EXPECT_NEAR(plane.HeightAt(-2.0, 3.0), -2.0 * std::tan(10 * kDeg), 1e-12);
}

TEST(GroundSurface, UndulationsHaveTheConfiguredRmsAndComeFromTheSeed) {
  GroundSurfaceOptions o;
  o.undulation_m = 0.5;
  o.undulation_wavelength_m = 20;
  const GroundSurface a(o, 7), b(o, 7), c(o, 8);
  double sum2 = 0;
  int n = 0, differ = 0;
  for (double x = -500; x <= 500; x += 3.7) {
    for (double y = -500; y <= 500; y += 3.7) {
      const double h = a.HeightAt(x, y);
      sum2 += h * h;
      ++n;
      EXPECT_EQ(h, b.HeightAt(x, y));
      differ += h != c.HeightAt(x, y);
    }
  }
  // A sum of 8 sinusoids of random direction: its RMS over a large area is the configured one.
  EXPECT_NEAR(std::sqrt(sum2 / n), 0.5, 0.05);
  EXPECT_GT(differ, n / 2);
}

TEST(GroundSurface, RejectsImpossibleShapes) {
  GroundSurfaceOptions o;
  o.slope_deg = 50;
  EXPECT_THROW(GroundSurface(o, 1), std::invalid_argument);
  o = {};
  o.roughness_m = -1;
  EXPECT_THROW(GroundSurface(o, 1), std::invalid_argument);
  o = {};
  o.undulation_wavelength_m = 0;
  EXPECT_THROW(GroundSurface(o, 1), std::invalid_argument);
}

}  // namespace
}  // namespace lunarnav::sim
