// Which shard of a batch this process runs: --shard K/N given on the command line, or
// --shard auto (auto/N) taken from the scheduler that started the process (a Slurm job
// array, GNU parallel). Every batch tool (stereo-batch, rectify, terrain-map) reads it here.
#pragma once

#include <functional>
#include <optional>
#include <string>

namespace lunarnav::util {

/// Shard K of N, and where K and N came from.
struct ShardSpec {
  int index = 0;       ///< K, 0 <= K < N.
  int count = 1;       ///< N >= 1.
  std::string source;  ///< e.g. "--shard 2/4", "Slurm array job 57, task 2 (tasks 0-3)".
};

/// Looks up an environment variable: its value, or std::nullopt when unset.
using EnvironmentLookup = std::function<std::optional<std::string>(const std::string& name)>;

/// The process's own environment (std::getenv).
std::optional<std::string> GetEnvironmentVariable(const std::string& name);

/// Reads --shard's text:
/// - "K/N": shard K of N (0 <= K < N);
/// - "auto": from a Slurm job array, K = (SLURM_ARRAY_TASK_ID - SLURM_ARRAY_TASK_MIN) /
///   SLURM_ARRAY_TASK_STEP and N = SLURM_ARRAY_TASK_COUNT (so `--array=0-3` and `--array=1-4`
///   both give shards 0..3 of 4);
/// - "auto/N": N given, K the Slurm array task id itself (resubmitting `--array=2` alone runs
///   shard 2 of N), or GNU parallel's PARALLEL_SEQ - 1 (its job numbers start at 1).
/// Empty text is shard 0 of 1.
/// @throws std::invalid_argument naming the variable and the reason when the text is malformed,
///         when no scheduler variable is set, when both Slurm's and GNU parallel's are (ambiguous),
///         or when the variables give no valid shard (a task id outside 0..N-1, an array that is
///         not an evenly stepped range).
ShardSpec ParseShard(const std::string& text, const EnvironmentLookup& env = GetEnvironmentVariable);

}  // namespace lunarnav::util
