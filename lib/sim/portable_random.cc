#include "sim/portable_random.h"

#include "util/check.h"

namespace lunarnav::sim {

std::uint64_t StreamSeed(std::uint64_t seed, std::string_view name) {
  std::uint64_t h = 0xCBF29CE484222325ull;  // FNV-1a of the name
  for (char c : name) {
    h ^= static_cast<unsigned char>(c);
    h *= 0x100000001B3ull;
  }
  return HashCoords(seed, static_cast<std::int64_t>(h));
}

std::uint64_t PortableRandom::UniformInt(std::uint64_t n) {
  LN_CHECK(n > 0);
  // Reject the top partial block of 2^64 so every residue is equally likely.
  const std::uint64_t limit = (~std::uint64_t{0}) - (~std::uint64_t{0}) % n;
  for (;;) {
    const std::uint64_t x = Bits();
    if (x < limit) return x % n;
  }
}

}  // namespace lunarnav::sim
