// stereo-batch: the matcher over a directory of rectified pairs, with the behaviour a long
// field run needs (bad pairs reported and skipped, atomic outputs, resume, shards).
#pragma once

#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calib/stereo_rig.h"
#include "calib/triangulation.h"
#include "calib/window_selection.h"
#include "io/stereo_pairs.h"
#include "stereo/frame_check.h"
#include "stereo/ncc_options.h"
#include "stereo/vertical_alignment.h"
#include "stereo/window_requests.h"

namespace lunarnav::stereo {

using io::ListStereoPairs;
using io::PairFiles;

/// The vehicle's attitude when a pair was taken, degrees (pitch nose up, roll right side
/// down, as poses give them).
struct VehicleAttitude {
  double pitch_deg = 0, roll_deg = 0;
};

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
  bool write_preview = false;    ///< Also OUT_DIR/preview/<stem>.png (stereo/preview.h).

  /// Rig geometry (issue 3). With a rig (which must be rectified, its rectified size that of
  /// the images), every pair's disparity is triangulated into OUT_DIR/xyz/<stem>.exr.
  std::optional<calib::StereoRig> rig;
  std::string rig_source;        ///< Where the rig came from (recorded in the summary).
  bool write_ply = false;        ///< Also OUT_DIR/cloud/<stem>.ply (needs the rig).
  /// Also OUT_DIR/xyz_sigma/<stem>.exr: the X, Y, Z error of a disparity error of this many
  /// pixels (needs the rig). Unset = not written.
  std::optional<double> xyz_sigma_px;
  /// Window selection (sec. 3.3, needs the rig): the region every pair measures; its row band
  /// and disparity range replace `matcher`'s. Unset = the matcher's own rows and range.
  std::optional<calib::RegionOfInterest> region;
  /// The rig's default when neither a region nor a disparity range or row band was given
  /// (calib::SelectGroundWindow): the ground both cameras see, to the far limit, with the
  /// objects' heights. Used like `region`.
  std::optional<calib::GroundWindow> ground;
  /// Per-pair distance intervals (the planner's requests); a listed pair measures
  /// {Y in its interval, Z in requests_region's heights}; other pairs fall back to `region`,
  /// or to the matcher's rows and range.
  std::vector<WindowRequest> requests;
  calib::RegionOfInterest requests_region;  ///< The heights for the requests (its Y is unused).
  std::string requests_source;   ///< The requests file (for messages and the summary).
  calib::WindowSelectionOptions window_selection;
  /// The vehicle's attitude per pair (stereo-batch --poses): a listed pair's rig default and
  /// requests take their region in the level frame at its mast base (window_selection's
  /// vehicle_pitch_deg and vehicle_roll_deg), so that a vehicle pitched over a rock still
  /// searches the ground ahead. Needs the rig; a pair not listed searches as a level vehicle.
  std::map<std::string, VehicleAttitude> attitudes;
  std::string attitudes_source;  ///< The poses file (for messages and the summary).

  /// The pairs' residual vertical misalignment (stereo/vertical_alignment.h): kAuto measures it
  /// on up to kVerticalSamplePairs pairs spread over the whole listing (every shard the same
  /// ones, so shards agree) and resamples every pair by it before matching, when it reaches
  /// kMinVerticalCorrectionPx where it was measured; kOff matches the rows as they are.
  /// kGiven: the misalignment another run measured (`vertical_given`, read from that run's
  /// summary.json by ReadMeasuredVerticalAlignment; none when it found the pairs aligned), not
  /// measured again: the shards of a cluster run, a rig whose misalignment is known.
  enum class VerticalAlignment { kOff, kAuto, kGiven };
  VerticalAlignment vertical_alignment = VerticalAlignment::kOff;
  std::optional<VerticalMisalignment> vertical_given;
  std::string vertical_source;  ///< The file it came from (for messages and the summary).

  /// Throws std::invalid_argument for bad options: geometry options without a rig, a rig
  /// that is not rectified, a region that the reference camera does not see.
  void Validate() const;
  nlohmann::json ToJson() const;
};

/// The pairs a run measures its vertical misalignment on, at most.
inline constexpr int kVerticalSamplePairs = 8;
/// Rounds of measuring at most: each on the pairs resampled by the rounds before.
inline constexpr int kVerticalRounds = 4;
/// A misalignment smaller than this where it was measured (the first round's surface, the 95th
/// percentile of |offset| at its samples) is left as it is, px.
inline constexpr double kMinVerticalCorrectionPx = 0.1;
/// A later round that finds less than this where it measured ends the rounds: about what a fit
/// of the surface's ten terms to two thousand samples with 0.15 px of noise finds in noise
/// alone, px. (A round can find more than the one before: the rows that misalignment kept from
/// matching at all match once it is partly taken out, and show what is left there.)
inline constexpr double kMinVerticalResidualPx = 0.02;
/// A misalignment larger than this somewhere is worth a warning (the rig wants a new calibration), px.
inline constexpr double kLargeVerticalMisalignmentPx = 1.5;

/// "auto", "off" or "file".
std::string ToString(BatchOptions::VerticalAlignment mode);
/// From "auto" or "off". @throws std::invalid_argument otherwise.
BatchOptions::VerticalAlignment VerticalAlignmentFromString(const std::string& text);

/// The misalignment a stereo-batch run with --vertical-alignment auto measured, from its
/// summary.json (or a shard's): the surface it resampled by, or none when it found the pairs
/// aligned. @throws InputError naming the file when it holds no measurement or a malformed one.
std::optional<VerticalMisalignment> ReadMeasuredVerticalAlignment(const std::filesystem::path& summary);

