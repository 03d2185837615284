// What every command-line tool shares: the common flags, parsing with the project's exit
// codes, and the command line recorded in summaries.
#pragma once

#include <optional>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

namespace lunarnav::util {

/// Adds --version (project version and git revision) and -q/--quiet.
void AddCommonFlags(CLI::App* app, bool* quiet);

/// The flags of the tools that work through a directory of pairs: --resume (`resume_help`
/// says which pairs it skips), --shard K/N (the text, for ApplyShard) and -j,--threads.
void AddBatchFlags(CLI::App* app, const std::string& resume_help, bool* resume, std::string* shard,
                   int* threads);

/// Adds --max-pixels: the largest image (width x height) the tool reads; `*max_pixels` holds
/// the default (io::kDefaultMaxImagePixels) and receives the value.
void AddMaxPixelsFlag(CLI::App* app, long long* max_pixels);

/// Reads --shard's K/N, auto or auto/N (util::ParseShard, from the scheduler's environment)
/// into *index and *count, and logs where they came from; nothing when `shard` is empty.
/// @throws std::invalid_argument as ParseShard does.
void ApplyShard(const std::string& shard, int* index, int* count);

/// Parses the command line. Returns std::nullopt when the tool should go on (and lowers the
/// log level if --quiet was given), else the exit code after CLI11 printed its message:
/// 0 for --help and --version, 2 (usage) for anything wrong.
std::optional<int> ParseCommandLine(CLI::App* app, int argc, char** argv, const bool& quiet);

/// The command line as a JSON array of strings, for summary.json.
nlohmann::json CommandLineJson(int argc, char** argv);

}  // namespace lunarnav::util
