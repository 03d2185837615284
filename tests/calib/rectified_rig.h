// Test helper: an ideal rectified rig like the paper's (sec. 3.1: 0.9 m baseline, 1.5 m up,
// 25 deg down, 740 px focal length at 640 x 480), of any size, optionally with a rectified
// frame rotated against the cameras' and a principal-point offset between the rectified
// images (as stereoRectify can produce), so that nothing relies on an aligned rig.
#pragma once

#include "calib/stereo_rig.h"

namespace lunarnav::calib::testing {

/// @param rect_from_left  rotation of the rectified frame (both cameras share it).
/// @param c_right_offset_px  c_right - c_left of the rectified projections.
inline StereoRig IdealRectifiedRig(int width_px = 640, int height_px = 480, double focal_px = 740,
                                   double baseline_m = 0.9,
                                   const Eigen::Matrix3d& rect_from_left = Eigen::Matrix3d::Identity(),
                                   double c_right_offset_px = 0.0) {
  StereoRig rig;
  rig.width_px = width_px;
  rig.height_px = height_px;
  const double cx = 0.5 * (width_px - 1), cy = 0.5 * (height_px - 1);
  for (CameraIntrinsics* c : {&rig.left, &rig.right}) {
    c->K << focal_px, 0, cx, 0, focal_px, cy, 0, 0, 1;
  }
  rig.right_from_left_R.setIdentity();
  // The right camera's centre lies baseline_m along the rectified x axis.
  rig.right_from_left_t_m = -(rect_from_left.transpose() * Eigen::Vector3d(baseline_m, 0, 0));
  rig.mast = MastPose{1.5, 25.0, 0.0, 0.0};
  RectifiedGeometry g;
  g.rect_from_left = rect_from_left;
  g.rect_from_right = rect_from_left;
  g.P_left << focal_px, 0, cx, 0, 0, focal_px, cy, 0, 0, 0, 1, 0;
  g.P_right << focal_px, 0, cx + c_right_offset_px, -focal_px * baseline_m, 0, focal_px, cy, 0, 0, 0, 1, 0;
  g.width_px = width_px;
  g.height_px = height_px;
  rig.rectified = g;
  return rig;
}

/// A rectified frame rolled and yawed against the cameras (degrees).
inline Eigen::Matrix3d RollYaw(double roll_deg, double yaw_deg) {
  const double k = 3.14159265358979323846 / 180.0;
  return (Eigen::AngleAxisd(roll_deg * k, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(yaw_deg * k, Eigen::Vector3d::UnitY()))
      .toRotationMatrix();
}

}  // namespace lunarnav::calib::testing
