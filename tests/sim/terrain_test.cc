#include "sim/terrain.h"

#include <gtest/gtest.h>

#include <algorithm>
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

TEST(Terrain, AlbedoAndReliefAreTheDocumentedNoiseFunctions) {
  // The terrain evaluates its noise with the per-octave work hoisted out; the values must be
  // those of sim::FractalNoise2 and sim::ValueNoise2 as documented.
  TerrainOptions o = SmallTerrain();
  o.rock_density_per_m2 = 0;
  o.slope_x = 0.01;
  const Terrain terrain(o);
  constexpr std::uint64_t kAlbedoSalt = 0x414C4245, kReliefSalt = 0x52454C49;
  SplitMix64 rng(9);
  for (int k = 0; k < 200; ++k) {
    const double x = rng.Uniform(-3, 3), y = rng.Uniform(0, 8), footprint = k % 2 ? 0.0 : rng.Uniform(0, 0.2);
    const double n = FractalNoise2(x, y, o.seed ^ kAlbedoSalt, o.texture_finest_m, o.texture_octaves, footprint);
    const double albedo = std::clamp(o.albedo_mean + o.albedo_sigma * n, 0.02, 1.0);
    EXPECT_NEAR(terrain.AlbedoAt(x, y, footprint), albedo, 1e-9);
  }
  // At a grid vertex the surface is the relief: slope plus three octaves of ValueNoise2.
  for (int k = 0; k < 50; ++k) {
    const int i = static_cast<int>(rng.Uniform(0, terrain.GridWidth() - 1));
    const int j = static_cast<int>(rng.Uniform(0, terrain.GridHeight() - 1));
    const double x = o.min_x_m + i * o.cell_m, y = o.min_y_m + j * o.cell_m, l = o.relief_wavelength_m;
    const std::uint64_t s = o.seed ^ kReliefSalt;
    const double relief = o.slope_x * x + o.relief_amplitude_m *
                                              (ValueNoise2(x / l, y / l, s) + 0.5 * ValueNoise2(2 * x / l, 2 * y / l, s + 1) +
                                               0.25 * ValueNoise2(4 * x / l, 4 * y / l, s + 2)) /
                                              1.75;
    EXPECT_NEAR(terrain.HeightAt(x, y), relief, 1e-6);
  }
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
