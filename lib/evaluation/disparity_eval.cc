#include "evaluation/disparity_eval.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <sstream>

#include "io/atomic_file.h"
#include "io/image_io.h"
#include "io/json_io.h"
#include "util/check.h"
#include "util/errors.h"
#include "util/log.h"
#include "util/timer.h"

namespace lunarnav::evaluation {
namespace fs = std::filesystem;

namespace {

std::string FormatThreshold(double t) {
  std::ostringstream s;
  s << t;
  return s.str();
}

// stem -> files with one of `extensions` in `dir`.
std::map<std::string, std::vector<fs::path>> FilesByStem(const fs::path& dir,
                                                        const std::vector<std::string>& extensions) {
  std::map<std::string, std::vector<fs::path>> by_stem;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const fs::path& path = entry.path();
    const std::string name = path.filename().string();
    if (name.empty() || name[0] == '.' || !entry.is_regular_file(ec)) continue;
    for (const std::string& ext : extensions) {
      if (path.extension() == ext) by_stem[path.stem().string()].push_back(path);
    }
  }
  LN_CHECK_INPUT(!ec) << dir.string() << ": cannot list (" << ec.message() << ")";
  return by_stem;
}

}  // namespace

SampleGrid ReadSampleGrid(const fs::path& estimate) {
  fs::path sidecar = estimate;
  sidecar.replace_extension(".json");
  SampleGrid grid;
  std::error_code ec;
  if (!fs::is_regular_file(sidecar, ec)) return grid;
  const nlohmann::json j = io::ReadJson(sidecar);
  try {
    const auto& g = j.at("disparity").at("grid");
    grid.origin_x = g.at("origin_px").at(0).get<int>();
    grid.origin_y = g.at("origin_px").at(1).get<int>();
    grid.step_x = g.at("step_px").at(0).get<int>();
    grid.step_y = g.at("step_px").at(1).get<int>();
    // The band the matcher processed: the pair's window (window selection: --range-y or
    // --requests) when it has one, else --rows.
    const auto& options = j.at("options");
    const nlohmann::json& rows = options.contains("window") && options.at("window").contains("rows")
                                     ? options.at("window").at("rows")
                                     : options.at("rows");
    if (!rows.is_null()) {
      grid.min_row = rows.at(0).get<int>();
      grid.max_row = rows.at(1).get<int>();
    }
  } catch (const nlohmann::json::exception& e) {
    throw InputError(sidecar.string() + ": no usable disparity.grid, options.window.rows or options.rows (" +
                     e.what() + ")");
  }
  LN_CHECK_INPUT(grid.step_x >= 1 && grid.step_y >= 1 && grid.origin_x >= 0 && grid.origin_y >= 0)
      << sidecar.string() << ": impossible disparity.grid";
  return grid;
}

void DisparityEvalOptions::Validate() const {
  LN_CHECK_ARG(!bad_thresholds_px.empty()) << "bad thresholds: need at least one";
  for (double t : bad_thresholds_px) LN_CHECK_ARG(t > 0) << "bad thresholds: must be > 0, got " << t;
  LN_CHECK_ARG(png_truth_scale > 0) << "PNG truth scale: must be > 0";
  LN_CHECK_ARG(mask_min_value >= 1 && mask_min_value <= 255) << "mask-min: must be in 1..255, got " << mask_min_value;
}

void DisparityScores::Add(const DisparityScores& other) {
  if (bad.size() < other.bad.size()) bad.resize(other.bad.size(), 0);
  truth_pixels += other.truth_pixels;
  estimated_pixels += other.estimated_pixels;
  for (std::size_t k = 0; k < other.bad.size(); ++k) bad[k] += other.bad[k];
  d1_outliers += other.d1_outliers;
  sum_abs_error_px += other.sum_abs_error_px;
  sum_squared_error_px2 += other.sum_squared_error_px2;
  if (signed_error_bins.size() < other.signed_error_bins.size()) {
    signed_error_bins.resize(other.signed_error_bins.size(), 0);
  }
  for (std::size_t k = 0; k < other.signed_error_bins.size(); ++k) signed_error_bins[k] += other.signed_error_bins[k];
}

