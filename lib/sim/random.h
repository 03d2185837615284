// Portable, counter-based random numbers and value noise for the simulators.
//
// Everything here is a pure function of its arguments (a seed and integer coordinates), so
// results do not depend on evaluation order or thread count, and nothing uses the standard
// library's distributions, whose output is implementation-defined.
#pragma once

#include <cstdint>

namespace lunarnav::sim {

/// SplitMix64 finaliser (Steele, Lea & Flood 2014): a bijective, well-mixed 64-bit hash.
std::uint64_t Mix64(std::uint64_t x);

/// A hash of up to four integer coordinates under a seed (Mix64 chained).
std::uint64_t HashCoords(std::uint64_t seed, std::int64_t a, std::int64_t b = 0, std::int64_t c = 0,
                         std::int64_t d = 0);

/// The top 53 bits of `bits` as a double uniform in [0, 1).
double UniformFromBits(std::uint64_t bits);

/// A standard normal deviate from 64 random bits (Box-Muller on two 32-bit halves; the
/// first half is mapped into (0, 1] so the logarithm is finite). |value| <= 6.7.
double GaussianFromBits(std::uint64_t bits);

/// A small sequential generator (SplitMix64) for drawing several numbers from one seed.
class SplitMix64 {
 public:
  explicit SplitMix64(std::uint64_t seed) : state_(seed) {}
  /// The next 64 random bits.
  std::uint64_t Next();
  /// Uniform in [0, 1).
  double Uniform() { return UniformFromBits(Next()); }
  /// Uniform in [lo, hi).
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  /// Standard normal.
  double Gaussian() { return GaussianFromBits(Next()); }

 private:
  std::uint64_t state_;
};

/// 2-D value noise: random lattice values in [-1, 1) at integer points, interpolated with
/// the quintic smoothstep (C2). The value at (x, y) depends only on (x, y, seed).
double ValueNoise2(double x, double y, std::uint64_t seed);

}  // namespace lunarnav::sim

namespace lunarnav::sim {

/// Band-limited fractal value noise with roughly unit standard deviation: `octaves` octaves
/// of ValueNoise2 with lattice spacings finest_m, 2 finest_m, ..., equal amplitudes. Octaves
/// finer than the sampling footprint fade out (weight clamp(spacing / footprint - 1, 0, 1)),
/// so a pixel that covers many texture cells sees their average, not aliasing. Octaves that
/// are dropped lower the variance, as averaging over a pixel does.
/// @param footprint_m  the size of the sampling footprint on the surface, metres (0 = none).
double FractalNoise2(double x_m, double y_m, std::uint64_t seed, double finest_m, int octaves,
                     double footprint_m);

}  // namespace lunarnav::sim
