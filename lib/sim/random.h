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

/// The 32-bit seed ValueNoise2 mixes from `seed`, for callers that evaluate one seed many
/// times (the terrain's octaves): mix once, then call ValueNoise2Mixed.
inline std::uint32_t NoiseSeed(std::uint64_t seed) { return static_cast<std::uint32_t>(Mix64(seed)); }

/// ValueNoise2 with its seed already mixed: ValueNoise2Mixed(x, y, NoiseSeed(s)) equals
/// ValueNoise2(x, y, s). Inline: it is the inner loop of texture and relief. |x|, |y| < 2^62.
inline double ValueNoise2Mixed(double x, double y, std::uint32_t mixed_seed) {
  // Lattice value in [-1, 1): a cheap 32-bit mix of the coordinates (lowbias32, C. Wellons).
  const auto lattice = [mixed_seed](std::int64_t ix, std::int64_t iy) {
    std::uint32_t h = mixed_seed ^ static_cast<std::uint32_t>(ix) * 0x85EBCA6Bu ^
                      static_cast<std::uint32_t>(iy) * 0xC2B2AE35u;
    h ^= h >> 16;
    h *= 0x7FEB352Du;
    h ^= h >> 15;
    h *= 0x846CA68Bu;
    h ^= h >> 16;
    return static_cast<double>(h) * (2.0 / 4294967296.0) - 1.0;
  };
  // floor without a library call.
  const auto floor = [](double v) {
    const auto t = static_cast<double>(static_cast<std::int64_t>(v));
    return t > v ? t - 1.0 : t;
  };
  const double fx = floor(x), fy = floor(y);
  const auto ix = static_cast<std::int64_t>(fx), iy = static_cast<std::int64_t>(fy);
  const double tx = x - fx, ty = y - fy;
  const double sx = tx * tx * tx * (tx * (tx * 6 - 15) + 10);
  const double sy = ty * ty * ty * (ty * (ty * 6 - 15) + 10);
  const double v00 = lattice(ix, iy), v10 = lattice(ix + 1, iy);
  const double v01 = lattice(ix, iy + 1), v11 = lattice(ix + 1, iy + 1);
  const double top = v00 + sx * (v10 - v00);
  const double bottom = v01 + sx * (v11 - v01);
  return top + sy * (bottom - top);
}

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