double DisparityScores::DensityPct() const {
  return truth_pixels > 0 ? 100.0 * static_cast<double>(estimated_pixels) / truth_pixels : NAN;
}
double DisparityScores::BadPct(std::size_t k) const {
  return estimated_pixels > 0 ? 100.0 * static_cast<double>(bad.at(k)) / estimated_pixels : NAN;
}
double DisparityScores::BadOrMissingPct(std::size_t k) const {
  return truth_pixels > 0
             ? 100.0 * static_cast<double>(bad.at(k) + truth_pixels - estimated_pixels) / truth_pixels
             : NAN;
}
double DisparityScores::D1Pct() const {
  return estimated_pixels > 0 ? 100.0 * static_cast<double>(d1_outliers) / estimated_pixels : NAN;
}
double DisparityScores::D1OrMissingPct() const {
  return truth_pixels > 0
             ? 100.0 * static_cast<double>(d1_outliers + truth_pixels - estimated_pixels) / truth_pixels
             : NAN;
}
double DisparityScores::MeanAbsErrorPx() const {
  return estimated_pixels > 0 ? sum_abs_error_px / estimated_pixels : NAN;
}
double DisparityScores::RmsErrorPx() const {
  return estimated_pixels > 0 ? std::sqrt(sum_squared_error_px2 / estimated_pixels) : NAN;
}
double DisparityScores::BiasPx() const {
  long long n = 0;
  for (long long c : signed_error_bins) n += c;
  if (n == 0) return NAN;
  // The bin holding the middle estimate (the lower middle of an even count).
  long long seen = 0;
  std::size_t k = 0;
  for (; k < signed_error_bins.size(); ++k) {
    seen += signed_error_bins[k];
    if (2 * seen >= n) break;
  }
  return -kBiasRangePx + static_cast<double>(k) * kBiasBinPx;
}

DisparityScores ScoreDisparity(const cv::Mat& estimate, const cv::Mat& truth, const cv::Mat& mask,
                               const SampleGrid& grid, const DisparityEvalOptions& options) {
  LN_CHECK(estimate.type() == CV_32FC1 && truth.type() == CV_32FC1) << "float maps expected";
  LN_CHECK(mask.empty() || (mask.type() == CV_8UC1 && mask.size() == truth.size()))
      << "mask: CV_8UC1 of the truth's size expected";
  LN_CHECK(grid.step_x >= 1 && grid.step_y >= 1 && grid.origin_x >= 0 && grid.origin_y >= 0)
      << "impossible sample grid";
  // Sample points of the truth image, and where each is in the estimate: the same pixel of a
  // full-size estimate, or the next cell of a compact one.
  const int samples_x = grid.origin_x < truth.cols ? (truth.cols - grid.origin_x + grid.step_x - 1) / grid.step_x : 0;
  const int samples_y = grid.origin_y < truth.rows ? (truth.rows - grid.origin_y + grid.step_y - 1) / grid.step_y : 0;
  const bool full_size = estimate.size() == truth.size();
  LN_CHECK_INPUT(full_size || (estimate.cols == samples_x && estimate.rows == samples_y))
      << "the estimate's " << estimate.cols << "x" << estimate.rows << " pixels are neither the truth's "
      << truth.cols << "x" << truth.rows << " nor its " << samples_x << "x" << samples_y
      << " sample points (grid origin " << grid.origin_x << "," << grid.origin_y << ", step "
      << grid.step_x << "x" << grid.step_y << ")";
  DisparityScores s;
  s.bad.assign(options.bad_thresholds_px.size(), 0);
  const int bias_bins = static_cast<int>(std::lround(2 * DisparityScores::kBiasRangePx / DisparityScores::kBiasBinPx));
  s.signed_error_bins.assign(static_cast<std::size_t>(bias_bins) + 1, 0);
  for (int j = 0; j < samples_y; ++j) {
    const int ty = grid.origin_y + j * grid.step_y;
    if (ty < grid.min_row || ty > grid.max_row) continue;
    const float* e = estimate.ptr<float>(full_size ? ty : j);
    const float* t = truth.ptr<float>(ty);
    const std::uint8_t* m = mask.empty() ? nullptr : mask.ptr<std::uint8_t>(ty);
    for (int i = 0; i < samples_x; ++i) {
      const int tx = grid.origin_x + i * grid.step_x;
      if (!std::isfinite(t[tx]) || (m != nullptr && m[tx] < options.mask_min_value)) continue;
      ++s.truth_pixels;
      const float estimated = e[full_size ? tx : i];
      if (!std::isfinite(estimated)) continue;
      ++s.estimated_pixels;
      const double signed_error = static_cast<double>(estimated) - t[tx];
      const double error = std::abs(signed_error);
      if (error <= DisparityScores::kBiasRangePx) {
        const long bin = std::lround((signed_error + DisparityScores::kBiasRangePx) / DisparityScores::kBiasBinPx);
        ++s.signed_error_bins[static_cast<std::size_t>(std::clamp<long>(bin, 0, bias_bins))];
      }
      s.sum_abs_error_px += error;
      s.sum_squared_error_px2 += error * error;
      for (std::size_t k = 0; k < s.bad.size(); ++k) s.bad[k] += error > options.bad_thresholds_px[k];
      s.d1_outliers += IsD1Outlier(error, t[tx]);
    }
  }
  return s;
}

