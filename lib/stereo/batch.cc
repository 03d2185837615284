#include "stereo/batch.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>
#include <sstream>

#include <tbb/enumerable_thread_specific.h>

#include "io/atomic_file.h"
#include "io/image_io.h"
#include "io/json_io.h"
#include "stereo/ncc_matcher.h"
#include "util/check.h"
#include "util/log.h"
#include "util/parallel.h"
#include "util/progress.h"
#include "util/resources.h"
#include "util/timer.h"
#include "util/version.h"

namespace lunarnav::stereo {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr const char* kSidecarFormat = "lunarnav.disparity/1";

std::string ReferenceConvention(ReferenceImage reference) {
  return reference == ReferenceImage::kRight ? "x_left = x_right + d (right image reference)"
                                             : "x_right = x_left - d (left image reference)";
}

// True when the outputs of `stem` are complete and were made with the same options.
bool OutputsComplete(const PairOutputPaths& paths, const json& options, json* sidecar) {
  std::error_code ec;
  for (const fs::path& p : {paths.disparity, paths.confidence, paths.rejections, paths.sidecar}) {
    if (!fs::is_regular_file(p, ec)) return false;
  }
  try {
    *sidecar = io::ReadJson(paths.sidecar);
  } catch (const InputError&) {
    return false;
  }
  return sidecar->value("format", "") == kSidecarFormat && sidecar->contains("options") &&
         (*sidecar)["options"] == options;
}

struct PairTimings {
  double read_s = 0, match_s = 0, write_s = 0;
};

// Reads, screens and matches one pair and writes its outputs. Throws InputError for a bad pair.
json ProcessPair(const BatchOptions& options, const PairFiles& pair, const PairOutputPaths& out,
                 const json& options_json, NccResult* result, PairTimings* timings) {
  LN_CHECK_INPUT(pair.problem.empty()) << pair.problem;
  util::Timer timer;
  const cv::Mat left = io::ReadGreyImage(pair.left);
  if (auto bad = CheckFrame(options.frame_check, left)) {
    throw InputError(pair.left.string() + ": " + *bad);
  }
  const cv::Mat right = io::ReadGreyImage(pair.right);
  if (auto bad = CheckFrame(options.frame_check, right)) {
    throw InputError(pair.right.string() + ": " + *bad);
  }
  LN_CHECK_INPUT(left.size() == right.size())
      << pair.right.string() << ": size " << right.cols << "x" << right.rows
      << " differs from the left image's " << left.cols << "x" << left.rows;
  LN_CHECK_INPUT(left.depth() == right.depth())
      << pair.right.string() << ": bit depth differs from the left image's";
  timings->read_s = timer.ElapsedSeconds();

  timer.Restart();
  NccOptions matcher = options.matcher;
  matcher.num_threads = 0;  // the batch's arena
  MatchStereoPair(matcher, left, right, result);
  timings->match_s = timer.ElapsedSeconds();

  timer.Restart();
  cv::Mat disparity_pfm = result->disparity_px.clone();
  cv::patchNaNs(disparity_pfm, std::numeric_limits<double>::infinity());
  io::WriteImageAtomic(out.disparity, disparity_pfm);
  io::WriteImageAtomic(out.confidence, result->correlation);
  io::WriteImageAtomic(out.rejections, result->rejection);
  timings->write_s = timer.ElapsedSeconds();

  json sidecar;
  sidecar["format"] = kSidecarFormat;
  sidecar["stem"] = pair.stem;
  sidecar["inputs"] = {{"left", pair.left.string()}, {"right", pair.right.string()}};
  sidecar["disparity"] = {
      {"file", out.disparity.filename().string()},
      {"dtype", "float32"},
      {"size_px", {left.cols, left.rows}},
      {"units", "px"},
      {"reference", ToString(options.matcher.reference)},
      {"convention", ReferenceConvention(options.matcher.reference)},
      {"invalid", "+inf in the PFM file (NaN in memory)"},
      {"grid", {{"origin_px", {0, 0}},
                {"step_px", {options.matcher.step_x_px, options.matcher.step_y_px}}}}};
  sidecar["confidence"] = {{"file", fs::relative(out.confidence, out.sidecar.parent_path()).string()},
                           {"dtype", "float32"},
                           {"meaning", "best normalized correlation C; NaN where not searched"}};
  sidecar["rejections"] = {{"file", fs::relative(out.rejections, out.sidecar.parent_path()).string()},
                           {"dtype", "uint8"},
                           {"meaning", "rejection code per pixel (docs/formats.md)"}};
  sidecar["options"] = options_json;
  sidecar["result"] = result->summary.ToJson();
  sidecar["result"]["timings_ms"] = {{"read", 1e3 * timings->read_s},
                                     {"match", 1e3 * timings->match_s},
                                     {"write", 1e3 * timings->write_s}};
  sidecar["version"] = kVersion;
  io::WriteJsonAtomic(out.sidecar, sidecar);  // last: its presence marks the pair complete
  return sidecar["result"];
}

}  // namespace

void BatchOptions::Validate() const {
  matcher.Validate();
  frame_check.Validate();
  io::CheckShard(shard_index, shard_count);
  LN_CHECK_ARG(num_threads >= 0) << "threads: must be >= 0";
}

json BatchOptions::ToJson() const {
  json j = matcher.ToJson();
  j["frame_check"] = frame_check.ToJson();
  return j;
}

PairOutputPaths OutputPathsFor(const fs::path& output_dir, const std::string& stem) {
  return {output_dir / "disparity" / (stem + ".pfm"), output_dir / "confidence" / (stem + ".tif"),
          output_dir / "rejections" / (stem + ".png"), output_dir / "disparity" / (stem + ".json")};
}

