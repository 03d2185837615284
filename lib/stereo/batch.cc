#include "stereo/batch.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <sstream>

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "io/atomic_file.h"
#include "io/image_io.h"
#include "io/json_io.h"
#include "stereo/ncc_matcher.h"
#include "util/check.h"
#include "util/log.h"
#include "util/progress.h"
#include "util/resources.h"
#include "util/timer.h"
#include "util/version.h"

namespace lunarnav::stereo {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr const char* kSidecarFormat = "lunarnav.disparity/1";

// stem -> the image files with that stem in one directory.
std::map<std::string, std::vector<fs::path>> ImagesByStem(const fs::path& dir) {
  std::map<std::string, std::vector<fs::path>> by_stem;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const fs::path& path = entry.path();
    const std::string name = path.filename().string();
    if (name.empty() || name[0] == '.' || !io::HasImageExtension(path)) continue;
    if (!entry.is_regular_file(ec) && !entry.is_symlink(ec)) continue;
    by_stem[path.stem().string()].push_back(path);
  }
  LN_CHECK_INPUT(!ec) << dir.string() << ": cannot list (" << ec.message() << ")";
  return by_stem;
}

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

std::vector<PairFiles> ListStereoPairs(const fs::path& input_dir) {
  std::error_code ec;
  LN_CHECK_INPUT(fs::is_directory(input_dir, ec)) << input_dir.string() << ": no such directory";
  const fs::path left_dir = input_dir / "left", right_dir = input_dir / "right";
  LN_CHECK_INPUT(fs::is_directory(left_dir, ec))
      << input_dir.string() << ": no left/ directory (expected left/ and right/ image folders)";
  LN_CHECK_INPUT(fs::is_directory(right_dir, ec))
      << input_dir.string() << ": no right/ directory (expected left/ and right/ image folders)";
  const auto lefts = ImagesByStem(left_dir);
  const auto rights = ImagesByStem(right_dir);
  std::map<std::string, PairFiles> pairs;
  auto add = [&](const std::map<std::string, std::vector<fs::path>>& side, bool is_left) {
    for (const auto& [stem, files] : side) {
      PairFiles& pair = pairs[stem];
      pair.stem = stem;
      (is_left ? pair.left : pair.right) = files.front();
      if (files.size() > 1 && pair.problem.empty()) {
        pair.problem = files[1].string() + ": several images with stem '" + stem + "' (" +
                       files[0].filename().string() + ", " + files[1].filename().string() + ")";
      }
    }
  };
  add(lefts, true);
  add(rights, false);
  std::vector<PairFiles> listing;
  for (auto& [stem, pair] : pairs) {
    if (pair.problem.empty() && pair.left.empty()) {
      pair.problem = (left_dir / (stem + ".*")).string() + ": missing (right image " +
                     pair.right.filename().string() + " has no partner)";
    }
    if (pair.problem.empty() && pair.right.empty()) {
      pair.problem = (right_dir / (stem + ".*")).string() + ": missing (left image " +
                     pair.left.filename().string() + " has no partner)";
    }
    listing.push_back(std::move(pair));
  }
  return listing;
}

void BatchOptions::Validate() const {
  matcher.Validate();
  frame_check.Validate();
  LN_CHECK_ARG(shard_count >= 1 && shard_index >= 0 && shard_index < shard_count)
      << "shard: need 0 <= K < N, got " << shard_index << "/" << shard_count;
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
  if (options.shard_count == 1) return "summary.json";
  return "summary.shard-" + std::to_string(options.shard_index) + "-of-" +
         std::to_string(options.shard_count) + ".json";
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
  std::vector<const PairFiles*> shard;
  for (std::size_t i = 0; i < listing.size(); ++i) {
    if (static_cast<int>(i % options.shard_count) == options.shard_index) shard.push_back(&listing[i]);
  }
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
  tbb::task_arena arena(options.num_threads > 0 ? options.num_threads
                                                : tbb::task_arena::automatic);
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, shard.size(), 1),
                      [&](const tbb::blocked_range<std::size_t>& range) {
                        for (std::size_t k = range.begin(); k != range.end(); ++k) process(k);
                      },
                      tbb::simple_partitioner());
  });

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
  j["threads"] = options.num_threads > 0 ? options.num_threads : tbb::info::default_concurrency();
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
