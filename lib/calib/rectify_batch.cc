#include "calib/rectify_batch.h"

#include <algorithm>
#include <sstream>

#include "calib/rectify.h"
#include "calib/stereo_rig_io.h"
#include "io/atomic_file.h"
#include "io/grey_depth.h"
#include "io/image_io.h"
#include "io/json_io.h"
#include "io/shard_merge.h"
#include "io/stereo_pairs.h"
#include "util/check.h"
#include "util/log.h"
#include "util/parallel.h"
#include "util/progress.h"
#include "util/resources.h"
#include "util/timer.h"
#include "util/summary.h"

namespace lunarnav::calib {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

struct PairPaths {
  fs::path left, right;
};

PairPaths OutputPathsFor(const fs::path& output_dir, const std::string& stem,
                         const std::string& format) {
  return {output_dir / "left" / (stem + "." + format), output_dir / "right" / (stem + "." + format)};
}

// Reads, rectifies and writes one pair. Throws InputError for a bad pair.
void ProcessPair(const Rectifier& rectifier, const StereoRig& rig, const io::PairFiles& pair,
                 const PairPaths& out, RectifyPairOutcome* outcome) {
  LN_CHECK_INPUT(pair.problem.empty()) << pair.problem;
  util::Timer timer;
  io::SignificantBits left_bits, right_bits;
  const cv::Mat left = io::ReadImage(pair.left, &left_bits);
  LN_CHECK_INPUT(left.cols == rig.width_px && left.rows == rig.height_px)
      << pair.left.string() << ": size " << left.cols << "x" << left.rows
      << " is not the rig's raw image size " << rig.width_px << "x" << rig.height_px;
  const cv::Mat right = io::ReadImage(pair.right, &right_bits);
  LN_CHECK_INPUT(right.cols == rig.width_px && right.rows == rig.height_px)
      << pair.right.string() << ": size " << right.cols << "x" << right.rows
      << " is not the rig's raw image size " << rig.width_px << "x" << rig.height_px;
  outcome->read_s = timer.ElapsedSeconds();

  timer.Restart();
  cv::Mat left_rect, right_rect;
  rectifier.Rectify(left, right, &left_rect, &right_rect);
  outcome->rectify_s = timer.ElapsedSeconds();

  timer.Restart();
  // The input's bit depth is kept: 16-bit stays 16-bit, and the significant bits of a 12-bit
  // camera's data, declared (a PNG's sBIT) or told from the data when the files say nothing
  // (io::InferSignificantBits), are written as sBIT, so that the next tool needs no guess.
  const io::SignificantBits bits =
      io::InferSignificantBits(left, right, left_bits.bits >= right_bits.bits ? left_bits : right_bits);
  outcome->bits = bits.bits;
  outcome->bits_source = bits.source;
  io::WriteImageAtomic(out.left, left_rect, bits.bits);
  io::WriteImageAtomic(out.right, right_rect, bits.bits);  // last: both files present = pair complete
  outcome->write_s = timer.ElapsedSeconds();
}

json RectifiedRigJson(const StereoRig& rig) {
  const RectifiedGeometry& g = *rig.rectified;
  const double f = g.P_left(0, 0);
  return {{"focal_px", f},
          {"baseline_m", -g.P_right(0, 3) / f},
          {"principal_point_left_px", {g.P_left(0, 2), g.P_left(1, 2)}},
          {"principal_point_right_px", {g.P_right(0, 2), g.P_right(1, 2)}},
          {"size_px", {g.width_px, g.height_px}}};
}

}  // namespace

void RectifyBatchOptions::Validate() const {
  LN_CHECK_ARG(!alpha || (*alpha >= 0.0 && *alpha <= 1.0))
      << "alpha: must be in [0, 1], got " << *alpha;
  LN_CHECK_ARG(image_format == "png" || image_format == "tif")
      << "format: png or tif, got '" << image_format << "'";
  io::CheckShard(shard_index, shard_count);
  LN_CHECK_ARG(num_threads >= 0) << "threads: must be >= 0";
}

json RectifyBatchOptions::ToJson() const {
  return {{"alpha", alpha ? json(*alpha) : json(nullptr)}, {"format", image_format}};
}

std::string RectifyBatchSummary::BriefReport() const {
  std::ostringstream s;
  s << pairs_in_shard << " pair" << (pairs_in_shard == 1 ? "" : "s") << ": " << pairs_ok << " ok";
  if (pairs_resumed > 0) s << ", " << pairs_resumed << " already done";
  s.setf(std::ios::fixed);
  s.precision(2);
  s << ", " << pairs_failed << " failed; " << seconds << " s";
  return s.str();
}

StereoRig RigForRectification(const StereoRig& rig, const RectifyBatchOptions& options) {
  if (rig.rectified && !options.alpha) return rig;
  return RectifyRig(rig, options.alpha.value_or(0.0));
}

