#include "stereo/frame_check.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "util/check.h"

namespace lunarnav::stereo {

void FrameCheckOptions::Validate() const {
  LN_CHECK_ARG(std::isfinite(blank_max_sigma) && blank_max_sigma >= 0)
      << "blank-sigma: must be >= 0, got " << blank_max_sigma;
  LN_CHECK_ARG(std::isfinite(saturated_max_fraction) && saturated_max_fraction > 0 &&
               saturated_max_fraction <= 1)
      << "saturation-fraction: must be in (0, 1], got " << saturated_max_fraction;
}

nlohmann::json FrameCheckOptions::ToJson() const {
  return {{"blank_max_sigma_grey8", blank_max_sigma},
          {"saturated_max_fraction", saturated_max_fraction}};
}

std::optional<std::string> CheckFrame(const FrameCheckOptions& options, const cv::Mat& image, int bit_depth) {
  LN_CHECK(image.type() == CV_8UC1 || image.type() == CV_16UC1);
  const int type_bits = image.depth() == CV_8U ? 8 : 16;
  const int bits = bit_depth > 0 ? std::min(bit_depth, type_bits) : type_bits;
  const double full_scale = static_cast<double>((1u << bits) - 1);
  cv::Scalar mean, stddev;
  cv::meanStdDev(image, mean, stddev);
  const double sigma8 = stddev[0] * 255.0 / full_scale;
  std::ostringstream reason;
  reason.precision(3);
  if (options.saturated_max_fraction < 1) {
    const double threshold = 0.98 * full_scale;
    const double fraction = static_cast<double>(cv::countNonZero(image >= threshold)) /
                            static_cast<double>(image.total());
    if (fraction > options.saturated_max_fraction) {
      reason << "saturated frame (" << 100.0 * fraction << "% of pixels at full scale, above "
             << 100.0 * options.saturated_max_fraction << "%)";
      return reason.str();
    }
  }
  if (options.blank_max_sigma > 0 && sigma8 < options.blank_max_sigma) {
    reason << "blank frame (intensity std dev " << sigma8 << " grey levels, below "
           << options.blank_max_sigma << ")";
    return reason.str();
  }
  return std::nullopt;
}

}  // namespace lunarnav::stereo
