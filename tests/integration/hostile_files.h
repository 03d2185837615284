// Test helpers: hostile files, forged to claim what their data cannot hold.
#pragma once

#include <zlib.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "integration/run_tool.h"

namespace lunarnav::testing {

/// Rewrites a PNG's IHDR to claim width x height (the chunk's CRC recomputed, so only the
/// size is wrong), keeping the rest of the file.
inline void ForgePngSize(const std::filesystem::path& path, std::uint32_t width, std::uint32_t height) {
  std::string bytes = ReadFileBytes(path);
  auto put = [&](std::size_t at, std::uint32_t v) {
    for (int k = 0; k < 4; ++k) bytes[at + k] = static_cast<char>((v >> (24 - 8 * k)) & 0xFF);
  };
  // Signature (8), IHDR length (4), "IHDR" (4), width, height, 5 more bytes, then the CRC of
  // "IHDR" and its 13 data bytes.
  put(16, width);
  put(20, height);
  const uLong crc = crc32(crc32(0L, Z_NULL, 0), reinterpret_cast<const Bytef*>(bytes.data() + 12), 17);
  put(29, static_cast<std::uint32_t>(crc));
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

/// A little TIFF (a few dozen bytes) whose one directory claims a width x height 8-bit grey
/// image in one strip of a few bytes.
inline void WriteForgedTiff(const std::filesystem::path& path, std::uint32_t width, std::uint32_t height) {
  std::string b = {'I', 'I', 42, 0, 8, 0, 0, 0};  // little-endian, directory at 8
  auto u16 = [&](std::uint16_t v) { b.push_back(static_cast<char>(v & 0xFF)); b.push_back(static_cast<char>(v >> 8)); };
  auto u32 = [&](std::uint32_t v) { for (int k = 0; k < 4; ++k) b.push_back(static_cast<char>((v >> (8 * k)) & 0xFF)); };
  auto entry = [&](std::uint16_t tag, std::uint16_t type, std::uint32_t value) {
    u16(tag);
    u16(type);
    u32(1);
    if (type == 3) { u16(static_cast<std::uint16_t>(value)); u16(0); } else { u32(value); }
  };
  const std::uint16_t entries = 8;
  const std::uint32_t data_at = 8 + 2 + 12 * entries + 4;
  u16(entries);
  entry(256, 4, width);     // ImageWidth, LONG
  entry(257, 4, height);    // ImageLength
  entry(258, 3, 8);         // BitsPerSample
  entry(259, 3, 1);         // Compression: none
  entry(262, 3, 1);         // Photometric: black is zero
  entry(273, 4, data_at);   // StripOffsets
  entry(278, 4, height);    // RowsPerStrip: one strip
  entry(279, 4, 4);         // StripByteCounts: 4 bytes where width x height are due
  u32(0);                   // no next directory
  b += std::string(4, '\x7f');
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(b.data(), static_cast<std::streamsize>(b.size()));
}

}  // namespace lunarnav::testing