/// What happened to one pair.
struct PairOutcome {
  enum class Status { kOk, kResumed, kFailed };
  std::string stem;
  Status status = Status::kFailed;
  std::string error;        ///< For kFailed: "<file>: <reason>".
  nlohmann::json result;    ///< For kOk and kResumed: counts and timings (the sidecar's).
  double seconds = 0;       ///< This run's time on the pair: reading, matching, writing (0 when resumed).
  double match_seconds = 0; ///< Of which matching.
};

/// Totals of a run.
struct BatchSummary {
  int pairs_listed = 0;     ///< In INPUT_DIR.
  int pairs_in_shard = 0;
  int pairs_ok = 0, pairs_resumed = 0, pairs_failed = 0;
  double seconds = 0, read_seconds = 0, match_seconds = 0, write_seconds = 0, xyz_seconds = 0;
  util::StageTimes stage_seconds;  ///< Per stage, summed over the pairs, in the order they ran.
  long long pixels_evaluated = 0, pixels_accepted = 0;
  long long points = 0;     ///< Triangulated points (with a rig).
  std::vector<PairOutcome> pairs;  ///< Name order.
  std::filesystem::path summary_path;
  /// e.g. "3 pairs: 3 ok, 0 failed; accepted 71.2% of evaluated pixels; 0.52 s".
  std::string BriefReport() const;
};

/// Output paths of one pair (xyz, cloud and xyz_sigma are written only when enabled).
struct PairOutputPaths {
  std::filesystem::path disparity, confidence, rejections, sidecar;
  std::filesystem::path xyz, cloud, xyz_sigma;
  std::filesystem::path preview;
};
PairOutputPaths OutputPathsFor(const std::filesystem::path& output_dir, const std::string& stem);

/// Name of the run summary: summary.json, or summary.shard-K-of-N.json for a shard.
std::string SummaryFileName(const BatchOptions& options);

/// The image a run's disparity maps are referenced to, as its summary.json in `output_dir`
/// records it (options.reference). None when the summary is missing or records none that can be
/// read; then `problem`, when given, says which ("<path>: no such file", or what was wrong).
std::optional<calib::ReferenceImage> ReadRunReference(const std::filesystem::path& output_dir,
                                                      std::string* problem = nullptr);

/// A run driven pair by pair: the closed loop of sec. 3.3, where a pair's request is known only
/// once the pairs before it are in the map. RunStereoBatch is this over every pair of the shard.
class StereoBatchRun {
 public:
  /// Lists INPUT_DIR's pairs, selects the windows (of options.requests, of a range or of the
  /// rig's default) and creates the output directories. Throws as RunStereoBatch.
  StereoBatchRun(const BatchOptions& options, const std::filesystem::path& input_dir,
                 const std::filesystem::path& output_dir);
  ~StereoBatchRun();
  StereoBatchRun(const StereoBatchRun&) = delete;
  StereoBatchRun& operator=(const StereoBatchRun&) = delete;

  /// The pairs of the shard, in name order.
  const std::vector<PairFiles>& Pairs() const;
  /// Sets the window of `request.stem` (as a line of --requests; BatchOptions::requests_region
  /// gives the heights). @throws InputError when the camera sees no point of the interval.
  void Request(const WindowRequest& request);
  /// Matches pair k of Pairs() in its window and writes its outputs (or, with resume, keeps
  /// complete ones). A bad pair is logged and returned as kFailed. Calls for different k may
  /// run concurrently; Request may not run beside them.
  const PairOutcome& Process(std::size_t k);
  /// Writes the run summary over the pairs processed so far and returns the totals.
  BatchSummary Finish(const nlohmann::json& invocation = nullptr);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// --resume's test of one pair: its sidecar (read into `sidecar`) is one the batch wrote with
/// `options` (format, options, a result whose counts and bit depth are of the types the batch
/// reads them as: a damaged sidecar is an incomplete pair, redone), and every output `batch`
/// enables exists with the size the sidecar recorded.
bool OutputsComplete(const BatchOptions& batch, const PairOutputPaths& paths, const nlohmann::json& options,
                     nlohmann::json* sidecar);

/// The rig's declared rectified size against the first readable pair of `input_dir`, before
/// the work the size sets (the ground window's rows and bands): a rig of other images is bad
/// input naming the rig and the image (a rig declaring 100000 x 100000 pixels kept the tools
/// busy for ever). Nothing when the directory holds no readable pair (each pair says so).
void CheckRigAgainstPairs(const calib::StereoRig& rig, const std::string& rig_source,
                          const std::filesystem::path& input_dir);

/// Matches every pair of the shard, writes OUT_DIR/{disparity,confidence,rejections}/<stem>.*
/// (and, with a rig, xyz/<stem>.exr, cloud/<stem>.ply, xyz_sigma/<stem>.exr as enabled) and
/// the run summary, which records the window (row band, disparity range) each pair used. A pair that cannot be read or is blank, saturated, mismatched or
/// unpaired is logged as one "error: pair <stem>: ..." line and counted as failed; the rest
/// go on. Every file is written atomically.
/// @param invocation  recorded in the summary (e.g. the command line).
/// @throws InputError when INPUT_DIR is unusable or holds no pairs, or a request's interval
///         is not seen by the camera (naming the requests file and line);
///         std::invalid_argument for bad options; other exceptions for system failures (e.g. the disk is full).
BatchSummary RunStereoBatch(const BatchOptions& options, const std::filesystem::path& input_dir,
                            const std::filesystem::path& output_dir,
                            const nlohmann::json& invocation = nullptr);

}  // namespace lunarnav::stereo
