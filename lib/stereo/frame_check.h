// Screening of unusable frames: a blank image (video cable disconnected) or a saturated one
// (light that overwhelms the auto-iris), the two failures the paper reports (sec. 3.5).
#pragma once

#include <optional>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

namespace lunarnav::stereo {

struct FrameCheckOptions {
  /// A frame whose intensity standard deviation, in 8-bit grey levels (deeper images are
  /// scaled by their bit depth), is below this is blank. >= 0; 0 disables the check.
  double blank_max_sigma = 1.0;
  /// A frame with more than this fraction of its pixels at >= 98 % of full scale is
  /// saturated. In (0, 1]; 1 disables the check.
  double saturated_max_fraction = 0.5;
  void Validate() const;
  nlohmann::json ToJson() const;
};

/// The reason `image` (CV_8UC1 or CV_16UC1) is unusable, or nothing when it is fine.
/// `bit_depth`: the significant bits of its grey levels (full scale 2^bits - 1; 0 = the
/// type's 8 or 16); the thresholds, given for 8-bit data, are scaled to it.
/// Saturation is checked first (a frame saturated everywhere is also flat).
/// e.g. "blank frame (intensity std dev 0.2 grey levels)".
std::optional<std::string> CheckFrame(const FrameCheckOptions& options, const cv::Mat& image, int bit_depth = 0);

}  // namespace lunarnav::stereo
