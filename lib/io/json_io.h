// JSON files written atomically and read with clear errors.
#pragma once

#include <cstdint>
#include <filesystem>

#include <nlohmann/json.hpp>

namespace lunarnav::io {

/// Writes `value` pretty-printed (2-space indent) to `path` atomically.
void WriteJsonAtomic(const std::filesystem::path& path, const nlohmann::json& value);

/// Reads a JSON file. @throws InputError with the file and the parser's position on error.
nlohmann::json ReadJson(const std::filesystem::path& path);

/// ReadJson for files whose size a hostile or broken writer chooses (shard summaries): refused
/// from its size before reading when larger than `max_bytes`, and while parsing once it holds
/// more than `max_values` values (each value costs ten times its text or more in memory: a
/// 108 MB file of small values took 3.5 GB to refuse). @throws InputError naming the limit.
nlohmann::json ReadJsonBounded(const std::filesystem::path& path, std::uintmax_t max_bytes, long max_values);

}  // namespace lunarnav::io
