// Test helper: raw (unrectified, distorted) images whose rectification is a given rectified
// pair, so that rendered pairs with exact disparity can stand in for a raw camera pair.
#pragma once

#include <vector>

#include <opencv2/imgproc.hpp>

#include "calib/rectify.h"

namespace lunarnav::calib::testing {

/// The raw image of one camera: each raw pixel samples `rectified` (bicubic) where the
/// rectification sends it; raw pixels that land outside `rectified` are 0.
inline cv::Mat UnrectifyImage(const Rectifier& rectifier, const StereoRig& rig, const cv::Mat& rectified,
                              bool left) {
  std::vector<cv::Point2d> raw;
  raw.reserve(static_cast<std::size_t>(rig.width_px) * rig.height_px);
  for (int y = 0; y < rig.height_px; ++y) {
    for (int x = 0; x < rig.width_px; ++x) raw.emplace_back(x, y);
  }
  const std::vector<cv::Point2d> rect = rectifier.RectifyPoints(raw, left);
  cv::Mat map_x(rig.height_px, rig.width_px, CV_32FC1), map_y(rig.height_px, rig.width_px, CV_32FC1);
  for (int y = 0, i = 0; y < rig.height_px; ++y) {
    for (int x = 0; x < rig.width_px; ++x, ++i) {
      map_x.at<float>(y, x) = static_cast<float>(rect[i].x);
      map_y.at<float>(y, x) = static_cast<float>(rect[i].y);
    }
  }
  cv::Mat out;
  cv::remap(rectified, out, map_x, map_y, cv::INTER_CUBIC, cv::BORDER_CONSTANT, cv::Scalar::all(0));
  return out;
}

}  // namespace lunarnav::calib::testing
