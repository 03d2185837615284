// A sequential random source whose draws are the same with every compiler and standard
// library, for simulators that must write bit-identical outputs for a seed.
//
// The standard's distributions (std::uniform_real_distribution, std::normal_distribution)
// are implementation-defined, so nothing here uses them: the bits come from SplitMix64
// (sim/random.h) and become numbers through UniformFromBits and GaussianFromBits, which use
// only integer and IEEE arithmetic (and std::log, std::cos of the C library for normals).
#pragma once

#include <cstdint>
#include <string_view>

#include "sim/random.h"

namespace lunarnav::sim {

/// A seed for the independent stream `name` of a run seeded with `seed`, so that adding or
/// removing one consumer of random numbers (faults, say) leaves the others' draws unchanged.
/// HashCoords of the seed and the name's FNV-1a hash.
std::uint64_t StreamSeed(std::uint64_t seed, std::string_view name);

/// A portable sequential random source: SplitMix64 plus explicit distributions.
class PortableRandom {
 public:
  explicit PortableRandom(std::uint64_t seed) : bits_(seed) {}
  PortableRandom(std::uint64_t seed, std::string_view stream) : bits_(StreamSeed(seed, stream)) {}

  /// The next raw 64 bits.
  std::uint64_t Bits() { return bits_.Next(); }
  /// Uniform in [0, 1): the top 53 bits of one draw, times 2^-53.
  double Uniform() { return UniformFromBits(Bits()); }
  /// Uniform in [lo, hi).
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  /// Uniform integer in [0, n) (n > 0), without modulo bias (rejection sampling).
  std::uint64_t UniformInt(std::uint64_t n);
  /// Standard normal from one draw (GaussianFromBits: Box-Muller, |value| <= 6.7).
  double Normal() { return GaussianFromBits(Bits()); }
  /// Normal with the given mean and standard deviation.
  double Normal(double mean, double sigma) { return mean + sigma * Normal(); }
  /// +1 or -1 with equal probability.
  double Sign() { return (Bits() >> 63) != 0 ? 1.0 : -1.0; }

 private:
  SplitMix64 bits_;
};

}  // namespace lunarnav::sim
