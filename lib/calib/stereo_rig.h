// The stereo rig: two calibrated cameras, their relative pose, their pose on the mast in the
// vehicle frame, and (after rectification) the rectified projections.
//
// Frames (docs/formats.md, "Rig file"):
//  - camera: OpenCV's, x right, y down, z along the optical axis; pixel centres at integers.
//  - vehicle (Krotkov & Hebert sec. 3.2): Z up, Y the direction of travel, X to the right,
//    origin at the base of the mast.
//  - head: the left camera's axes, origin midway between the two optical centres.
#pragma once

#include <optional>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace lunarnav::calib {

/// A pinhole camera with OpenCV's distortion model.
struct CameraIntrinsics {
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();  ///< [fx 0 cx; 0 fy cy; 0 0 1], pixels.
  /// OpenCV order: k1 k2 p1 p2 [k3 [k4 k5 k6]]; empty = no distortion.
  std::vector<double> distortion;
};

/// Where the stereo head sits on the mast, in the vehicle frame.
struct MastPose {
  double height_m = 1.5;          ///< Height of the head centre above the mast base (Z).
  double tilt_deg = 25.0;         ///< Downward pitch of the optical axes from horizontal.
  double lateral_offset_m = 0.0;  ///< X of the head centre (right positive).
  double forward_offset_m = 0.0;  ///< Y of the head centre (forward positive).
};

/// The rectified geometry (both images share rows): rotations taking each camera's frame to
/// its rectified frame, and the rectified projections (OpenCV stereoRectify's R1 R2 P1 P2).
struct RectifiedGeometry {
  Eigen::Matrix3d rect_from_left = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d rect_from_right = Eigen::Matrix3d::Identity();
  Eigen::Matrix<double, 3, 4> P_left = Eigen::Matrix<double, 3, 4>::Zero();
  Eigen::Matrix<double, 3, 4> P_right = Eigen::Matrix<double, 3, 4>::Zero();
  int width_px = 0, height_px = 0;  ///< Rectified image size.
};

struct StereoRig {
  int width_px = 640, height_px = 480;  ///< Size of the raw images.
  CameraIntrinsics left, right;
  /// x_right = R x_left + t (OpenCV stereoCalibrate's R, T), t in metres.
  Eigen::Matrix3d right_from_left_R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d right_from_left_t_m = Eigen::Vector3d(-0.9, 0, 0);
  MastPose mast;
  std::optional<RectifiedGeometry> rectified;

  /// Distance between the optical centres, metres.
  double BaselineM() const { return right_from_left_t_m.norm(); }
  /// The left camera's pose in the vehicle frame: X_vehicle = T * X_left.
  Eigen::Isometry3d VehicleFromLeft() const;
  /// The right camera's pose in the vehicle frame.
  Eigen::Isometry3d VehicleFromRight() const;
  /// Throws InputError naming `source` and the field for impossible values: non-positive
  /// focal lengths, a principal point far outside the image, a rotation that is not one, a
  /// zero baseline, a tilt outside (-90, 90) deg, an inconsistent rectified geometry.
  void Validate(const std::string& source) const;
};

/// The rotation taking head (left camera) axes to vehicle axes for a head pitched down by
/// tilt: the optical axis z points along (0, cos t, -sin t), x along the vehicle's X.
Eigen::Matrix3d VehicleFromHeadRotation(double tilt_deg);

}  // namespace lunarnav::calib