std::string SummaryFileName(const BatchOptions& options) {
  return io::SummaryFileName(options.shard_index, options.shard_count);
}

std::string BatchSummary::BriefReport() const {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(1);
  s << pairs_in_shard << " pair" << (pairs_in_shard == 1 ? "" : "s") << ": " << pairs_ok << " ok";
  if (pairs_resumed > 0) s << ", " << pairs_resumed << " already done";
  s << ", " << pairs_failed << " failed";
  if (pixels_evaluated > 0) {
    s << "; accepted " << 100.0 * static_cast<double>(pixels_accepted) / pixels_evaluated
      << "% of evaluated pixels";
  }
  s.precision(2);
  s << "; " << seconds << " s";
  return s.str();
}

BatchSummary RunStereoBatch(const BatchOptions& options, const fs::path& input_dir,
                            const fs::path& output_dir, const json& invocation) {
  options.Validate();
  util::Timer total_timer;
  const std::vector<PairFiles> listing = ListStereoPairs(input_dir);
  LN_CHECK_INPUT(!listing.empty())
      << input_dir.string() << ": no image pairs in left/ and right/ (PNG, PGM, TIFF or JPEG)";
  const std::vector<const PairFiles*> shard =
      io::SelectShard(listing, options.shard_index, options.shard_count);
  for (const char* sub : {"disparity", "confidence", "rejections"}) {
    io::CreateOutputDirectory(output_dir / sub);
    io::RemoveStaleTempFiles(output_dir / sub);
  }
  io::RemoveStaleTempFiles(output_dir);

  const json options_json = options.ToJson();
  BatchSummary summary;
  summary.pairs_listed = static_cast<int>(listing.size());
  summary.pairs_in_shard = static_cast<int>(shard.size());
  summary.pairs.resize(shard.size());
  std::vector<PairTimings> timings(shard.size());
  tbb::enumerable_thread_specific<NccResult> results;  // reused buffers, one per thread
  util::ProgressBar progress(shard.size(), "stereo-batch", options.show_progress);

  auto process = [&](std::size_t k) {
    const PairFiles& pair = *shard[k];
    PairOutcome& outcome = summary.pairs[k];
    outcome.stem = pair.stem;
    const PairOutputPaths out = OutputPathsFor(output_dir, pair.stem);
    json sidecar;
    if (options.resume && OutputsComplete(out, options_json, &sidecar)) {
      outcome.status = PairOutcome::Status::kResumed;
      outcome.result = sidecar["result"];
    } else {
      try {
        outcome.result = ProcessPair(options, pair, out, options_json, &results.local(), &timings[k]);
        outcome.status = PairOutcome::Status::kOk;
      } catch (const InputError& e) {
        outcome.status = PairOutcome::Status::kFailed;
        outcome.error = e.what();
        LN_LOG(Error) << "pair " << pair.stem << ": " << e.what();
      }
    }
    progress.Increment();
  };
  util::ParallelForEachItem(shard.size(), options.num_threads, process);

  json pairs_json = json::array();
  json failed_json = json::array();
  for (std::size_t k = 0; k < shard.size(); ++k) {
    const PairOutcome& outcome = summary.pairs[k];
    json entry = {{"stem", outcome.stem}};
    switch (outcome.status) {
      case PairOutcome::Status::kOk: ++summary.pairs_ok; entry["status"] = "ok"; break;
      case PairOutcome::Status::kResumed: ++summary.pairs_resumed; entry["status"] = "resumed"; break;
      case PairOutcome::Status::kFailed: ++summary.pairs_failed; entry["status"] = "failed"; break;
    }
    if (outcome.status == PairOutcome::Status::kFailed) {
      entry["error"] = outcome.error;
      failed_json.push_back({{"stem", outcome.stem}, {"error", outcome.error}});
    } else {
      entry["result"] = outcome.result;
      summary.pixels_evaluated += outcome.result.value("pixels_evaluated", 0LL);
      summary.pixels_accepted += outcome.result.value("pixels_accepted", 0LL);
    }
    summary.read_seconds += timings[k].read_s;
    summary.match_seconds += timings[k].match_s;
    summary.write_seconds += timings[k].write_s;
    pairs_json.push_back(std::move(entry));
  }
  summary.seconds = total_timer.ElapsedSeconds();

  json j;
  j["tool"] = "stereo-batch";
  j["version"] = kVersion;
  j["git_revision"] = kGitRevision;
  j["invocation"] = invocation;
  j["input_dir"] = input_dir.string();
  j["output_dir"] = output_dir.string();
  j["options"] = options_json;
  j["shard"] = {options.shard_index, options.shard_count};
  j["threads"] = util::EffectiveThreadCount(options.num_threads);
  j["kernel"] = ActiveKernelName();
  j["counts"] = {{"pairs_listed", summary.pairs_listed},
                 {"pairs_in_shard", summary.pairs_in_shard},
                 {"pairs_ok", summary.pairs_ok},
                 {"pairs_resumed", summary.pairs_resumed},
                 {"pairs_failed", summary.pairs_failed},
                 {"pixels_evaluated", summary.pixels_evaluated},
                 {"pixels_accepted", summary.pixels_accepted}};
  j["timings_s"] = {{"total", summary.seconds},
                    {"read_sum", summary.read_seconds},
                    {"match_sum", summary.match_seconds},
                    {"write_sum", summary.write_seconds}};
  j["peak_memory_mib"] = util::PeakResidentMemoryMiB();
  j["failed"] = failed_json;
  j["pairs"] = pairs_json;
  summary.summary_path = output_dir / SummaryFileName(options);
  io::WriteJsonAtomic(summary.summary_path, j);
  return summary;
}

}  // namespace lunarnav::stereo
