#include "stereo/batch.h"

#include <algorithm>
#include <array>
#include <new>
#include <cmath>
#include <cstdint>
#include <exception>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>

#include <opencv2/core.hpp>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_invoke.h>

#include "calib/stereo_rig_io.h"
#include "calib/triangulation.h"
#include "io/atomic_file.h"
#include "io/float_array_io.h"
#include "io/grey_depth.h"
#include "io/image_io.h"
#include "io/json_io.h"
#include "io/ply_io.h"
#include "io/shard_merge.h"
#include "stereo/ncc_matcher.h"
#include "stereo/preview.h"
#include "stereo/vertical_alignment.h"
#include "util/check.h"
#include "util/log.h"
#include "util/parallel.h"
#include "util/progress.h"
#include "util/resources.h"
#include "util/timer.h"
#include "util/version.h"
#include "util/summary.h"

namespace lunarnav::stereo {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr const char* kSidecarFormat = "lunarnav.disparity/1";
constexpr const char* kVehicleFrame = "vehicle: X right, Y forward (direction of travel), Z up, metres, origin at the mast base";

// The window (row band and disparity range) one pair measures, and where it came from.
struct PairWindow {
  std::string source;  // "requests", "range-y" or "rig-ground"
  calib::RegionOfInterest region;
  calib::ImageWindow window;
  long request_line = 0;
  std::vector<std::pair<int, int>> row_disparity_px;  // with a rig default: per-row bands (semi-global), guard included
  std::vector<int> row_accept_min_px;                 // with a rig default: the far limit's disparity per row
  std::vector<int> row_accept_max_px;                 // requests, a tall guard: the near limit's disparity per row
  int guard_min_disparity_px = 0;
  int guard_max_disparity_px = 0;
  std::optional<VehicleAttitude> attitude;  // the region is then in the level frame
  // The rig's default search (calib::SelectGroundWindow's window and per-row bands).
  static PairWindow FromGround(const calib::GroundWindow& g) {
    return {"rig-ground", g.region, g.window, 0, g.row_disparity_px, g.row_accept_min_px, g.row_accept_max_px,
            g.guard_min_disparity_px, std::max(g.window.max_disparity_px, g.guard_max_disparity_px), std::nullopt};
  }
  nlohmann::json ToJson() const {
    nlohmann::json j = window.ToJson();
    j["source"] = source;
    j["region"] = region.ToJson();
    if (attitude) j["vehicle_attitude_deg"] = {{"pitch", attitude->pitch_deg}, {"roll", attitude->roll_deg}};
    if (request_line > 0) j["request_line"] = request_line;
    if (!row_disparity_px.empty()) {
      long searched = 0;
      int rows = 0;
      for (const auto& [lo, hi] : row_disparity_px) {
        if (hi < lo) continue;
        ++rows;
        searched += hi - lo + 1;
      }
      j["row_band_mean_px"] = rows > 0 ? static_cast<double>(searched) / rows : 0.0;
    }
    return j;
  }
};

std::string ReferenceConvention(ReferenceImage reference) {
  return reference == ReferenceImage::kRight ? "x_left = x_right + d (right image reference)"
                                             : "x_right = x_left - d (left image reference)";
}

// An output's name in the sidecar's file_bytes: its folder and file ("xyz/a.exr").
std::string OutputKey(const fs::path& p) { return (p.parent_path().filename() / p.filename()).generic_string(); }

// A pair's output files that the options enable (the sidecar aside).
std::vector<fs::path> EnabledOutputs(const BatchOptions& batch, const PairOutputPaths& paths) {
  std::vector<fs::path> files = {paths.disparity, paths.confidence, paths.rejections};
  if (batch.rig) files.push_back(paths.xyz);
  if (batch.write_ply) files.push_back(paths.cloud);
  if (batch.xyz_sigma_px) files.push_back(paths.xyz_sigma);
  if (batch.write_preview) files.push_back(paths.preview);
  return files;
}

// True when the outputs of `stem` are complete and were made with the same options.
}  // namespace

bool OutputsComplete(const BatchOptions& batch, const PairOutputPaths& paths, const json& options,
                     json* sidecar) {
  const std::vector<fs::path> files = EnabledOutputs(batch, paths);
  std::error_code ec;
  if (!fs::is_regular_file(paths.sidecar, ec)) return false;
  for (const fs::path& p : files) {
    if (!fs::is_regular_file(p, ec)) return false;
  }
  try {
    *sidecar = io::ReadJson(paths.sidecar);
  } catch (const InputError&) {
    return false;
  }
  // A sidecar damaged in any way the batch would read is no record of a complete pair: the
  // pair is redone (a value of another type ended the whole batch with a JSON type error).
  const json& j = *sidecar;
  if (!j.is_object() || !j.contains("format") || !j["format"].is_string() || j["format"] != kSidecarFormat ||
      !j.contains("options") || j["options"] != options || !j.contains("result") || !j["result"].is_object() ||
      (j.contains("file_bytes") && !j["file_bytes"].is_object())) {
    return false;
  }
  const json& result = j["result"];
  for (const char* count : {"pixels_evaluated", "pixels_accepted", "points"}) {
    if (result.contains(count) && !result[count].is_number_unsigned()) return false;
  }
  if (result.contains("bit_depth") &&
      !(result["bit_depth"].is_number_integer() && result["bit_depth"] >= 1 && result["bit_depth"] <= 32)) {
    return false;
  }
  // Every output has the size it was written with (a file cut or replaced since is redone).
  const json sizes = j.value("file_bytes", json::object());
  for (const fs::path& p : files) {
    const auto it = sizes.find(OutputKey(p));
    if (it == sizes.end() || !it->is_number_unsigned() || it->get<std::uintmax_t>() != fs::file_size(p, ec) || ec) {
      return false;
    }
  }
  return true;
}

