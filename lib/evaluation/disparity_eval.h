// Scoring disparity maps against ground-truth disparity (`evaluate disparity`), with the
// measures of the KITTI and Middlebury stereo benchmarks.
#pragma once

#include <filesystem>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "evaluation/table.h"

namespace lunarnav::evaluation {

/// The pixels a matcher evaluated (stereo-batch's partial subsampling; the sidecar's "grid"):
/// (origin_x + i step_x, origin_y + j step_y). Only these are scored. An estimate either has
/// the truth's size (other pixels ignored) or holds just these samples, row by row.
struct SampleGrid {
  int origin_x = 0, origin_y = 0;
  int step_x = 1, step_y = 1;
  /// The band of rows the matcher processed (window selection); rows outside are not scored.
  int min_row = 0, max_row = std::numeric_limits<int>::max();
};

/// The sample grid of a stereo-batch map from the sidecar next to `estimate` (<stem>.json
/// beside disparity/<stem>.pfm), or the identity grid when there is no sidecar.
/// @throws InputError naming the sidecar when it has no usable grid.
SampleGrid ReadSampleGrid(const std::filesystem::path& estimate);

struct DisparityEvalOptions {
  /// An estimate is bad at a pixel when |estimate - truth| > threshold.
  std::vector<double> bad_thresholds_px = {0.5, 1.0, 2.0, 4.0};
  /// 16-bit PNG truth holds disparity * scale, 0 = no truth (KITTI's 256).
  double png_truth_scale = 256.0;
  /// A mask pixel is scored when its value is at least this: 1 = any nonzero value; 255 =
  /// the non-occluded pixels of Middlebury 2014's masks (255 non-occluded, 128 occluded,
  /// 0 unknown). In 1..255.
  int mask_min_value = 1;
  void Validate() const;
};

/// Counts and sums over the truth pixels of one or several maps; Add() pools them.
struct DisparityScores {
  long long truth_pixels = 0;       ///< Valid truth pixels (inside the mask) at sample points.
  long long estimated_pixels = 0;   ///< Of those, with a finite estimate.
  std::vector<long long> bad;       ///< Per threshold: estimated pixels with error above it.
  long long d1_outliers = 0;        ///< Estimated pixels that are KITTI D1 outliers (IsD1Outlier).
  double sum_abs_error_px = 0, sum_squared_error_px2 = 0;
  /// The signed errors (estimate minus truth) of the estimates within kBiasRangePx of the
  /// truth, counted in bins of kBiasBinPx (the first bin centred on -kBiasRangePx): what
  /// BiasPx's median reads, and pools like the other counts.
  static constexpr double kBiasRangePx = 3.0, kBiasBinPx = 0.01;
  std::vector<long long> signed_error_bins;

  void Add(const DisparityScores& other);
  /// estimated / truth pixels, %; NaN without truth pixels.
  double DensityPct() const;
  /// Bad estimates among the estimated pixels, %; NaN without estimates.
  double BadPct(std::size_t threshold_index) const;
  /// Bad or missing among the truth pixels (a missing estimate counts as bad), %.
  double BadOrMissingPct(std::size_t threshold_index) const;
  /// KITTI 2015's D1: outliers among the estimated pixels, %; NaN without estimates.
  double D1Pct() const;
  /// D1 counting every truth pixel without an estimate as an outlier too, % (KITTI's D1 of
  /// a method that does not fill its holes).
  double D1OrMissingPct() const;
  double MeanAbsErrorPx() const;
  double RmsErrorPx() const;
  /// The median signed error (estimate minus truth) of the estimates within kBiasRangePx of
  /// the truth, px (to kBiasBinPx): a matcher's, or a calibration's, systematic offset, which
  /// the gross errors beyond do not move. NaN without such estimates.
  double BiasPx() const;
};

/// KITTI 2015's outlier: an error of more than 3 px and more than 5 % of the true disparity.
inline bool IsD1Outlier(double abs_error_px, double truth_px) {
  return abs_error_px > 3.0 && abs_error_px > 0.05 * std::abs(truth_px);
}

/// Scores `estimate` (CV_32FC1, NaN or +-inf = no disparity) against `truth` (CV_32FC1, NaN
/// or +-inf = no truth). `mask` (CV_8UC1, truth's size, nonzero = evaluate) may be empty.
/// @throws InputError when the estimate has neither the truth's size nor the grid's.
DisparityScores ScoreDisparity(const cv::Mat& estimate, const cv::Mat& truth, const cv::Mat& mask,
                               const SampleGrid& grid, const DisparityEvalOptions& options);

/// An OpenCV matcher's disparity map (StereoBM, StereoSGBM: CV_16SC1, disparity x 16, values
/// below min_disparity x 16 = no match) as an estimate ScoreDisparity reads (CV_32FC1, NaN =
/// no disparity). @throws InputError when the map is not CV_16SC1.
cv::Mat DisparityFromOpenCv(const cv::Mat& fixed16, int min_disparity = 0);

/// Reads ground-truth disparity: PFM (float; inf/NaN = none) or 16-bit PNG (value / scale,
/// 0 = none). @throws InputError naming the file.
cv::Mat ReadTruthDisparity(const std::filesystem::path& path, double png_scale);

/// One stem of an `evaluate disparity` run.
struct DisparityItem {
  std::string stem;
  std::filesystem::path estimate, truth, mask;  ///< Empty when absent.
  std::string problem;                          ///< Why it cannot be scored; empty if it can.
  DisparityScores scores;
};

/// The estimates of RESULTS (a stereo-batch output directory: disparity/<stem>.pfm with
/// sidecars giving the sample grid; or a directory of .pfm files) matched by stem with the
/// truth files of TRUTH_DIR (<stem>.pfm or <stem>.png, also under TRUTH_DIR/disparity/) and
/// the masks of MASK_DIR (<stem>.png, optional). Every stem of either side is an item; an
/// item without both sides, or whose files cannot be read, has a `problem`.
/// @throws InputError when a directory is missing or no stem has both sides.
std::vector<DisparityItem> EvaluateDisparityDirectories(const std::filesystem::path& results,
                                                        const std::filesystem::path& truth_dir,
                                                        const std::filesystem::path& mask_dir,
                                                        const DisparityEvalOptions& options);

/// The per-pair table with a final "all" row pooling every scored pair.
Table DisparityTable(const std::vector<DisparityItem>& items, const DisparityEvalOptions& options);

/// The inputs and options of `evaluate disparity` (docs/evaluate.md).
struct DisparityCommand {
  std::filesystem::path results, truth, masks, output_dir;  ///< masks: empty for none.
  std::vector<double> bad_thresholds_px;                    ///< Empty: the defaults of `options`.
  DisparityEvalOptions options;
};

/// `evaluate disparity`: scores every pair and writes the table (disparity.csv, .json, .md)
/// and summary.json (`summary_head` plus inputs, options, counts, failed pairs, table).
/// @return kExitOk, or kExitBatchPartial when some pairs could not be scored.
/// @throws std::invalid_argument for bad options, InputError as EvaluateDisparityDirectories.
int RunDisparityCommand(const DisparityCommand& command, const nlohmann::json& summary_head);

}  // namespace lunarnav::evaluation
