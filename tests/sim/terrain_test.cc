#include "sim/terrain.h"

#include <gtest/gtest.h>

#include <cmath>

#include "sim/random.h"

namespace lunarnav::sim {
namespace {

TerrainOptions SmallTerrain() {
  TerrainOptions o;
  o.min_x_m = -4;
  o.max_x_m = 4;
  o.min_y_m = -1;
  o.max_y_m = 9;
  o.cell_m = 0.04;
  o.relief_amplitude_m = 0.4;
  o.relief_wavelength_m = 4;
  o.rock_density_per_m2 = 1.0;
  o.seed = 17;
  return o;
}

// Brute force: march the ray in steps far below a cell and bisect the first sign change of
// z(t) - HeightAt(x(t), y(t)).
std::optional<double> MarchIntersect(const Terrain& terrain, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                                     double t_max, double step) {
  auto above = [&](double t) {
    const Eigen::Vector3d p = o + t * d;
    const double h = terrain.HeightAt(p.x(), p.y());
    return std::isnan(h) ? 1.0 : p.z() - h;
  };
  double prev = 0;
  for (double t = step; t <= t_max; t += step) {
    if (above(t) <= 0) {
      double lo = prev, hi = t;
      for (int k = 0; k < 60; ++k) {
        const double mid = 0.5 * (lo + hi);
        (above(mid) <= 0 ? hi : lo) = mid;
      }
      return hi;
    }
    prev = t;
  }
  return std::nullopt;
}

TEST(Terrain, RayCastAgreesWithBruteForceMarching) {
  const Terrain terrain(SmallTerrain());
  SplitMix64 rng(3);
  int hits = 0, misses = 0;
  for (int k = 0; k < 300; ++k) {
    // Rays from a camera-like height, looking down at shallow and steep angles.
    const Eigen::Vector3d o(rng.Uniform(-2, 2), rng.Uniform(-0.5, 1), 1.5);
    const double heading = rng.Uniform(-0.6, 0.6), down = rng.Uniform(0.02, 0.9);
    const Eigen::Vector3d d(std::sin(heading) * std::cos(down), std::cos(heading) * std::cos(down), -std::sin(down));
    const std::optional<double> fast = terrain.Intersect(o, d, 0.0, 30.0);
    const std::optional<double> slow = MarchIntersect(terrain, o, d, 30.0, 0.002);
    ASSERT_EQ(fast.has_value(), slow.has_value()) << "ray " << k;
    if (fast) {
      ++hits;
      // The march can step over a sliver thinner than its step; both see the same surface.
      EXPECT_NEAR(*fast, *slow, 0.003) << "ray " << k;
      const Eigen::Vector3d p = o + *fast * d;
      EXPECT_NEAR(p.z(), terrain.HeightAt(p.x(), p.y()), 1e-6);
    } else {
      ++misses;
    }
  }
  EXPECT_GT(hits, 200);
  EXPECT_GT(misses, 5);
}

TEST(Terrain, RocksStandOutAndAlbedoIsWorldAnchored) {
  TerrainOptions flat = SmallTerrain();
  flat.relief_amplitude_m = 0;
  flat.rock_density_per_m2 = 0;
  const Terrain bare(flat);
  EXPECT_EQ(bare.MaxHeight(), 0.0);
  EXPECT_EQ(bare.MinHeight(), 0.0);
  TerrainOptions rocky = flat;
  rocky.rock_density_per_m2 = 2.0;
  const Terrain with_rocks(rocky);
  EXPECT_GT(with_rocks.MaxHeight(), rocky.rock_min_height_m);
  EXPECT_LE(with_rocks.MaxHeight(), rocky.rock_max_height_m + 1e-6);
  // A different extent holding the same point gives the same height and albedo there.
  TerrainOptions shifted = rocky;
  shifted.min_x_m = -2;
  shifted.min_y_m = 0;
  const Terrain other(shifted);
  for (double x : {-1.0, 0.5, 1.72}) {
    for (double y : {0.4, 3.0, 7.2}) {
      EXPECT_NEAR(other.HeightAt(x, y), with_rocks.HeightAt(x, y), 1e-6);
      EXPECT_EQ(other.AlbedoAt(x, y, 0.01), with_rocks.AlbedoAt(x, y, 0.01));
    }
  }
  EXPECT_TRUE(std::isnan(with_rocks.HeightAt(50, 0)));
}

TEST(Terrain, InvalidOptionsAreUsageErrors) {
  TerrainOptions o = SmallTerrain();
  o.cell_m = 0;
  EXPECT_THROW(Terrain{o}, std::invalid_argument);
  o = SmallTerrain();
  o.max_x_m = o.min_x_m;
  EXPECT_THROW(Terrain{o}, std::invalid_argument);
}

}  // namespace
}  // namespace lunarnav::sim
