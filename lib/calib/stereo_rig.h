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
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace lunarnav::calib {

/// A pinhole camera with OpenCV's distortion model.
struct CameraIntrinsics {
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();  ///< [fx 0 cx; 0 fy cy; 0 0 1], pixels.
  /// OpenCV order: k1 k2 p1 p2 [k3 [k4 k5 k6]]; empty = no distortion.
  std::vector<double> distortion;
  /// @throws InputError naming `where` (e.g. "rig.json.left"): K not finite or not
  /// [[fx, s, cx], [0, fy, cy], [0, 0, 1]] with positive focal lengths and a principal point
  /// near the width x height image, or not 0, 4, 5 or 8 distortion coefficients (finite).
  void Validate(int width, int height, const std::string& where) const;
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

/// The longest baseline a rig file may give, metres: beyond any stereo rig (a value in
/// millimetres read as metres trips it).
inline constexpr double kMaxBaselineM = 100.0;

struct StereoRig {
  int width_px = 640, height_px = 480;  ///< Size of the raw images.
  CameraIntrinsics left, right;
  /// x_right = R x_left + t (OpenCV stereoCalibrate's R, T), t in metres.
  Eigen::Matrix3d right_from_left_R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d right_from_left_t_m = Eigen::Vector3d(-0.9, 0, 0);
  MastPose mast;
  std::optional<RectifiedGeometry> rectified;
  /// What reading the rig changed (e.g. a printed rotation replaced by the nearest rotation),
  /// one sentence each naming the file and field; not written to rig files. Tools that read a
  /// rig report these in their summary.
  std::vector<std::string> notes;

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

/// Printed precision: a rotation read from a file whose ||R^T R - I|| (Frobenius) and
/// |det R - 1| are both at most this is taken as a rotation printed to a few significant
/// digits (6 digits give about 1e-6) and replaced by the nearest rotation; beyond it, it is
/// not a rotation.
constexpr double kPrintedRotationTolerance = 1e-4;
/// Printed precision of the rectified projections' shared values (focal length, principal
/// row): relative differences up to this are round-off, and the right's are set to the left's.
constexpr double kPrintedProjectionTolerance = 1e-6;

/// The rotation nearest to `m` in the Frobenius norm (U V^T of its SVD, det +1).
Eigen::Matrix3d NearestRotation(const Eigen::Matrix3d& m);

/// Replaces a rotation within kPrintedRotationTolerance of one by the nearest rotation, and
/// appends a note naming `where` to `notes` when that changed it.
/// @throws InputError naming `where` for a matrix beyond the tolerance or not finite.
void RepairPrintedRotation(Eigen::Matrix3d* r, const std::string& where, std::vector<std::string>* notes);

/// Makes values typed or printed with limited precision exact, before Validate: every
/// rotation of the rig (right_from_left.R, rectified.rect_from_left, rect_from_right) within
/// kPrintedRotationTolerance of a rotation is replaced by the nearest rotation, and a right
/// rectified projection whose focal lengths and principal row agree with the left's within
/// kPrintedProjectionTolerance gets the left's. Each change is appended to rig->notes, naming
/// `source` and the field and saying how much changed.
/// @throws InputError naming `source` and the field for a matrix beyond the tolerance.
void RepairPrintedPrecision(StereoRig* rig, const std::string& source);

/// The rotation taking head (left camera) axes to vehicle axes for a head pitched down by
/// tilt: the optical axis z points along (0, cos t, -sin t), x along the vehicle's X.
Eigen::Matrix3d VehicleFromHeadRotation(double tilt_deg);

}  // namespace lunarnav::calib