cv::Mat DisparityFromOpenCv(const cv::Mat& fixed16, int min_disparity) {
  LN_CHECK_INPUT(fixed16.type() == CV_16SC1) << "an OpenCV disparity map (16-bit signed, x 16) expected";
  cv::Mat out(fixed16.size(), CV_32FC1);
  const int least = min_disparity * 16;  // OpenCV marks no match with (min_disparity - 1) x 16
  for (int y = 0; y < fixed16.rows; ++y) {
    const auto* in = fixed16.ptr<std::int16_t>(y);
    auto* o = out.ptr<float>(y);
    for (int x = 0; x < fixed16.cols; ++x) {
      o[x] = in[x] < least ? std::numeric_limits<float>::quiet_NaN() : in[x] / 16.0f;
    }
  }
  return out;
}

cv::Mat ReadTruthDisparity(const fs::path& path, double png_scale) {
  if (path.extension() == ".pfm") {
    cv::Mat truth = io::ReadPfm(path);
    LN_CHECK_INPUT(truth.channels() == 1) << path.string() << ": a 1-channel PFM expected";
    return truth;
  }
  const cv::Mat raw = io::ReadImage(path);  // names the file and the reason when it cannot
  LN_CHECK_INPUT(raw.type() == CV_16UC1)
      << path.string() << ": a 16-bit single-channel PNG expected (disparity x " << png_scale << ")";
  cv::Mat truth;
  raw.convertTo(truth, CV_32F, 1.0 / png_scale);
  truth.setTo(std::numeric_limits<float>::quiet_NaN(), raw == 0);
  return truth;
}

