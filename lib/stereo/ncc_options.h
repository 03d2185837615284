// Options and outputs of the normalized-correlation stereo matcher.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "calib/triangulation.h"

namespace lunarnav::stereo {

/// Which image the disparity map is referenced to (calib/triangulation.h).
using calib::ReferenceImage;
using calib::ReferenceImageFromString;
using calib::ToString;

/// Why a pixel has no disparity. Stored as these codes in rejection maps (docs/formats.md).
enum class Rejection : std::uint8_t {
  kAccepted = 0,        ///< Valid disparity.
  kNotEvaluated = 1,    ///< Outside the row band, or not on the (dx, dy) subsampling grid.
  kBorder = 2,          ///< The correlation window, or every searched disparity, leaves the image.
  kLowTexture = 3,      ///< Filter 1: sigma of the reference window < sigma_min.
  kLowCorrelation = 4,  ///< Filter 2: best correlation C < C_min.
  kAmbiguous = 5,       ///< Filter 3: (C - C') / C < M, C' the second-highest correlation peak.
  kRangeEdge = 6,       ///< The best correlation is at an end of the searched disparity range.
  kMedian = 7           ///< Filter 4: the median filter found too few valid neighbours.
};
inline constexpr int kNumRejectionCodes = 8;
/// Short snake_case name of a code ("low_texture"), used in summaries.
std::string ToString(Rejection reason);

/// Parameters of the matcher. Defaults are the paper's (Krotkov & Hebert, sec. 3.2-3.4).
struct NccOptions {
  /// Half-width w_x of the correlation window, pixels (window is 2*w_x+1 wide). >= 0.
  int half_window_x_px = 25;
  /// Half-height w_y of the correlation window, pixels. >= 0.
  int half_window_y_px = 17;
  /// Subsampling steps (dx, dy) of partial subsampling (sec. 3.4): disparity is computed
  /// only at pixels with x = k*dx, y = k*dy (in the right image's columns for the paper's
  /// convention), and the window sums run over the pixels of the window on that grid.
  /// Every integer disparity is still searched. 1, 1 is full resolution.
  int step_x_px = 1;
  int step_y_px = 1;
  /// Inclusive disparity search range [d_min, d_max], pixels. d_min <= d_max.
  int min_disparity_px = 0;
  int max_disparity_px = 127;
  /// Inclusive band of reference-image rows [y_min, y_max] to process (window selection,
  /// sec. 3.3). Unset = the whole image.
  std::optional<int> min_row;
  std::optional<int> max_row;
  /// Which image the map is referenced to.
  ReferenceImage reference = ReferenceImage::kRight;
  /// Filter 1: minimum standard deviation of the reference window's intensities, in grey
  /// levels of an 8-bit image (16-bit images are scaled by 255/65535). >= 0.
  double min_sigma = 2.0;
  /// Filter 2: minimum best normalized correlation C_min, in [-1, 1].
  double min_correlation = 0.5;
  /// Filter 3: ambiguity threshold M (0.10 = 10 %): reject when (C - C')/C < M, C' the
  /// second-highest peak of the correlation curve. In [0, 1]; 0 disables it.
  double ambiguity = 0.10;
  /// Filter 4: size k of the k x k median filter on the disparity map (on the subsampling
  /// grid), odd; 0 or 1 = off. Each disparity is replaced by the median of the valid ones
  /// in its neighbourhood; a pixel with fewer valid neighbours than half of the evaluated
  /// ones is rejected as an isolated match.
  int median_size = 3;
  /// Worker threads: 0 = run in the caller's TBB arena (all cores by default), 1 = serial.
  int num_threads = 0;

  /// Throws std::invalid_argument naming the offending option.
  void Validate() const;
  nlohmann::json ToJson() const;
};

/// Counts and timing of one matched pair.
struct NccSummary {
  int width = 0, height = 0;
  int evaluated_pixels = 0;  ///< Grid pixels inside the row band (everything not kNotEvaluated).
  int accepted_pixels = 0;
  std::array<int, kNumRejectionCodes> pixels_by_reason{};  ///< Indexed by Rejection code.
  int band_min_row = 0, band_max_row = -1;  ///< Row band actually processed.
  int working_shift_bits = 0;  ///< Right shift applied to 16-bit data to keep sums exact.
  double match_seconds = 0;
  /// e.g. "accepted 41.2% of 307200 px (low_texture 3.1%, ...) in 12.3 ms".
  std::string BriefReport() const;
  nlohmann::json ToJson() const;
};

/// The matcher's output, in the reference image's pixel grid (full image size).
struct NccResult {
  cv::Mat disparity_px;  ///< CV_32FC1, sub-pixel disparity; NaN where rejected or not evaluated.
  cv::Mat correlation;   ///< CV_32FC1, best correlation C wherever a search ran, else NaN.
  cv::Mat rejection;     ///< CV_8UC1, Rejection codes.
  NccSummary summary;
};

}  // namespace lunarnav::stereo
