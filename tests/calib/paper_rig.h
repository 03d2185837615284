// Test helper: a rig like the paper's (sec. 3.1): 0.9 m baseline, 1.5 m up, 25 deg down,
// 640 x 480 images, 740 px focal length (8 mm lenses on a 1/2" sensor).
#pragma once

#include "calib/stereo_rig.h"

namespace lunarnav::calib::testing {

inline StereoRig PaperRig() {
  StereoRig rig;
  rig.width_px = 640;
  rig.height_px = 480;
  for (CameraIntrinsics* c : {&rig.left, &rig.right}) {
    c->K << 740, 0, 319.5, 0, 740, 239.5, 0, 0, 1;
    c->distortion = {-0.12, 0.05, 0.0005, -0.0003, 0.0};
  }
  rig.right_from_left_R = Eigen::AngleAxisd(0.004, Eigen::Vector3d::UnitY()).toRotationMatrix();
  rig.right_from_left_t_m = Eigen::Vector3d(-0.9, 0.002, 0.001);
  rig.mast = MastPose{1.5, 25.0, 0.0, 0.0};
  return rig;
}

}  // namespace lunarnav::calib::testing
