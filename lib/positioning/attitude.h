// The rover's attitude as a rotation: the convention shared by TUM output and evaluation.
#pragma once

#include <cmath>

#include <Eigen/Geometry>

namespace lunarnav::positioning {

/// The rotation taking the body frame (x forward, y left, z up) into the ENU frame, for a
/// compass heading (clockwise from north), pitch (nose up) and roll (right side down), rad:
/// yaw = 90 deg - heading about z, then -pitch about y, then -roll about x.
/// Written out: the product of the three half-angle rotations, one sine and cosine each.
inline Eigen::Quaterniond EnuFromBody(double heading_rad, double pitch_rad, double roll_rad) {
  const double z = 0.5 * (M_PI / 2 - heading_rad), y = 0.5 * -pitch_rad, x = 0.5 * -roll_rad;  // half angles
  const double sz = std::sin(z), cz = std::cos(z), sy = std::sin(y), cy = std::cos(y), sx = std::sin(x),
               cx = std::cos(x);
  // q = q_z(yaw) q_y(-pitch) q_x(-roll); Eigen's constructor takes w, x, y, z.
  return Eigen::Quaterniond(cz * cy * cx + sz * sy * sx, cz * cy * sx - sz * sy * cx, cz * sy * cx + sz * cy * sx,
                            sz * cy * cx - cz * sy * sx);
}

}  // namespace lunarnav::positioning