RectifyBatchSummary RunRectifyBatch(const RectifyBatchOptions& options, const StereoRig& rig,
                                    const std::string& rig_source, const fs::path& input_dir,
                                    const fs::path& output_dir, const json& invocation) {
  options.Validate();
  util::Timer total_timer;
  rig.Validate(rig_source);
  const std::vector<io::PairFiles> listing = io::ListStereoPairs(input_dir);
  LN_CHECK_INPUT(!listing.empty())
      << input_dir.string() << ": no image pairs in left/ and right/ (PNG, PGM, TIFF or JPEG)";
  const std::vector<const io::PairFiles*> shard =
      io::SelectShard(listing, options.shard_index, options.shard_count);

  RectifyBatchSummary summary;
  summary.rectified_rig = RigForRectification(rig, options);
  summary.rig_path = output_dir / "rig.json";
  const json rig_json = StereoRigToJson(summary.rectified_rig);
  io::CreateOutputDirectory(output_dir);
  if (options.resume && fs::exists(summary.rig_path)) {
    const json previous = StereoRigToJson(ReadStereoRig(summary.rig_path));
    LN_CHECK_ARG(previous == rig_json)
        << summary.rig_path.string()
        << ": holds another rectified rig than this run's (other rig file or --alpha); "
           "--resume needs the same, or drop --resume to redo every pair";
  }
  for (const char* sub : {"left", "right"}) {
    io::CreateOutputDirectory(output_dir / sub);
    io::RemoveStaleTempFiles(output_dir / sub);
  }
  io::RemoveStaleTempFiles(output_dir);
  WriteStereoRig(summary.rig_path, summary.rectified_rig);

  util::Timer maps_timer;
  const Rectifier rectifier(summary.rectified_rig);
  summary.maps_seconds = maps_timer.ElapsedSeconds();

  summary.pairs_listed = static_cast<int>(listing.size());
  summary.pairs_in_shard = static_cast<int>(shard.size());
  summary.pairs.resize(shard.size());
  util::ProgressBar progress(shard.size(), "rectify", options.show_progress);
  util::ParallelForEachItem(shard.size(), options.num_threads, [&](std::size_t k) {
    const io::PairFiles& pair = *shard[k];
    RectifyPairOutcome& outcome = summary.pairs[k];
    outcome.stem = pair.stem;
    const PairPaths out = OutputPathsFor(output_dir, pair.stem, options.image_format);
    std::error_code ec;
    if (options.resume && fs::is_regular_file(out.left, ec) && fs::is_regular_file(out.right, ec)) {
      outcome.status = RectifyPairOutcome::Status::kResumed;
    } else {
      try {
        ProcessPair(rectifier, summary.rectified_rig, pair, out, &outcome);
        outcome.status = RectifyPairOutcome::Status::kOk;
      } catch (const InputError& e) {
        outcome.status = RectifyPairOutcome::Status::kFailed;
        outcome.error = e.what();
        LN_LOG(Error) << "pair " << pair.stem << ": " << e.what();
      }
    }
    progress.Increment();
  });

  json pairs_json = json::array(), failed_json = json::array();
  double read_s = 0, rectify_s = 0, write_s = 0;
  for (const RectifyPairOutcome& outcome : summary.pairs) {
    json entry = {{"stem", outcome.stem}};
    switch (outcome.status) {
      case RectifyPairOutcome::Status::kOk:
        ++summary.pairs_ok;
        entry["status"] = "ok";
        entry["bit_depth"] = outcome.bits;
        entry["bit_depth_source"] = outcome.bits_source;
        entry["timings_ms"] = {{"read", 1e3 * outcome.read_s},
                               {"rectify", 1e3 * outcome.rectify_s},
                               {"write", 1e3 * outcome.write_s}};
        break;
      case RectifyPairOutcome::Status::kResumed:
        ++summary.pairs_resumed;
        entry["status"] = "resumed";
        break;
      case RectifyPairOutcome::Status::kFailed:
        ++summary.pairs_failed;
        entry["status"] = "failed";
        entry["error"] = outcome.error;
        failed_json.push_back({{"stem", outcome.stem}, {"error", outcome.error}});
        break;
    }
    read_s += outcome.read_s;
    rectify_s += outcome.rectify_s;
    write_s += outcome.write_s;
    pairs_json.push_back(std::move(entry));
  }
  summary.seconds = total_timer.ElapsedSeconds();

  json j = util::SummaryHead("rectify", invocation);
  j["input_dir"] = input_dir.string();
  j["output_dir"] = output_dir.string();
  j["rig"] = {{"input", rig_source},
              {"input_was_rectified", rig.rectified.has_value()},
              {"output", summary.rig_path.filename().string()},
              {"rectified", RectifiedRigJson(summary.rectified_rig)},
              {"notes", rig.notes}};
  j["listing"] = io::ListingRecord("stereo-pairs", "pairs", io::PairStems(listing));  // shard-merge's check
  j["options"] = options.ToJson();
  j["shard"] = {options.shard_index, options.shard_count};
  j["threads"] = util::EffectiveThreadCount(options.num_threads);
  j["counts"] = {{"pairs_listed", summary.pairs_listed},
                 {"pairs_in_shard", summary.pairs_in_shard},
                 {"pairs_ok", summary.pairs_ok},
                 {"pairs_resumed", summary.pairs_resumed},
                 {"pairs_failed", summary.pairs_failed}};
  j["timings_s"] = {{"total", summary.seconds},
                    {"maps", summary.maps_seconds},
                    {"read_sum", read_s},
                    {"rectify_sum", rectify_s},
                    {"write_sum", write_s}};
  j["peak_memory_mib"] = util::PeakResidentMemoryMiB();
  j["failed"] = failed_json;
  j["pairs"] = pairs_json;
  summary.summary_path = output_dir / io::SummaryFileName(options.shard_index, options.shard_count);
  io::WriteJsonAtomic(summary.summary_path, j);
  return summary;
}

}  // namespace lunarnav::calib
