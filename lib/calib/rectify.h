// Rectification (Krotkov & Hebert sec. 3.2: "we use a rectification procedure ... applied to
// the input images"): after it, epipolar lines are image rows, as the matcher assumes.
#pragma once

#include <opencv2/core.hpp>

#include "calib/stereo_rig.h"

namespace lunarnav::calib {

/// The rig with its rectified geometry filled in, by OpenCV's stereoRectify (Bouguet's
/// method: each camera rotated half-way, principal points aligned vertically). The rectified
/// images keep the raw size; `alpha` 0 keeps only pixels valid in both views, 1 keeps every
/// raw pixel (OpenCV's meaning).
/// @throws InputError via Validate for an impossible rig; std::invalid_argument for alpha.
StereoRig RectifyRig(const StereoRig& rig, double alpha = 0.0);

/// Remapping tables of a rectified rig, computed once and applied to every pair of a run.
class Rectifier {
 public:
  /// @param rig  a rectified rig (RectifyRig's result); std::invalid_argument otherwise.
  explicit Rectifier(const StereoRig& rig);

  /// Warps a raw pair (any depth, 1 or 3 channels, the rig's raw size) into the rectified
  /// geometry with bilinear interpolation; pixels that fall outside the raw image are 0.
  /// @throws InputError when an image does not have the rig's raw size.
  void Rectify(const cv::Mat& left, const cv::Mat& right, cv::Mat* left_out, cv::Mat* right_out) const;

  /// Rectified coordinates of raw pixel positions of one camera (undistorted and rotated).
  std::vector<cv::Point2d> RectifyPoints(const std::vector<cv::Point2d>& raw, bool left) const;

 private:
  StereoRig rig_;
  cv::Mat left_map1_, left_map2_, right_map1_, right_map2_;
};

}  // namespace lunarnav::calib