std::vector<DisparityItem> EvaluateDisparityDirectories(const fs::path& results, const fs::path& truth_dir,
                                                        const fs::path& mask_dir,
                                                        const DisparityEvalOptions& options) {
  options.Validate();
  std::error_code ec;
  io::CheckInputDirectory(results);
  io::CheckInputDirectory(truth_dir);
  const fs::path estimate_dir = fs::is_directory(results / "disparity", ec) ? results / "disparity" : results;
  const fs::path truth_files = fs::is_directory(truth_dir / "disparity", ec) ? truth_dir / "disparity" : truth_dir;
  const auto estimates = FilesByStem(estimate_dir, {".pfm"});
  const auto truths = FilesByStem(truth_files, {".pfm", ".png"});
  std::map<std::string, std::vector<fs::path>> masks;
  if (!mask_dir.empty()) {
    io::CheckInputDirectory(mask_dir);
    masks = FilesByStem(mask_dir, {".png"});
  }
  std::map<std::string, DisparityItem> by_stem;
  for (const auto& [stem, files] : estimates) by_stem[stem].estimate = files.front();
  for (const auto& [stem, files] : truths) {
    DisparityItem& item = by_stem[stem];
    item.truth = files.front();
    if (files.size() > 1) {
      item.problem = files[1].string() + ": several truth files for '" + stem + "'";
    }
  }
  int scored = 0;
  std::vector<DisparityItem> items;
  for (auto& [stem, item] : by_stem) {
    item.stem = stem;
    if (item.problem.empty() && item.estimate.empty()) {
      item.problem = (estimate_dir / (stem + ".pfm")).string() + ": no estimate for this truth";
    } else if (item.problem.empty() && item.truth.empty()) {
      item.problem = (truth_files / (stem + ".{pfm,png}")).string() + ": no truth for this estimate";
    }
    if (item.problem.empty() && !mask_dir.empty()) {
      const auto m = masks.find(stem);
      if (m == masks.end()) {
        item.problem = (mask_dir / (stem + ".png")).string() + ": no mask for this pair";
      } else {
        item.mask = m->second.front();
      }
    }
    if (item.problem.empty()) {
      try {
        const cv::Mat estimate = io::ReadPfm(item.estimate);
        LN_CHECK_INPUT(estimate.channels() == 1) << item.estimate.string() << ": a 1-channel PFM expected";
        const cv::Mat truth = ReadTruthDisparity(item.truth, options.png_truth_scale);
        cv::Mat mask;
        if (!item.mask.empty()) {
          mask = io::ReadGreyImage(item.mask);
          LN_CHECK_INPUT(mask.type() == CV_8UC1 && mask.size() == truth.size())
              << item.mask.string() << ": an 8-bit mask of the truth's size expected";
        }
        try {
          item.scores = ScoreDisparity(estimate, truth, mask, ReadSampleGrid(item.estimate), options);
        } catch (const InputError& e) {
          throw InputError(item.estimate.string() + ": " + e.what());
        }
        ++scored;
      } catch (const InputError& e) {
        item.problem = e.what();
      }
    }
    items.push_back(std::move(item));
  }
  LN_CHECK_INPUT(!items.empty()) << estimate_dir.string() << " and " << truth_files.string()
                                 << ": no disparity maps (.pfm) or truth files (.pfm, .png)";
  LN_CHECK_INPUT(scored > 0) << results.string() << " and " << truth_dir.string()
                             << ": no stem has both an estimate and its truth (first: "
                             << items.front().problem << ")";
  return items;
}

