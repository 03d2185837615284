// The rover's attitude as a rotation: the convention shared by TUM output and evaluation.
#pragma once

#include <cmath>

#include <Eigen/Geometry>

namespace lunarnav::positioning {

/// The sine and cosine of half an angle: what a rotation by the angle is made of.
struct HalfAngle {
  double sin = 0, cos = 1;
  static HalfAngle Of(double angle_rad) { return {std::sin(0.5 * angle_rad), std::cos(0.5 * angle_rad)}; }
};

/// The rotation taking the body frame (x forward, y left, z up) into the ENU frame, for a
/// compass heading (clockwise from north), pitch (nose up) and roll (right side down), given
/// by their half angles: yaw = 90 deg - heading about z, then -pitch about y, then -roll
/// about x. Written out: the product of the three half-angle rotations.
inline Eigen::Quaterniond EnuFromBody(const HalfAngle& heading, const HalfAngle& pitch, const HalfAngle& roll) {
  // Half of yaw = 45 deg - heading / 2: sin and cos by the difference formulas.
  constexpr double kHalfSqrt2 = 0.70710678118654752440;
  const double sz = kHalfSqrt2 * (heading.cos - heading.sin), cz = kHalfSqrt2 * (heading.cos + heading.sin);
  const double sy = -pitch.sin, cy = pitch.cos, sx = -roll.sin, cx = roll.cos;
  // q = q_z(yaw) q_y(-pitch) q_x(-roll); Eigen's constructor takes w, x, y, z.
  return Eigen::Quaterniond(cz * cy * cx + sz * sy * sx, cz * cy * sx - sz * sy * cx, cz * sy * cx + sz * cy * sx,
                            sz * cy * cx - cz * sy * sx);
}

/// The same from the angles, rad.
inline Eigen::Quaterniond EnuFromBody(double heading_rad, double pitch_rad, double roll_rad) {
  return EnuFromBody(HalfAngle::Of(heading_rad), HalfAngle::Of(pitch_rad), HalfAngle::Of(roll_rad));
}

}  // namespace lunarnav::positioning
