// The predicted elevation error of a stereo point from the rig's geometry (Krotkov & Hebert
// sec. 3.2; docs/frames.md, "Error model"): what stereo-batch --xyz-sigma writes in the Z
// channel of xyz_sigma/<stem>.exr, computed from the point itself so that terrain-map need not
// read a second array per pair.
#pragma once

#include <cmath>
#include <limits>

#include <Eigen/Core>

#include "calib/stereo_rig.h"
#include "calib/triangulation.h"

namespace lunarnav::mapping {

class ElevationErrorModel {
 public:
  /// @param rig  a rectified rig (its `rectified` block present).
  /// @param reference  the image the disparity maps are referenced to.
  /// @param sigma_d_px  the disparity error, pixels, > 0.
  /// @throws std::invalid_argument for an unrectified rig or a bad sigma.
  ElevationErrorModel(const calib::StereoRig& rig, calib::ReferenceImage reference, double sigma_d_px);

  /// |dZ/dd| sigma_d for the vehicle-frame point p: sigma_d depth / (f B) |Z - Z_ref|, depth
  /// along the rectified optical axis; equals calib::PredictPointSigma(...).z(). NaN behind
  /// the cameras.
  double SigmaZ(double x, double y, double z) const {
    const double depth = axis_.x() * (x - left_.x()) + axis_.y() * (y - left_.y()) + axis_.z() * (z - left_.z());
    if (!(depth > 0)) return std::numeric_limits<double>::quiet_NaN();
    return scale_ * depth * std::abs(z - ref_z_);
  }
  /// The horizontal part of the same error: sigma_d depth / (f B) times the point's horizontal
  /// distance from the reference camera (the error runs along the ray). NaN behind the cameras.
  double SigmaHorizontal(double x, double y, double z) const {
    const double depth = axis_.x() * (x - left_.x()) + axis_.y() * (y - left_.y()) + axis_.z() * (z - left_.z());
    if (!(depth > 0)) return std::numeric_limits<double>::quiet_NaN();
    return scale_ * depth * std::hypot(x - ref_x_, y - ref_y_);
  }
  /// Both errors and the point's horizontal distance from the reference camera at once (the
  /// fusion's inner loop); false (outputs untouched) behind the cameras.
  bool Errors(double x, double y, double z, double* sigma_z, double* sigma_h, double* range_m) const {
    const double depth = axis_.x() * (x - left_.x()) + axis_.y() * (y - left_.y()) + axis_.z() * (z - left_.z());
    if (!(depth > 0)) return false;
    const double dx = x - ref_x_, dy = y - ref_y_;
    *range_m = std::sqrt(dx * dx + dy * dy);  // hypot's care for overflow costs a tenth of the fusion
    *sigma_z = scale_ * depth * std::abs(z - ref_z_);
    *sigma_h = scale_ * depth * *range_m;
    return true;
  }
  /// The disparity of the vehicle-frame point p, pixels: f B / its depth along the optical
  /// axis. NaN behind the cameras.
  double DisparityPx(double x, double y, double z) const {
    const double depth = axis_.x() * (x - left_.x()) + axis_.y() * (y - left_.y()) + axis_.z() * (z - left_.z());
    return depth > 0 ? sigma_d_ / (scale_ * depth) : std::numeric_limits<double>::quiet_NaN();
  }
  /// The reference camera's centre in the vehicle frame, metres: where the points' rays start.
  Eigen::Vector3d ReferenceCamera() const { return {ref_x_, ref_y_, ref_z_}; }

 private:
  Eigen::Vector3d left_, axis_;
  double ref_x_ = 0, ref_y_ = 0, ref_z_ = 0, scale_ = 0;  // scale_ = sigma_d / (f B)
  double sigma_d_ = 1;
};

}  // namespace lunarnav::mapping
