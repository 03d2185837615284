// JSON files written atomically and read with clear errors.
#pragma once

#include <filesystem>

#include <nlohmann/json.hpp>

namespace lunarnav::io {

/// Writes `value` pretty-printed (2-space indent) to `path` atomically.
void WriteJsonAtomic(const std::filesystem::path& path, const nlohmann::json& value);

/// Reads a JSON file. @throws InputError with the file and the parser's position on error.
nlohmann::json ReadJson(const std::filesystem::path& path);

}  // namespace lunarnav::io