namespace {


// The byte sizes of a pair's written outputs, by OutputKey, for --resume's check.
json FileSizes(const std::vector<fs::path>& files) {
  json sizes = json::object();
  for (const fs::path& p : files) sizes[OutputKey(p)] = static_cast<std::uintmax_t>(fs::file_size(p));
  return sizes;
}

struct PairTimings {
  double read_s = 0, match_s = 0, write_s = 0, xyz_s = 0;
  /// Every stage in the order it ran (the matcher's prefixed "match: "); the writers that run
  /// side by side each with its own wall time.
  util::StageTimes stages;
};

// Runs `fn` and adds its wall time to `stages` as `name`.
template <typename Fn>
void Timed(util::StageTimes* stages, const char* name, Fn&& fn) {
  util::Timer timer;
  fn();
  stages->emplace_back(name, timer.ElapsedSeconds());
}

// The 8-bit grey levels of the reference image, for the point cloud's colour.
cv::Mat Grey8(const cv::Mat& image) {
  if (image.depth() == CV_8U) return image;
  cv::Mat grey;
  image.convertTo(grey, CV_8U, 255.0 / 65535.0);
  return grey;
}

// Triangulates the pair's disparity map and writes the enabled geometry outputs; returns their
// description for the sidecar and adds the number of points to `result`.
json WriteGeometry(const BatchOptions& options, const std::string& stem, const NccResult& match,
                   const cv::Mat& reference_image, const PairOutputPaths& out, json* result, util::StageTimes* stages) {
  const calib::StereoRig& rig = *options.rig;
  const calib::ReferenceImage reference = options.matcher.reference;
  cv::Mat xyz;
  Timed(stages, "triangulate", [&] { xyz = calib::TriangulateDisparity(rig, match.disparity_px, reference); });
  const std::map<std::string, std::string> attributes = {
      {"lunarnav:quantity", "XYZ"},  {"lunarnav:channels", "R=X G=Y B=Z"},
      {"lunarnav:units", "m"},       {"lunarnav:frame", kVehicleFrame},
      {"lunarnav:reference", ToString(reference)}, {"lunarnav:invalid", "NaN"},
      {"lunarnav:stem", stem}};
  Timed(stages, "write xyz (EXR)", [&] { io::WriteExrAtomic(out.xyz, xyz, {}, attributes); });
  const int points = cv::countNonZero(match.disparity_px == match.disparity_px);  // not NaN
  json j;
  j["xyz"] = {{"file", fs::relative(out.xyz, out.sidecar.parent_path()).string()},
              {"dtype", "float32"},
              {"channels", {"X", "Y", "Z"}},
              {"units", "m"},
              {"frame", kVehicleFrame},
              {"invalid", "NaN"}};
  std::int64_t finite_points = 0;
  for (int y = 0; y < xyz.rows; ++y) {
    const cv::Vec3f* row = xyz.ptr<cv::Vec3f>(y);
    for (int x = 0; x < xyz.cols; ++x) finite_points += std::isfinite(row[x][0]) ? 1 : 0;
  }
  (*result)["points"] = finite_points;
  (*result)["disparities_beyond_infinity"] = points - finite_points;
  if (options.write_ply) {
    std::int64_t written = 0;
    Timed(stages, "write cloud (PLY)", [&] {
      written = io::WritePlyAtomic(
          out.cloud, xyz, Grey8(reference_image),
          {"lunarnav stereo-batch " + std::string(kVersion), "pair " + stem, std::string("frame ") + kVehicleFrame,
           "colour: grey level of the " + ToString(reference) + " image"});
    });
    j["cloud"] = {{"file", fs::relative(out.cloud, out.sidecar.parent_path()).string()}, {"points", written}};
  }
  if (options.xyz_sigma_px) {
    cv::Mat sigma;
    Timed(stages, "predict xyz_sigma", [&] {
      sigma = calib::PredictXyzSigma(rig, match.disparity_px, reference, *options.xyz_sigma_px);
    });
    std::map<std::string, std::string> sigma_attributes = attributes;
    sigma_attributes["lunarnav:quantity"] = "predicted XYZ error of a disparity error of sigma_d";
    sigma_attributes["lunarnav:sigma_d_px"] = std::to_string(*options.xyz_sigma_px);
    // Half floats: a predicted error needs three digits, not seven (a third of the bytes and
    // of the time of writing them).
    Timed(stages, "write xyz_sigma (EXR)", [&] {
      io::WriteExrAtomic(out.xyz_sigma, sigma, {}, sigma_attributes, io::ExrStorage::kFloat16);
    });
    j["xyz_sigma"] = {{"file", fs::relative(out.xyz_sigma, out.sidecar.parent_path()).string()},
                      {"dtype", "float16"},
                      {"channels", {"sigma_X", "sigma_Y", "sigma_Z"}},
                      {"units", "m"},
                      {"sigma_d_px", *options.xyz_sigma_px}};
  }
  return j;
}

// A pair's images, decoded and checked (as ProcessPair reads them).
struct LoadedPair {
  cv::Mat left, right;
  io::SignificantBits bits;
};

LoadedPair LoadPair(const BatchOptions& options, const PairFiles& pair, const PairWindow* window) {
  LN_CHECK_INPUT(pair.problem.empty()) << pair.problem;
  // Both images decoded at once (a lone pair has the threads to spare; a batch's pairs keep
  // them busy anyway). An unreadable file is reported as the first one that failed.
  io::SignificantBits left_bits, right_bits;
  LoadedPair p;
  cv::Mat& left = p.left;
  cv::Mat& right = p.right;
  std::exception_ptr left_error, right_error;
  tbb::parallel_invoke(
      [&] {
        try {
          left = io::ReadGreyImage(pair.left, &left_bits);
        } catch (...) {
          left_error = std::current_exception();
        }
      },
      [&] {
        try {
          right = io::ReadGreyImage(pair.right, &right_bits);
        } catch (...) {
          right_error = std::current_exception();
        }
      });
  if (left_error) std::rethrow_exception(left_error);
  if (right_error) std::rethrow_exception(right_error);
  // The grey levels' depth: --bit-depth, else what the files say (the deeper of the two), and for
  // 16-bit files that say nothing, what the data say (io::InferSignificantBits).
  io::SignificantBits& bits = p.bits;
  bits = left_bits.bits >= right_bits.bits ? left_bits : right_bits;
  if (options.matcher.bit_depth > 0) {
    bits = {options.matcher.bit_depth, "--bit-depth"};
  } else {
    bits = io::InferSignificantBits(left, right, bits);  // 16-bit files that declare nothing
  }
  if (auto bad = CheckFrame(options.frame_check, left, bits.bits)) {
    throw InputError(pair.left.string() + ": " + *bad);
  }
  if (auto bad = CheckFrame(options.frame_check, right, bits.bits)) {
    throw InputError(pair.right.string() + ": " + *bad);
  }
  LN_CHECK_INPUT(left.size() == right.size())
      << pair.right.string() << ": size " << right.cols << "x" << right.rows
      << " differs from the left image's " << left.cols << "x" << left.rows;
  LN_CHECK_INPUT(left.depth() == right.depth())
      << pair.right.string() << ": bit depth differs from the left image's";
  if (options.rig) {
    const calib::RectifiedGeometry& g = *options.rig->rectified;
    LN_CHECK_INPUT(left.cols == g.width_px && left.rows == g.height_px)
        << pair.left.string() << ": size " << left.cols << "x" << left.rows
        << " differs from the rig's rectified size " << g.width_px << "x" << g.height_px << " ("
        << options.rig_source << ")";
  }
  // A --rows band that misses the images entirely is a mistake in the options (exit 2), not
  // in the data: nothing would be evaluated.
  LN_CHECK_ARG(window != nullptr || !options.matcher.min_row || *options.matcher.min_row < left.rows)
      << "rows: " << *options.matcher.min_row << ":" << *options.matcher.max_row << " lies outside the images' "
      << left.rows << " rows (0:" << left.rows - 1 << ")";
  return p;
}

// The matcher's options for one pair: its window's rows and range (and per-row bands).
NccOptions PairMatcher(const BatchOptions& options, const PairWindow* window,
                       const std::vector<float>& ground_disparity_px, int bits) {
  NccOptions matcher = options.matcher;
  matcher.num_threads = 0;  // the batch's arena
  matcher.bit_depth = bits;
  if (window != nullptr) {  // window selection: the band replaces the rows and range
    matcher.min_row = window->window.min_row;
    matcher.max_row = window->window.max_row;
    matcher.min_disparity_px = window->window.min_disparity_px;
    matcher.max_disparity_px = window->window.max_disparity_px;
    // Semi-global matching searches each row's own band (docs/stereo-batch.md).
    if (matcher.aggregation == Aggregation::kSemiGlobal && !window->row_disparity_px.empty()) {
      matcher.row_disparity_px = window->row_disparity_px;
      matcher.row_accept_min_px = window->row_accept_min_px;
      matcher.row_accept_max_px = window->row_accept_max_px;
      matcher.row_ground_disparity_px = ground_disparity_px;
      matcher.min_disparity_px = window->guard_min_disparity_px;
      matcher.max_disparity_px = std::max(matcher.max_disparity_px, window->guard_max_disparity_px);
    }
  }
  return matcher;
}

// Reads, screens (resamples by `vertical` when given) and matches one pair and writes its
// outputs. Throws InputError for a bad pair.
json ProcessPair(const BatchOptions& options, const PairFiles& pair, const PairOutputPaths& out,
                 const json& options_json, const PairWindow* window, const std::vector<float>& ground_disparity_px,
                 const VerticalResampler* vertical, NccResult* result, PairTimings* timings) {
  util::Timer timer;
  LoadedPair loaded = LoadPair(options, pair, window);
  cv::Mat& left = loaded.left;
  cv::Mat& right = loaded.right;
  const io::SignificantBits& bits = loaded.bits;
  timings->read_s = timer.ElapsedSeconds();
  timings->stages.emplace_back("decode and check", timings->read_s);
  if (vertical != nullptr) {
    LN_CHECK_INPUT(left.size() == vertical->size())
        << pair.left.string() << ": size " << left.cols << "x" << left.rows << " differs from the vertical alignment's "
        << vertical->size().width << "x" << vertical->size().height
        << (options.vertical_source.empty() ? std::string() : " (" + options.vertical_source + ")");
    timer.Restart();
    vertical->Apply(&left, &right);
    const double resample_s = timer.ElapsedSeconds();
    timings->read_s += resample_s;
    timings->stages.emplace_back("vertical alignment (resample)", resample_s);
  }
  timer.Restart();
  const NccOptions matcher = PairMatcher(options, window, ground_disparity_px, bits.bits);
  MatchStereoPair(matcher, left, right, result);
  timings->match_s = timer.ElapsedSeconds();
  for (const auto& [stage, seconds] : result->summary.stage_seconds) timings->stages.emplace_back("match: " + stage, seconds);

  timer.Restart();
  // The maps are encoded and written side by side, each timed on its own.
  std::array<util::StageTimes, 4> written;
  tbb::parallel_invoke(
      [&] {
        Timed(&written[0], "write disparity (PFM)", [&] {
          cv::Mat disparity_pfm = result->disparity_px.clone();
          cv::patchNaNs(disparity_pfm, std::numeric_limits<double>::infinity());
          io::WriteImageAtomic(out.disparity, disparity_pfm);
        });
      },
      [&] { Timed(&written[1], "write confidence (TIFF)", [&] { io::WriteImageAtomic(out.confidence, result->correlation); }); },
      [&] { Timed(&written[2], "write rejections (PNG)", [&] { io::WriteLabelImageAtomic(out.rejections, result->rejection); }); },
      [&] {
        if (!options.write_preview) return;
        Timed(&written[3], "write preview (PNG)", [&] {
          const cv::Mat& reference = options.matcher.reference == ReferenceImage::kRight ? right : left;
          io::WriteImageAtomic(out.preview, DisparityPreview(*result, reference, bits.bits, matcher.step_x_px,
                                                             matcher.step_y_px, matcher.min_disparity_px,
                                                             matcher.max_disparity_px));
        });
      });
  timings->write_s = timer.ElapsedSeconds();
  for (const util::StageTimes& w : written) timings->stages.insert(timings->stages.end(), w.begin(), w.end());

  json result_extra;
  json geometry;
  if (options.rig) {
    timer.Restart();
    geometry = WriteGeometry(options, pair.stem, *result,
                             options.matcher.reference == ReferenceImage::kRight ? right : left, out, &result_extra,
                             &timings->stages);
    timings->xyz_s = timer.ElapsedSeconds();
  }

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
  if (options.rig) sidecar["geometry"] = geometry;
  if (options.write_preview) {
    sidecar["preview"] = {{"file", fs::relative(out.preview, out.sidecar.parent_path()).string()},
                          {"meaning", "disparity colour-mapped (Turbo) over the searched range; rejected pixels "
                                      "in their reason's colour; legend below the image"}};
  }
  sidecar["options"] = options_json;
  sidecar["result"] = result->summary.ToJson();
  if (window != nullptr) sidecar["result"]["window"] = window->ToJson();
  sidecar["result"]["bit_depth_source"] = bits.source;
  if (!result_extra.is_null()) sidecar["result"].update(result_extra);
  sidecar["result"]["timings_ms"] = {{"read", 1e3 * timings->read_s},
                                     {"match", 1e3 * timings->match_s},
                                     {"write", 1e3 * timings->write_s}};
  if (options.rig) sidecar["result"]["timings_ms"]["xyz"] = 1e3 * timings->xyz_s;
  sidecar["file_bytes"] = FileSizes(EnabledOutputs(options, out));
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
  LN_CHECK_ARG(rig || (!write_ply && !xyz_sigma_px && !region && requests.empty() && attitudes.empty()))
      << "ply, xyz-sigma, range-y, requests and poses need the rig (--rig RIG.json)";
  for (const auto& [stem, a] : attitudes) {
    LN_CHECK_ARG(std::abs(a.pitch_deg) < 90 && std::abs(a.roll_deg) < 90)
        << attitudes_source << ": stem " << stem << ": pitch and roll must be in (-90, 90) deg, got "
        << a.pitch_deg << ", " << a.roll_deg;
  }
  if (!rig) return;
  LN_CHECK_ARG(rig->rectified.has_value())
      << (rig_source.empty() ? std::string("rig") : rig_source)
      << ": the rig has no rectified geometry; triangulation and window selection need the rectified rig "
         "(the rig.json that rectify writes next to the rectified images)";
  if (xyz_sigma_px) {
    LN_CHECK_ARG(std::isfinite(*xyz_sigma_px) && *xyz_sigma_px > 0)
        << "xyz-sigma: the disparity error must be > 0 px, got " << *xyz_sigma_px;
  }
  window_selection.Validate();
  if (region) {
    region->Validate();
    const calib::ImageWindow w = calib::SelectWindow(*rig, *region, matcher.reference, window_selection);
    LN_CHECK_ARG(w.visible) << "range-y: no point with Y in [" << region->y_min_m << ", " << region->y_max_m
                            << "] m and Z in [" << region->z_min_m << ", " << region->z_max_m
                            << "] m is seen by the " << ToString(matcher.reference) << " camera";
  }
}

std::string ToString(BatchOptions::VerticalAlignment mode) {
  switch (mode) {
    case BatchOptions::VerticalAlignment::kAuto: return "auto";
    case BatchOptions::VerticalAlignment::kGiven: return "file";
    case BatchOptions::VerticalAlignment::kOff: break;
  }
  return "off";
}

std::optional<VerticalMisalignment> ReadMeasuredVerticalAlignment(const fs::path& summary) {
  const json j = io::ReadJson(summary);
  const std::string source = summary.string();
  LN_CHECK_INPUT(j.is_object() && j.contains("vertical_alignment") && j["vertical_alignment"].is_object())
      << source << ": no vertical_alignment (a stereo-batch summary.json of a run with --vertical-alignment auto)";
  const json& v = j["vertical_alignment"];
  LN_CHECK_INPUT(v.contains("applied") && v["applied"].is_boolean())
      << source << ": vertical_alignment: no applied (true or false)";
  if (!v["applied"].get<bool>()) return std::nullopt;
  LN_CHECK_INPUT(v.contains("misalignment")) << source << ": vertical_alignment: applied, but no misalignment";
  return VerticalMisalignment::FromJson(v["misalignment"], source + ": vertical_alignment.misalignment");
}

BatchOptions::VerticalAlignment VerticalAlignmentFromString(const std::string& text) {
  if (text == "auto") return BatchOptions::VerticalAlignment::kAuto;
  LN_CHECK_ARG(text == "off") << "vertical-alignment: auto or off, got '" << text << "'";
  return BatchOptions::VerticalAlignment::kOff;
}

json BatchOptions::ToJson() const {
  json j = matcher.ToJson();
  j["vertical_alignment"] = ToString(vertical_alignment);
  j["frame_check"] = frame_check.ToJson();
  if (rig) {
    // The rig itself, not its file name: resuming with another rig redoes the pairs.
    j["geometry"] = {{"rig", calib::StereoRigToJson(*rig)},
                     {"ply", write_ply},
                     {"xyz_sigma_d_px", xyz_sigma_px ? json(*xyz_sigma_px) : json(nullptr)}};
    if (region || ground || !requests.empty()) {
      j["window_selection"] = {{"range", region ? region->ToJson() : json(nullptr)},
                               {"from_rig", ground && !region ? ground->region.ToJson() : json(nullptr)},
                               {"requests", requests.empty() ? json(nullptr) : json(requests_source)},
                               {"requests_z_m", {requests_region.z_min_m, requests_region.z_max_m}},
                               {"attitudes", attitudes.empty() ? json(nullptr) : json(attitudes_source)},
                               {"disparity_margin_px", window_selection.disparity_margin_px}};
    }
  }
  return j;
}

PairOutputPaths OutputPathsFor(const fs::path& output_dir, const std::string& stem) {
  return {output_dir / "disparity" / (stem + ".pfm"), output_dir / "confidence" / (stem + ".tif"),
          output_dir / "rejections" / (stem + ".png"), output_dir / "disparity" / (stem + ".json"),
          output_dir / "xyz" / (stem + ".exr"),        output_dir / "cloud" / (stem + ".ply"),
          output_dir / "xyz_sigma" / (stem + ".exr"), output_dir / "preview" / (stem + ".png")};
}

std::string SummaryFileName(const BatchOptions& options) {
  return io::SummaryFileName(options.shard_index, options.shard_count);
}

std::optional<calib::ReferenceImage> ReadRunReference(const fs::path& output_dir, std::string* problem) {
  const fs::path path = output_dir / "summary.json";
  std::error_code ec;
  std::string why;
  if (!fs::is_regular_file(path, ec)) {
    why = path.string() + ": no such file";
  } else {
    try {  // bounded in size and values
      return calib::ReferenceImageFromString(io::ReadJson(path).at("options").at("reference").get<std::string>());
    } catch (const std::exception& e) {  // not stereo-batch's, or damaged
      why = path.string() + ": records no reference image that can be read (" + e.what() + ")";
    }
  }
  if (problem != nullptr) *problem = why;
  return std::nullopt;
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

// The state of a run: the listing, the windows, the outcomes so far.
struct StereoBatchRun::Impl {
  BatchOptions options;
  fs::path input_dir, output_dir;
  util::Timer total_timer;
  std::vector<PairFiles> listing;
  std::vector<const PairFiles*> shard;
  std::vector<PairFiles> shard_pairs;
  std::map<std::string, PairWindow> requested;
  std::optional<PairWindow> range_window;
  std::vector<std::string> subdirectories;
  json options_json;
  std::vector<PairOutcome> outcomes;
  std::vector<char> processed;
  std::vector<PairTimings> timings;
  tbb::enumerable_thread_specific<NccResult> results;  // reused buffers, one per thread

  std::map<std::string, PairWindow> attitude_windows;  // the rig default of pairs with an attitude
  // The ground's disparity per row of the reference image (calib::GroundDisparityByRow: the
  // rig's alone, the same for every pair and attitude), for the aggregation's row steps.
  std::vector<float> ground_disparity_px;
  // The pairs' vertical misalignment (BatchOptions::vertical_alignment): the resampler when it
  // is taken out, and what was measured (the summary's vertical_alignment).
  std::optional<VerticalResampler> vertical;
  json vertical_json;
  double vertical_seconds = 0;

  void MeasureVerticalAlignment();

  const PairWindow* WindowFor(const std::string& stem) const {
    if (const auto it = requested.find(stem); it != requested.end()) return &it->second;
    if (const auto it = attitude_windows.find(stem); it != attitude_windows.end()) return &it->second;
    return range_window ? &*range_window : nullptr;
  }

  // Window selection for one pair: with its attitude when the poses give one.
  calib::WindowSelectionOptions SelectionFor(const std::string& stem) const {
    calib::WindowSelectionOptions s = options.window_selection;
    if (const auto it = options.attitudes.find(stem); it != options.attitudes.end()) {
      s.vehicle_pitch_deg = it->second.pitch_deg;
      s.vehicle_roll_deg = it->second.roll_deg;
    }
    return s;
  }
  std::optional<VehicleAttitude> AttitudeOf(const std::string& stem) const {
    const auto it = options.attitudes.find(stem);
    return it == options.attitudes.end() ? std::nullopt : std::optional<VehicleAttitude>(it->second);
  }

  // The rig's default window of a pair with an attitude; the level one when the cameras of so
  // tilted a vehicle see no ground (with a warning).
  PairWindow AttitudeWindow(const std::string& stem) const {
    try {
      PairWindow w = PairWindow::FromGround(calib::SelectGroundWindow(
          *options.rig, options.matcher.reference, options.ground->options, SelectionFor(stem)));
      w.attitude = AttitudeOf(stem);
      return w;
    } catch (const std::invalid_argument& e) {
      LN_LOG(Warning) << options.attitudes_source << ": stem " << stem << ": at pitch "
                      << options.attitudes.at(stem).pitch_deg << " deg, roll " << options.attitudes.at(stem).roll_deg
                      << " deg the cameras see no ground; the pair searches as a level vehicle (" << e.what() << ")";
      return *range_window;
    }
  }

  // The --range-y window of a pair with an attitude (the interval in the level frame, as a
  // request's); the level one when that vehicle's cameras see none of it (with a warning).
  PairWindow RangeAttitudeWindow(const std::string& stem) const {
    PairWindow w = *range_window;
    w.attitude = AttitudeOf(stem);
    w.window = calib::SelectWindow(*options.rig, w.region, options.matcher.reference, SelectionFor(stem));
    if (w.window.visible) return w;
    LN_LOG(Warning) << options.attitudes_source << ": stem " << stem << ": at pitch "
                    << options.attitudes.at(stem).pitch_deg << " deg, roll " << options.attitudes.at(stem).roll_deg
                    << " deg the cameras see none of --range-y; the pair searches as a level vehicle";
    return *range_window;
  }

  // The window of one request (a request the camera cannot see is bad input, named by its line).
  PairWindow RequestWindow(const WindowRequest& r) const {
    PairWindow w;
    w.source = "requests";
    w.region = options.requests_region;
    w.region.y_min_m = r.y_min_m;
    w.region.y_max_m = r.y_max_m;
    w.request_line = r.line;
    w.attitude = AttitudeOf(r.stem);
    const calib::WindowSelectionOptions selection = SelectionFor(r.stem);
    w.window = calib::SelectWindow(*options.rig, w.region, options.matcher.reference, selection);
    LN_CHECK_INPUT(w.window.visible)
        << options.requests_source << ":" << r.line << ": no point with Y in [" << r.y_min_m << ", " << r.y_max_m
        << "] m and Z in [" << w.region.z_min_m << ", " << w.region.z_max_m << "] m is seen by the "
        << ToString(options.matcher.reference) << " camera";
    if (options.ground) {
      // Per-row bands with the far guard, as the rig's default has them, and a near guard: in
      // the requested rows the ground beyond the interval (the top rows) or below the heights,
      // and the ground nearer than it (the lower rows), would otherwise be matched inside the
      // one range: points in the air, or below the ground, within the interval.
      const calib::RowBands bands =
          calib::SelectRowBands(*options.rig, options.matcher.reference, w.region, w.window,
                                options.ground->guard_distance_factor, options.ground->guard_tilt_deg,
                                options.ground->guard_distance_factor, selection, options.ground->options.tall_guard_m);
      w.row_disparity_px = bands.row_disparity_px;
      w.row_accept_min_px = bands.row_accept_min_px;
      w.row_accept_max_px = bands.row_accept_max_px;
      w.guard_min_disparity_px = bands.guard_min_disparity_px;
      w.guard_max_disparity_px = bands.guard_max_disparity_px;
    }
    return w;
  }
};

StereoBatchRun::StereoBatchRun(const BatchOptions& options, const fs::path& input_dir, const fs::path& output_dir)
    : impl_(std::make_unique<Impl>()) {
  options.Validate();
  Impl& run = *impl_;
  run.options = options;
  run.input_dir = input_dir;
  run.output_dir = output_dir;
  run.listing = ListStereoPairs(input_dir);
  LN_CHECK_INPUT(!run.listing.empty())
      << input_dir.string() << ": no image pairs in left/ and right/ (PNG, PGM, TIFF or JPEG)";
  run.shard = io::SelectShard(run.listing, options.shard_index, options.shard_count);
  for (const PairFiles* p : run.shard) run.shard_pairs.push_back(*p);

  // Window selection: each requested pair's window, and the window of every other pair when a
  // range is given.
  for (const WindowRequest& r : options.requests) run.requested.emplace(r.stem, run.RequestWindow(r));
  if (!options.requests.empty()) {
    int unknown = 0;
    std::string example;
    for (const auto& entry : run.requested) {
      const std::string& stem = entry.first;  // not a structured binding: clang 14 cannot capture one
      const bool listed =
          std::any_of(run.listing.begin(), run.listing.end(), [&](const PairFiles& p) { return p.stem == stem; });
      if (!listed && unknown++ == 0) example = stem;
    }
    if (unknown > 0) {
      LN_LOG(Warning) << options.requests_source << ": " << unknown << " requested stem"
                      << (unknown == 1 ? "" : "s") << " (e.g. '" << example << "') not among the pairs of "
                      << input_dir.string();
    }
  }
  if (options.region) {
    run.range_window.emplace();
    run.range_window->source = "range-y";
    run.range_window->region = *options.region;
    run.range_window->window =
        calib::SelectWindow(*options.rig, *options.region, options.matcher.reference, options.window_selection);
  } else if (options.ground) {
    run.range_window = PairWindow::FromGround(*options.ground);
  }
  if (options.rig && options.matcher.aggregation == Aggregation::kSemiGlobal) {
    run.ground_disparity_px = calib::GroundDisparityByRow(*options.rig, options.matcher.reference);
  }
  if (run.range_window && !options.attitudes.empty()) {
    // A pair with an attitude searches the ground (the rig's default, or --range-y's interval)
    // where its vehicle's attitude puts it (10-20 ms a pair for the paper's rig: made in parallel).
    std::vector<std::string> stems;
    for (const PairFiles& p : run.shard_pairs) {
      if (options.attitudes.count(p.stem) > 0) stems.push_back(p.stem);
    }
    std::vector<PairWindow> windows(stems.size());
    util::ParallelForEachItem(stems.size(), options.num_threads, [&](std::size_t k) {
      windows[k] = options.region ? run.RangeAttitudeWindow(stems[k]) : run.AttitudeWindow(stems[k]);
    });
    for (std::size_t k = 0; k < stems.size(); ++k) run.attitude_windows.emplace(stems[k], std::move(windows[k]));
  }

  run.subdirectories = {"disparity", "confidence", "rejections"};
  if (options.rig) run.subdirectories.push_back("xyz");
  if (options.write_ply) run.subdirectories.push_back("cloud");
  if (options.xyz_sigma_px) run.subdirectories.push_back("xyz_sigma");
  if (options.write_preview) run.subdirectories.push_back("preview");
  for (const std::string& sub : run.subdirectories) {
    io::CreateOutputDirectory(output_dir / sub);
    io::RemoveStaleTempFiles(output_dir / sub);
  }
  io::RemoveStaleTempFiles(output_dir);
  run.options_json = options.ToJson();
  run.outcomes.resize(run.shard.size());
  run.processed.assign(run.shard.size(), 0);
  run.timings.resize(run.shard.size());
  if (options.vertical_alignment == BatchOptions::VerticalAlignment::kGiven) {
    // Another run's measurement (the shards of a cluster run): the same record, not measured.
    const std::optional<VerticalMisalignment>& m = options.vertical_given;
    run.vertical_json = {{"mode", "file"}, {"source", options.vertical_source}, {"applied", m.has_value()}};
    if (m) {
      if (options.rig) {
        const calib::RectifiedGeometry& g = *options.rig->rectified;
        LN_CHECK_INPUT(m->width_px == g.width_px && m->height_px == g.height_px)
            << options.vertical_source << ": a misalignment of " << m->width_px << "x" << m->height_px
            << " images, the rig's are " << g.width_px << "x" << g.height_px << " (" << options.rig_source << ")";
      }
      run.vertical_json["misalignment"] = m->ToJson();
      run.vertical_json["max_abs_offset_px"] = m->MaxAbsOffsetPx();
      run.vertical.emplace(*m, options.matcher.reference);
    }
    run.options_json["vertical_alignment_applied"] = m ? run.vertical_json["misalignment"] : json(nullptr);
  }
  if (options.vertical_alignment == BatchOptions::VerticalAlignment::kAuto) {
    run.MeasureVerticalAlignment();
    // The resampling changes every pair's outputs: resuming redoes pairs made with another.
    run.options_json["vertical_alignment_applied"] = run.vertical_json.value("applied", false)
                                                         ? run.vertical_json["misalignment"]
                                                         : json(nullptr);
  }
}

// Matches up to kVerticalSamplePairs pairs spread over the whole listing (a shard's own pairs
// would give each shard its own resampling), measures their rows' offsets and fits the surface;
// then again over pairs resampled by the sum so far, for what the fits left (the matches of
// misaligned rows lean towards the offset, so a round finds a part of it), until a round finds
// less than kMinVerticalResidualPx where it measured or kVerticalRounds have run. The first
// round decides: under kMinVerticalCorrectionPx where it measured, nothing is resampled. A pair
// that cannot be
// read is skipped here (it fails in its turn).
void StereoBatchRun::Impl::MeasureVerticalAlignment() {
  util::Timer timer;
  const std::size_t n = listing.size();
  const std::size_t k_pairs = std::clamp<std::size_t>(n / 6, 1, kVerticalSamplePairs);
  std::vector<const PairFiles*> picked;
  for (std::size_t i = 0; i < k_pairs; ++i) picked.push_back(&listing[(2 * i + 1) * n / (2 * k_pairs)]);
  vertical_json = {{"mode", "auto"}, {"applied", false}};
  json stems = json::array();
  for (const PairFiles* p : picked) stems.push_back(p->stem);
  vertical_json["pairs"] = stems;
  // The picked pairs read once for every round (none where a pair cannot be read).
  std::vector<std::optional<LoadedPair>> loaded(picked.size());
  util::ParallelForEachItem(picked.size(), options.num_threads, [&](std::size_t k) {
    try {
      loaded[k] = LoadPair(options, *picked[k], WindowFor(picked[k]->stem));
    } catch (const InputError&) {  // each such pair fails in its turn, named there
    } catch (const std::invalid_argument&) {
    }
  });
  std::optional<VerticalMisalignment> total;
  bool aligned = true;  // the first round found less than kMinVerticalCorrectionPx
  json rounds = json::array();
  for (int round = 0; round < kVerticalRounds; ++round) {
    std::optional<VerticalResampler> resampler;
    if (total) resampler.emplace(*total, options.matcher.reference);
    std::vector<std::vector<VerticalSample>> per_pair(picked.size());
    std::vector<cv::Size> sizes(picked.size());
    util::ParallelForEachItem(picked.size(), options.num_threads, [&](std::size_t k) {
      if (!loaded[k]) return;
      const PairWindow* window = WindowFor(picked[k]->stem);
      cv::Mat left = loaded[k]->left, right = loaded[k]->right;  // Apply gives them new buffers
      const int bits = loaded[k]->bits.bits;
      try {
        if (resampler) resampler->Apply(&left, &right);
        NccResult result;
        MatchStereoPair(PairMatcher(options, window, ground_disparity_px, bits), left, right, &result);
        per_pair[k] = MeasureVerticalOffsets(left, right, bits, result.disparity_px, options.matcher.step_x_px,
                                             options.matcher.step_y_px, options.matcher.reference);
        sizes[k] = left.size();
      } catch (const InputError&) {  // each such pair fails in its turn, named there
      } catch (const std::invalid_argument&) {
      } catch (const std::bad_alloc&) {
      } catch (const cv::Exception& e) {
        if (e.code != cv::Error::StsNoMem) throw;
      }
    });
    std::vector<VerticalSample> samples;
    cv::Size size;
    for (std::size_t k = 0; k < picked.size(); ++k) {
      if (per_pair[k].empty()) continue;
      if (size.area() == 0) size = sizes[k];
      if (sizes[k] != size) continue;  // the rig's size, checked in each pair's turn
      samples.insert(samples.end(), per_pair[k].begin(), per_pair[k].end());
    }
    VerticalFitReport report;
    const std::optional<VerticalMisalignment> fit =
        size.area() > 0 ? FitVerticalMisalignment(samples, size, &report) : std::nullopt;
    rounds.push_back({{"samples", report.samples},
                      {"samples_kept", report.samples_kept},
                      {"median_abs_offset_px", report.median_abs_offset_px},
                      {"residual_px", report.residual_px},
                      {"surface_p95_abs_px", report.surface_p95_abs_px},
                      {"max_abs_offset_px", fit ? json(fit->MaxAbsOffsetPx()) : json(nullptr)}});
    if (!fit) break;
    if (!total) {
      total = *fit;
      if (report.surface_p95_abs_px < kMinVerticalCorrectionPx) break;  // aligned as well as it can be measured
      aligned = false;
      continue;
    }
    if (report.surface_p95_abs_px < kMinVerticalResidualPx) break;  // what is left is the fit's own noise
    total = total->Plus(*fit);
  }
  vertical_json["rounds"] = rounds;
  vertical_seconds = timer.ElapsedSeconds();  // in timings_s (shards must agree on the rest)
  if (!total) {
    LN_LOG(Warning) << "vertical alignment: too few textured matches on the pairs " << stems.dump()
                    << " to measure the rows' misalignment (at least " << kMinVerticalSamples
                    << "); the pairs are matched as they are";
    vertical_json["note"] = "too few textured matches to measure";
    return;
  }
  const double max_abs = total->MaxAbsOffsetPx();
  vertical_json["misalignment"] = total->ToJson();
  vertical_json["max_abs_offset_px"] = max_abs;
  if (aligned) return;
  vertical_json["applied"] = true;
  vertical.emplace(*total, options.matcher.reference);
  if (max_abs > kLargeVerticalMisalignmentPx) {
    LN_LOG(Warning) << "vertical alignment: the pairs' rows lie up to " << max_abs
                    << " px apart (the same point in both images); each pair is resampled to take it out, but a "
                       "new calibration of the rig would serve better";
  }
}

StereoBatchRun::~StereoBatchRun() = default;

const std::vector<PairFiles>& StereoBatchRun::Pairs() const { return impl_->shard_pairs; }

void StereoBatchRun::Request(const WindowRequest& request) {
  LN_CHECK_ARG(impl_->options.rig.has_value()) << "window requests need a rig";
  impl_->requested.insert_or_assign(request.stem, impl_->RequestWindow(request));
}

namespace {
void FailForMemory(const PairFiles& pair, PairOutcome* outcome) {
  outcome->status = PairOutcome::Status::kFailed;
  outcome->error = pair.left.string() + ": not enough memory to match this pair (its images are too large for this "
                   "machine: --max-pixels, or a smaller --disparity range)";
  LN_LOG(Error) << "pair " << pair.stem << ": " << outcome->error;
}
}  // namespace

const PairOutcome& StereoBatchRun::Process(std::size_t k) {
  Impl& run = *impl_;
  LN_CHECK(k < run.shard.size()) << "pair index " << k << " of " << run.shard.size();
  const PairFiles& pair = *run.shard[k];
  PairOutcome& outcome = run.outcomes[k];
  outcome = PairOutcome{};
  outcome.stem = pair.stem;
  run.timings[k] = PairTimings{};
  const PairOutputPaths out = OutputPathsFor(run.output_dir, pair.stem);
  const PairWindow* window = run.WindowFor(pair.stem);
  json pair_options = run.options_json;
  if (window != nullptr) pair_options["window"] = window->ToJson();
  json sidecar;
  if (run.options.resume && OutputsComplete(run.options, out, pair_options, &sidecar)) {
    outcome.status = PairOutcome::Status::kResumed;
    outcome.result = sidecar["result"];
  } else {
    try {
      outcome.result = ProcessPair(run.options, pair, out, pair_options, window, run.ground_disparity_px,
                                   run.vertical ? &*run.vertical : nullptr, &run.results.local(), &run.timings[k]);
      outcome.status = PairOutcome::Status::kOk;
    } catch (const InputError& e) {
      outcome.status = PairOutcome::Status::kFailed;
      outcome.error = util::BoundedMessage(e.what());
      LN_LOG(Error) << "pair " << pair.stem << ": " << e.what();
    } catch (const std::bad_alloc&) {
      // One oversize pair (an 8192 x 8192 16-bit pair asked 6.4 GB) fails alone: its memory
      // is freed as the exception leaves, and the batch goes on (exit 4 at the end).
      FailForMemory(pair, &outcome);
    } catch (const cv::Exception& e) {
      if (e.code != cv::Error::StsNoMem) throw;
      FailForMemory(pair, &outcome);
    }
  }
  outcome.seconds = run.timings[k].read_s + run.timings[k].match_s + run.timings[k].write_s + run.timings[k].xyz_s;
  outcome.match_seconds = run.timings[k].match_s;
  run.processed[k] = 1;
  return outcome;
}

BatchSummary StereoBatchRun::Finish(const json& invocation) {
  Impl& run = *impl_;
  const BatchOptions& options = run.options;
  BatchSummary summary;
  summary.pairs_listed = static_cast<int>(run.listing.size());
  summary.pairs_in_shard = static_cast<int>(run.shard.size());
  json pairs_json = json::array();
  json failed_json = json::array();
  // The vertical alignment's measurement first: it ran before every pair (a stage of the run,
  // not of a pair, so that the stages still account for the process's time).
  if (options.vertical_alignment == BatchOptions::VerticalAlignment::kAuto) {
    summary.stage_seconds.emplace_back("vertical alignment (measure)", run.vertical_seconds);
  }
  for (std::size_t k = 0; k < run.shard.size(); ++k) {
    if (!run.processed[k]) continue;
    const PairOutcome& outcome = run.outcomes[k];
    summary.pairs.push_back(outcome);
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
    summary.read_seconds += run.timings[k].read_s;
    summary.match_seconds += run.timings[k].match_s;
    summary.write_seconds += run.timings[k].write_s;
    summary.xyz_seconds += run.timings[k].xyz_s;
    util::AddStages(run.timings[k].stages, &summary.stage_seconds);
    if (outcome.status != PairOutcome::Status::kFailed) {
      summary.points += outcome.result.value("points", 0LL);
    }
    pairs_json.push_back(std::move(entry));
  }
  summary.seconds = run.total_timer.ElapsedSeconds();
  // The grey levels' depth of each pair: one batch is one camera, so pairs that differ (a
  // depth told from the data of some, an sBIT in others) are worth a warning.
  std::map<int, std::vector<std::string>> depths;
  for (const PairOutcome& outcome : summary.pairs) {
    if (outcome.status != PairOutcome::Status::kFailed && outcome.result.contains("bit_depth")) {
      depths[outcome.result["bit_depth"].get<int>()].push_back(outcome.stem);
    }
  }
  json depths_json = json::object();
  for (const auto& [bits, stems] : depths) depths_json[std::to_string(bits)] = stems.size();
  if (depths.size() > 1) {
    std::ostringstream s;
    for (const auto& [bits, stems] : depths) {
      s << (s.tellp() > 0 ? ", " : "") << bits << " bits (" << stems.size() << " pair" << (stems.size() == 1 ? "" : "s")
        << ", e.g. " << stems.front() << ")";
    }
    LN_LOG(Warning) << "the pairs' grey levels have different depths: " << s.str()
                    << "; their thresholds differ (each sidecar's result.bit_depth_source says why; --bit-depth sets one)";
  }

  json j = util::SummaryHead("stereo-batch", invocation);
  j["input_dir"] = run.input_dir.string();
  j["output_dir"] = run.output_dir.string();
  j["listing"] = io::ListingRecord("stereo-pairs", "pairs", io::PairStems(run.listing));  // shard-merge's check
  j["options"] = run.options_json;
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
  // Per stage, summed over the pairs, in the order the stages ran (docs/performance.md's
  // profile): wall seconds of each, the writers that run side by side each on its own.
  json stages = json::array();
  for (const auto& [stage, seconds] : summary.stage_seconds) stages.push_back({{"stage", stage}, {"seconds", seconds}});
  j["timings_s"]["stages_sum"] = std::move(stages);
  if (options.rig) {
    j["counts"]["points"] = summary.points;
    j["timings_s"]["xyz_sum"] = summary.xyz_seconds;
    j["geometry"] = {{"rig_file", options.rig_source},
                     {"rig_notes", options.rig->notes},  // what reading the rig changed (printed precision)
                     {"frame", kVehicleFrame},
                     {"outputs", run.subdirectories}};
    if (options.region) j["geometry"]["window_range_y"] = run.range_window->ToJson();
    if (options.ground && !options.region) {
      // stereo-batch's default with a rig: what the rig sees, and why (docs/stereo-batch.md).
      j["geometry"]["window_from_rig"] = options.ground->ToJson();
    }
    if (!run.requested.empty()) {
      j["geometry"]["requests"] = {{"file", options.requests_source}, {"count", run.requested.size()}};
    }
  }
  if (!run.vertical_json.is_null()) {
    j["vertical_alignment"] = run.vertical_json;
    if (options.vertical_alignment == BatchOptions::VerticalAlignment::kAuto) {
      j["timings_s"]["vertical_alignment"] = run.vertical_seconds;
    }
  }
  j["bit_depths"] = depths_json;
  j["peak_memory_mib"] = util::PeakResidentMemoryMiB();
  j["failed"] = failed_json;
  j["pairs"] = pairs_json;
  summary.summary_path = run.output_dir / SummaryFileName(options);
  io::WriteJsonAtomic(summary.summary_path, j);
  return summary;
}

void CheckRigAgainstPairs(const calib::StereoRig& rig, const std::string& rig_source,
                          const std::filesystem::path& input_dir) {
  if (!rig.rectified) return;
  for (const io::PairFiles& pair : io::ListStereoPairs(input_dir)) {
    if (!pair.problem.empty()) continue;
    cv::Mat left;
    try {
      left = io::ReadGreyImage(pair.left);
    } catch (const InputError&) {
      continue;  // the pair's own failure, reported in its turn
    }
    const calib::RectifiedGeometry& g = *rig.rectified;
    LN_CHECK_INPUT(left.cols == g.width_px && left.rows == g.height_px)
        << rig_source << ": declares rectified images of " << g.width_px << "x" << g.height_px << ", but "
        << pair.left.string() << " is " << left.cols << "x" << left.rows << " (the rig of other images?)";
    return;
  }
}

BatchSummary RunStereoBatch(const BatchOptions& options, const fs::path& input_dir, const fs::path& output_dir,
                            const json& invocation) {
  StereoBatchRun run(options, input_dir, output_dir);
  const std::size_t n = run.Pairs().size();
  util::ProgressBar progress(n, "stereo-batch", options.show_progress);
  util::ParallelForEachItem(n, options.num_threads, [&](std::size_t k) {
    run.Process(k);
    progress.Increment();
  });
  return run.Finish(invocation);
}

}  // namespace lunarnav::stereo