Table DisparityTable(const std::vector<DisparityItem>& items, const DisparityEvalOptions& options) {
  Table table;
  table.title = "Disparity against ground truth";
  table.columns = {{"stem", "", "pair", 0}, {"truth_pixels", "", "truth pixels", 0},
                   {"density", "pct", "density (%)", 2}};
  for (double t : options.bad_thresholds_px) {
    const std::string name = "bad_" + FormatThreshold(t);
    table.columns.push_back({name, "pct", "bad-" + FormatThreshold(t) + " (%)", 2});
  }
  table.columns.push_back({"bad_or_missing_" + FormatThreshold(options.bad_thresholds_px.back()), "pct",
                           "bad-" + FormatThreshold(options.bad_thresholds_px.back()) + " or missing (%)", 2});
  table.columns.push_back({"d1", "pct", "D1 (%)", 2});
  table.columns.push_back({"d1_or_missing", "pct", "D1 or missing (%)", 2});
  table.columns.push_back({"mean_abs_error", "px", "mean |error| (px)", 3});
  table.columns.push_back({"rms_error", "px", "RMS error (px)", 3});
  table.columns.push_back({"bias", "px", "median signed error within 3 px (px)", 2});
  auto row_of = [&](const std::string& name, const DisparityScores& s, const std::string& problem) {
    std::vector<Cell> row = {Cell::Text(name)};
    if (!problem.empty()) {
      for (std::size_t c = 1; c < table.columns.size(); ++c) row.push_back(Cell::NotAvailable(problem));
      return row;
    }
    row.push_back(Cell::Number(static_cast<double>(s.truth_pixels)));
    const std::string no_truth = "no truth pixels", no_estimate = "no estimate on truth pixels";
    row.push_back(Cell::NumberOr(s.DensityPct(), no_truth));
    for (std::size_t k = 0; k < options.bad_thresholds_px.size(); ++k) {
      row.push_back(Cell::NumberOr(s.BadPct(k), no_estimate));
    }
    row.push_back(Cell::NumberOr(s.BadOrMissingPct(options.bad_thresholds_px.size() - 1), no_truth));
    row.push_back(Cell::NumberOr(s.D1Pct(), no_estimate));
    row.push_back(Cell::NumberOr(s.D1OrMissingPct(), no_truth));
    row.push_back(Cell::NumberOr(s.MeanAbsErrorPx(), no_estimate));
    row.push_back(Cell::NumberOr(s.RmsErrorPx(), no_estimate));
    row.push_back(Cell::NumberOr(s.BiasPx(), "no estimate within 3 px of the truth"));
    return row;
  };
  DisparityScores all;
  int scored = 0;
  for (const DisparityItem& item : items) {
    table.AddRow(row_of(item.stem, item.scores, item.problem));
    if (item.problem.empty()) {
      all.Add(item.scores);
      ++scored;
    }
  }
  table.AddRow(row_of("all (" + std::to_string(scored) + " pairs)", all, scored ? "" : "no pair scored"));
  table.notes = {
      "bad-N: estimates more than N px from the truth, % of the estimated truth pixels; "
      "bad-N or missing: also counting truth pixels without an estimate as bad.",
      "D1 (KITTI 2015): estimates more than 3 px and more than 5 % from the truth, % of the estimated "
      "truth pixels; D1 or missing: also counting truth pixels without an estimate.",
      "Median signed error: of (estimate - truth) over the estimates within 3 px of the truth, to 0.01 px: a "
      "systematic offset (the matcher's, or the calibration's when the truth comes from another sensor), "
      "which gross errors do not move.",
      "Errors are measured at the estimate's sample points (partial subsampling grid)."};
  return table;
}

int RunDisparityCommand(const DisparityCommand& command, const nlohmann::json& summary_head) {
  util::Timer timer;
  DisparityEvalOptions options = command.options;
  if (!command.bad_thresholds_px.empty()) options.bad_thresholds_px = command.bad_thresholds_px;
  options.Validate();
  io::CreateOutputDirectory(command.output_dir);
  const auto items = EvaluateDisparityDirectories(command.results, command.truth, command.masks, options);
  long failed = 0;
  nlohmann::json failed_json = nlohmann::json::array();
  for (const auto& item : items) {
    if (item.problem.empty()) continue;
    ++failed;
    LN_LOG(Error) << "pair " << item.stem << ": " << item.problem;
    failed_json.push_back({{"stem", item.stem}, {"error", item.problem}});
  }
  const Table table = DisparityTable(items, options);
  WriteTable(command.output_dir, "disparity", table);
  nlohmann::json summary = summary_head;
  summary["inputs"] = {
      {"results", command.results.string()}, {"truth", command.truth.string()}, {"masks", command.masks.string()}};
  summary["options"] = {{"bad_thresholds_px", options.bad_thresholds_px}, {"png_truth_scale", options.png_truth_scale}};
  const long scored = static_cast<long>(items.size()) - failed;
  summary["counts"] = {{"stems", items.size()}, {"scored", scored}, {"failed", failed}};
  summary["failed"] = failed_json;
  summary["table"] = table.ToJson();
  summary["timings_s"] = {{"total", timer.ElapsedSeconds()}};
  io::WriteJsonAtomic(command.output_dir / "summary.json", summary);
  LN_LOG(Info) << "evaluate disparity: " << scored << " of " << items.size() << " pairs scored; "
               << (command.output_dir / "disparity.md").string();
  return failed > 0 ? kExitBatchPartial : kExitOk;
}

}  // namespace lunarnav::evaluation
