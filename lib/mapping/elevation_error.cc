#include "mapping/elevation_error.h"

#include <cmath>

#include "util/check.h"

namespace lunarnav::mapping {

ElevationErrorModel::ElevationErrorModel(const calib::StereoRig& rig, calib::ReferenceImage reference,
                                         double sigma_d_px) {
  LN_CHECK_ARG(rig.rectified.has_value()) << "rig: no rectified geometry (use rectify's rig file)";
  LN_CHECK_ARG(std::isfinite(sigma_d_px) && sigma_d_px > 0) << "sigma_d: must be > 0 px";
  const calib::RectifiedGeometry& g = *rig.rectified;
  const double f = g.P_left(0, 0), baseline_m = -g.P_right(0, 3) / f;
  const Eigen::Isometry3d vehicle_from_left = rig.VehicleFromLeft();
  const Eigen::Matrix3d vehicle_from_rect = vehicle_from_left.linear() * g.rect_from_left.transpose();
  left_ = vehicle_from_left.translation();
  axis_ = vehicle_from_rect * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d ref_offset_rect(reference == calib::ReferenceImage::kRight ? baseline_m : 0.0, 0, 0);
  const Eigen::Vector3d ref = left_ + vehicle_from_rect * ref_offset_rect;
  ref_x_ = ref.x();
  ref_y_ = ref.y();
  ref_z_ = ref.z();
  scale_ = sigma_d_px / (f * baseline_m);
  sigma_d_ = sigma_d_px;
}

}  // namespace lunarnav::mapping
