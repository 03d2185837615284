// Test helper: two output directories of a batch tool compared file by file, timings aside:
// what a sharded run (merged with shard-merge) must share with a one-machine run.
#pragma once

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace lunarnav::testing {

/// `j` without the keys that describe a run rather than its results (at any depth): timings
/// (and any key ending in `_ms` or `_s`, such as a pair's `match_ms`), memory, command line,
/// thread count, output directory, and the merge's own record.
inline nlohmann::json WithoutRunKeys(nlohmann::json j) {
  static const std::set<std::string> kRunKeys = {"peak_memory_mib", "invocation", "threads", "output_dir", "merge"};
  auto ends_with = [](const std::string& s, const std::string& suffix) {
    return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
  };
  if (j.is_object()) {
    for (auto it = j.begin(); it != j.end();) {
      if (kRunKeys.count(it.key()) > 0 || it.key().rfind("timings_", 0) == 0 || ends_with(it.key(), "_ms") ||
          ends_with(it.key(), "_s")) {
        it = j.erase(it);
      } else {
        it.value() = WithoutRunKeys(it.value());
        ++it;
      }
    }
  } else if (j.is_array()) {
    for (auto& v : j) v = WithoutRunKeys(v);
  }
  return j;
}

/// The regular files under `dir` by relative path, sorted, the shard summaries aside.
inline std::vector<std::string> OutputFiles(const std::filesystem::path& dir) {
  static const std::regex kShardSummary(R"(summary\.shard-\d+-of-\d+\.json)");
  std::vector<std::string> files;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(dir)) {
    if (entry.is_regular_file() && !std::regex_match(entry.path().filename().string(), kShardSummary)) {
      files.push_back(std::filesystem::relative(entry.path(), dir).generic_string());
    }
  }
  std::sort(files.begin(), files.end());
  return files;
}

/// The differences between two output directories (empty when they agree): files present in
/// one only, files whose bytes differ, JSON files that differ outside WithoutRunKeys.
inline std::vector<std::string> CompareOutputDirs(const std::filesystem::path& a, const std::filesystem::path& b) {
  std::vector<std::string> differences;
  const std::vector<std::string> files_a = OutputFiles(a), files_b = OutputFiles(b);
  std::vector<std::string> only;
  std::set_symmetric_difference(files_a.begin(), files_a.end(), files_b.begin(), files_b.end(),
                                std::back_inserter(only));
  for (const std::string& f : only) differences.push_back(f + ": in one directory only");
  auto bytes = [](const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  };
  for (const std::string& f : files_a) {
    if (!std::binary_search(files_b.begin(), files_b.end(), f)) continue;
    const std::string bytes_a = bytes(a / f), bytes_b = bytes(b / f);
    if (std::filesystem::path(f).extension() == ".json") {
      const nlohmann::json ja = WithoutRunKeys(nlohmann::json::parse(bytes_a, nullptr, false));
      const nlohmann::json jb = WithoutRunKeys(nlohmann::json::parse(bytes_b, nullptr, false));
      if (ja.is_discarded() || jb.is_discarded()) {
        differences.push_back(f + ": not JSON");
      } else if (ja != jb) {
        const nlohmann::json patch = nlohmann::json::diff(ja, jb);
        differences.push_back(f + ": differs: " + patch[0].dump().substr(0, 300));
      }
    } else if (bytes_a != bytes_b) {
      differences.push_back(f + ": bytes differ");
    }
  }
  return differences;
}

}  // namespace lunarnav::testing
