// rectify: raw image-pair sequences -> rectified pairs and the rectified rig file, with the
// behaviour a long field run needs (bad pairs reported and skipped, atomic outputs, resume,
// shards), as stereo-batch has.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calib/stereo_rig.h"

namespace lunarnav::calib {

struct RectifyBatchOptions {
  /// Rectify the rig anew with this alpha (0: only pixels valid in both views, 1: every raw
  /// pixel kept). Unset: use the rig's rectified geometry when it has one, else alpha 0.
  std::optional<double> alpha;
  std::string image_format = "png";  ///< Output files: "png" or "tif" (lossless, any depth).
  bool resume = false;               ///< Skip pairs whose two outputs exist (same rig).
  int shard_index = 0;               ///< Process pairs i with i % shard_count == shard_index.
  int shard_count = 1;
  int num_threads = 0;               ///< 0 = all cores.
  bool show_progress = true;         ///< Progress bar on stderr (only when it is a terminal).
  void Validate() const;
  nlohmann::json ToJson() const;
};

/// What happened to one pair.
struct RectifyPairOutcome {
  enum class Status { kOk, kResumed, kFailed };
  std::string stem;
  Status status = Status::kFailed;
  std::string error;  ///< For kFailed: "<file>: <reason>".
  double read_s = 0, rectify_s = 0, write_s = 0;
  int bits = 0;              ///< For kOk: the grey levels' significant bits written (sBIT below 16).
  std::string bits_source;   ///< Where they came from (io::SignificantBits::source).
};

struct RectifyBatchSummary {
  int pairs_listed = 0, pairs_in_shard = 0;
  int pairs_ok = 0, pairs_resumed = 0, pairs_failed = 0;
  double seconds = 0, maps_seconds = 0;
  StereoRig rectified_rig;
  std::vector<RectifyPairOutcome> pairs;  ///< Name order.
  std::filesystem::path rig_path, summary_path;
  /// e.g. "3 pairs: 3 ok, 0 failed; 0.21 s".
  std::string BriefReport() const;
};

/// The rig a run uses: `rig` itself when it is rectified and no alpha is asked for,
/// otherwise RectifyRig(rig, alpha or 0).
StereoRig RigForRectification(const StereoRig& rig, const RectifyBatchOptions& options);

/// Rectifies every pair of the shard of INPUT_DIR/{left,right} with remap tables computed
/// once, writing OUT_DIR/left/<stem>.<fmt>, OUT_DIR/right/<stem>.<fmt> (same channels and bit
/// depth as the input), OUT_DIR/rig.json (the rectified rig: stereo-batch --rig reads it) and
/// the run summary. A pair that cannot be read, has the wrong size or no partner is logged as
/// one "error: pair <stem>: ..." line and counted as failed; the rest go on. Every file is
/// written atomically, the right image last, so that a pair with both files is complete.
/// @param rig_source  the rig file's name, for messages and the summary.
/// @throws InputError when INPUT_DIR is unusable or holds no pairs; std::invalid_argument for
///         bad options or, with --resume, when OUT_DIR/rig.json holds another rig.
RectifyBatchSummary RunRectifyBatch(const RectifyBatchOptions& options, const StereoRig& rig,
                                    const std::string& rig_source,
                                    const std::filesystem::path& input_dir,
                                    const std::filesystem::path& output_dir,
                                    const nlohmann::json& invocation = nullptr);

}  // namespace lunarnav::calib
