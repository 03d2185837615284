#include "sim/random.h"

#include <algorithm>
#include <cmath>

namespace lunarnav::sim {

std::uint64_t Mix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

std::uint64_t HashCoords(std::uint64_t seed, std::int64_t a, std::int64_t b, std::int64_t c, std::int64_t d) {
  std::uint64_t h = Mix64(seed);
  h = Mix64(h ^ static_cast<std::uint64_t>(a));
  h = Mix64(h ^ static_cast<std::uint64_t>(b));
  h = Mix64(h ^ static_cast<std::uint64_t>(c));
  return Mix64(h ^ static_cast<std::uint64_t>(d));
}

double UniformFromBits(std::uint64_t bits) { return static_cast<double>(bits >> 11) * 0x1.0p-53; }

double GaussianFromBits(std::uint64_t bits) {
  // u1 in (0, 1], u2 in [0, 1), each from 32 bits.
  const double u1 = (static_cast<double>(bits >> 32) + 1.0) * 0x1.0p-32;
  const double u2 = static_cast<double>(bits & 0xFFFFFFFFull) * 0x1.0p-32;
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

std::uint64_t SplitMix64::Next() {
  state_ += 0x9E3779B97F4A7C15ull;
  std::uint64_t z = state_;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

double ValueNoise2(double x, double y, std::uint64_t seed) { return ValueNoise2Mixed(x, y, NoiseSeed(seed)); }

}  // namespace lunarnav::sim

namespace lunarnav::sim {

double FractalNoise2(double x_m, double y_m, std::uint64_t seed, double finest_m, int octaves,
                     double footprint_m) {
  // The standard deviation of ValueNoise2 over the plane is 0.45 (measured; checked in
  // random_test: FractalNoise2.HasUnitVarianceWithAllOctaves).
  constexpr double kValueNoiseSigma = 0.45;
  double sum = 0;
  double spacing = finest_m;
  for (int k = 0; k < octaves; ++k, spacing *= 2) {
    const double w = footprint_m > 0 ? std::clamp(spacing / footprint_m - 1.0, 0.0, 1.0) : 1.0;
    if (w > 0) sum += w * ValueNoise2(x_m / spacing, y_m / spacing, seed + static_cast<std::uint64_t>(k));
  }
  return sum / (kValueNoiseSigma * std::sqrt(static_cast<double>(octaves)));
}

}  // namespace lunarnav::sim
