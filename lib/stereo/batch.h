// stereo-batch: the matcher over a directory of rectified pairs, with the behaviour a long
// field run needs (bad pairs reported and skipped, atomic outputs, resume, shards).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "io/stereo_pairs.h"
#include "stereo/frame_check.h"
#include "stereo/ncc_options.h"

namespace lunarnav::stereo {

using io::ListStereoPairs;
using io::PairFiles;

/// Everything stereo-batch does besides matching.
struct BatchOptions {
  NccOptions matcher;            ///< num_threads is ignored: the batch uses `num_threads`.
  FrameCheckOptions frame_check;
  bool resume = false;           ///< Skip pairs whose outputs are complete and were made
                                 ///< with the same options.
  int shard_index = 0;           ///< Process pairs i with i % shard_count == shard_index.
  int shard_count = 1;
  int num_threads = 0;           ///< 0 = all cores.
  bool show_progress = true;     ///< Progress bar on stderr (only when it is a terminal).
  void Validate() const;
  nlohmann::json ToJson() const;
};

/// What happened to one pair.
struct PairOutcome {
  enum class Status { kOk, kResumed, kFailed };
  std::string stem;
  Status status = Status::kFailed;
  std::string error;        ///< For kFailed: "<file>: <reason>".
  nlohmann::json result;    ///< For kOk and kResumed: counts and timings (the sidecar's).
};

/// Totals of a run.
struct BatchSummary {
  int pairs_listed = 0;     ///< In INPUT_DIR.
  int pairs_in_shard = 0;
  int pairs_ok = 0, pairs_resumed = 0, pairs_failed = 0;
  double seconds = 0, read_seconds = 0, match_seconds = 0, write_seconds = 0;
  long long pixels_evaluated = 0, pixels_accepted = 0;
  std::vector<PairOutcome> pairs;  ///< Name order.
  std::filesystem::path summary_path;
  /// e.g. "3 pairs: 3 ok, 0 failed; accepted 71.2% of evaluated pixels; 0.52 s".
  std::string BriefReport() const;
};

/// Output paths of one pair.
struct PairOutputPaths {
  std::filesystem::path disparity, confidence, rejections, sidecar;
};
PairOutputPaths OutputPathsFor(const std::filesystem::path& output_dir, const std::string& stem);

/// Name of the run summary: summary.json, or summary.shard-K-of-N.json for a shard.
std::string SummaryFileName(const BatchOptions& options);

/// Matches every pair of the shard, writes OUT_DIR/{disparity,confidence,rejections}/<stem>.*
/// and the run summary. A pair that cannot be read or is blank, saturated, mismatched or
/// unpaired is logged as one "error: pair <stem>: ..." line and counted as failed; the rest
/// go on. Every file is written atomically.
/// @param invocation  recorded in the summary (e.g. the command line).
/// @throws InputError when INPUT_DIR is unusable or holds no pairs; std::invalid_argument for
///         bad options; other exceptions for system failures (e.g. the disk is full).
BatchSummary RunStereoBatch(const BatchOptions& options, const std::filesystem::path& input_dir,
                            const std::filesystem::path& output_dir,
                            const nlohmann::json& invocation = nullptr);

}  // namespace lunarnav::stereo
