// The rover's attitude as a rotation: the convention shared by TUM output and evaluation.
#pragma once

#include <cmath>

#include <Eigen/Geometry>

namespace lunarnav::positioning {

/// The rotation taking the body frame (x forward, y left, z up) into the ENU frame, for a
/// compass heading (clockwise from north), pitch (nose up) and roll (right side down), rad:
/// yaw = 90 deg - heading about z, then -pitch about y, then -roll about x.
inline Eigen::Quaterniond EnuFromBody(double heading_rad, double pitch_rad, double roll_rad) {
  return Eigen::AngleAxisd(M_PI / 2 - heading_rad, Eigen::Vector3d::UnitZ()) *
         Eigen::AngleAxisd(-pitch_rad, Eigen::Vector3d::UnitY()) *
         Eigen::AngleAxisd(-roll_rad, Eigen::Vector3d::UnitX());
}

}  // namespace lunarnav::positioning
