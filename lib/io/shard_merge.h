// The shards of one batch (summary.shard-K-of-N.json files that `--shard` runs wrote into one
// output directory) merged into the summary.json a single run would have written, with the
// checks a cluster run needs: the shards ran the same tool, version, options and input
// listing, and every item of the listing was done exactly once. Used by shard-merge for every
// batch tool (stereo-batch, rectify, terrain-map); docs/cluster.md.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace lunarnav::io {

/// The `listing` record a batch tool puts in its summary: what it listed (`kind`, e.g.
/// "stereo-pairs"), the summary's array of items (`entries`, e.g. "pairs", whose counts are
/// `<entries>_listed`, `_in_shard`, `_ok`, `_resumed`, `_failed`), the number of items and
/// ListingDigest of their names in listing order. Two runs over the same input agree on it.
nlohmann::json ListingRecord(const std::string& kind, const std::string& entries,
                             const std::vector<std::string>& names);

/// "fnv1a64:<16 hex digits>": FNV-1a (64 bit) over the names, each followed by '\n'.
std::string ListingDigest(const std::vector<std::string>& names);

/// The names of the items of a listing `kind` in `input_dir`, in listing order, or
/// std::nullopt when that kind is unknown or the directory cannot be listed. Knows
/// "stereo-pairs" (io::ListStereoPairs); used to name the items of missing shards.
std::optional<std::vector<std::string>> RelistItems(const std::string& kind,
                                                    const std::filesystem::path& input_dir);

struct ShardMergeOptions {
  /// Where the inputs are, to name the items of missing shards; empty = the `input_dir` the
  /// shards recorded (relative to the working directory when it is relative).
  std::filesystem::path input_dir;
  int num_threads = 0;  ///< Threads reading the shard summaries; 0 = all cores.
  /// Lists a kind's items (RelistItems; replaceable for tests).
  std::function<std::optional<std::vector<std::string>>(const std::string&, const std::filesystem::path&)> relist =
      RelistItems;
  void Validate() const;
};

/// An item that no shard did (its shard is missing), or that every shard listing it failed.
struct UndoneItem {
  long index = 0;            ///< Position in the listing.
  std::string name;          ///< Empty when neither a shard nor the re-listed input names it.
  std::string shard;         ///< "K/N" of the shard that should have done it.
  std::string reason;        ///< "shard missing" or the failure.
};

struct ShardMergeResult {
  std::string tool;                        ///< The batch tool the shards ran.
  int shard_files = 0;                     ///< summary.shard-*-of-*.json files merged.
  long items_listed = 0, items_done = 0;   ///< Done = ok or resumed.
  long items_failed = 0, items_never = 0;  ///< Failed in every shard listing them / in no shard.
  std::vector<std::string> missing_shards; ///< "K/N" of each shard without a summary.
  std::vector<UndoneItem> undone;          ///< Listing order.
  std::vector<std::string> done_twice;     ///< Items listed by several shard files.
  std::string entries = "pairs";           ///< What the items are called.
  std::filesystem::path summary_path;
  /// Every item of the listing done once or more, none failed.
  bool Complete() const { return items_done == items_listed; }
  /// e.g. "4 shards of stereo-batch: 40 of 40 pairs done, 0 failed, 0 never done".
  std::string BriefReport() const;
};

/// Reads every summary.shard-K-of-N.json of `output_dir`, checks that they belong to one batch
/// and writes `output_dir`/summary.json (atomically): the single run's keys, with counts made
/// from the merged items, timings summed over the shards, the largest peak memory, items and
/// failures in listing order, and `merge` (each shard's run, completeness, missing shards,
/// items done twice or never). Written also when the set is incomplete (merge.complete false).
/// Several shardings of one batch (e.g. 4 shards, then 8 with --resume) may be merged: an item
/// done twice is counted once (a success preferred to a failure). Logs one error line per
/// missing shard and per item not done.
/// @param invocation  the merge's command line, recorded in `merge`.
/// @throws InputError naming the files and the difference when there is no shard summary, a
///         summary is unreadable or not a batch tool's, or the shards are not one batch:
///         another tool, version, input directory, input listing or option set (any key of
///         the summary that is not a run's own: invocation, threads, kernel, counts, timings,
///         memory, items).
ShardMergeResult MergeShardSummaries(const std::filesystem::path& output_dir, const ShardMergeOptions& options,
                                     const nlohmann::json& invocation = nullptr);

}  // namespace lunarnav::io
