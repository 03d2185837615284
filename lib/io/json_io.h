// JSON files written atomically and read with clear errors.
#pragma once

#include <cstdint>
#include <filesystem>

#include <nlohmann/json.hpp>

namespace lunarnav::io {

/// Writes `value` pretty-printed (2-space indent) to `path` atomically.
void WriteJsonAtomic(const std::filesystem::path& path, const nlohmann::json& value);

/// The largest JSON file a tool reads (rigs, sensor and vehicle files, sidecars, summaries,
/// trials, shard summaries): 256 MiB of text and 4 million values, far above any the tools
/// write (a stereo-batch summary holds about 60 values a pair: some 60,000 pairs in one
/// summary), far below what costs gigabytes to hold (docs/reliability.md).
inline constexpr std::uintmax_t kMaxJsonBytes = std::uintmax_t{256} << 20;
inline constexpr long kMaxJsonValues = 4'000'000;

/// Reads a JSON file of at most kMaxJsonBytes and kMaxJsonValues (ReadJsonBounded).
/// @throws InputError with the file and the parser's position on error, or naming the limit.
nlohmann::json ReadJson(const std::filesystem::path& path);

/// A JSON file refused from its size before reading when larger than `max_bytes`, and while
/// parsing once it holds more than `max_values` values (each value costs ten times its text or
/// more in memory: a 108 MB file of small values took 3.5 GB to refuse).
/// @throws InputError naming the limit.
nlohmann::json ReadJsonBounded(const std::filesystem::path& path, std::uintmax_t max_bytes, long max_values);

}  // namespace lunarnav::io
