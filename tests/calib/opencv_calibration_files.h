// Test helper: a rig written as OpenCV's stereo_calib sample writes its calibration.
#pragma once

#include <filesystem>

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <opencv2/core/eigen.hpp>

#include "calib/stereo_rig.h"

namespace lunarnav::calib::testing {

/// Writes `dir`/intrinsics.yml (M1 D1 M2 D2) and `dir`/extrinsics.yml (R T) for `rig`, with T
/// in units of `metres_per_unit` (the target's square size, as the sample leaves it).
inline void WriteOpenCvCalibration(const std::filesystem::path& dir, const StereoRig& rig, double metres_per_unit) {
  cv::FileStorage in((dir / "intrinsics.yml").string(), cv::FileStorage::WRITE);
  cv::Mat m1, m2;
  cv::eigen2cv(rig.left.K, m1);
  cv::eigen2cv(rig.right.K, m2);
  in << "M1" << m1 << "D1" << cv::Mat(rig.left.distortion).t() << "M2" << m2 << "D2"
     << cv::Mat(rig.right.distortion).t();
  cv::FileStorage ex((dir / "extrinsics.yml").string(), cv::FileStorage::WRITE);
  cv::Mat r, t;
  cv::eigen2cv(rig.right_from_left_R, r);
  const Eigen::Vector3d t_units = rig.right_from_left_t_m / metres_per_unit;
  cv::eigen2cv(t_units, t);
  ex << "R" << r << "T" << t;
}

}  // namespace lunarnav::calib::testing
