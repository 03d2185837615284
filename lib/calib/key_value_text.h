// Calibration text files of the "key: numbers" kind (KITTI's calib files, Middlebury's
// calib.txt): one key and its value per line.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace lunarnav::calib {

/// A value and the line (1-based) it was read from.
struct TextEntry {
  std::string value;
  int line = 0;
};

/// Lines "key<separator>value" (keys trimmed; blank lines skipped; a UTF-8 BOM and CR dropped).
/// @throws InputError naming the file (and line) when it cannot be read or a line has no
///         separator.
std::map<std::string, TextEntry> ReadKeyValues(const std::filesystem::path& path, char separator);

/// The entry of `key`. @throws InputError "FILE: missing field 'KEY'".
const TextEntry& TextField(const std::map<std::string, TextEntry>& entries, const std::string& key,
                           const std::filesystem::path& path);

/// The `count` finite numbers of a value (separators [ ] ; , and blanks ignored).
/// @throws InputError naming the file, line and key otherwise.
std::vector<double> TextNumbers(const TextEntry& entry, const std::string& key, const std::filesystem::path& path,
                                int count);

}  // namespace lunarnav::calib
