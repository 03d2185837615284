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

/// HalfAngle::Of for an angle that changes little from one call to the next (a vehicle's
/// heading, pitch or roll, sample by sample), without a sine and cosine per call: the last
/// call's values are turned by the small difference d of the half angles (the angle-sum
/// formulas), sin d and cos d from their Taylor series (|d| <= 1/16: the terms left out are
/// below 2e-19). Exact (HalfAngle::Of) at the first call, every kExactEvery calls and for
/// any larger step, so that rounding (a few ulp a step) cannot pile up: the values agree with
/// HalfAngle::Of to about 1e-14.
class HalfAngleTracker {
 public:
  static constexpr int kExactEvery = 64;
  HalfAngle operator()(double angle_rad) {
    const double half = 0.5 * angle_rad;
    const double d = half - half_;
    if (since_exact_ >= kExactEvery || !(std::abs(d) <= 0.0625)) {
      value_ = HalfAngle::Of(angle_rad);
      since_exact_ = 0;
    } else {
      constexpr double k6 = 1.0 / 6, k20 = 1.0 / 20, k42 = 1.0 / 42, k72 = 1.0 / 72;
      constexpr double k2 = 0.5, k12 = 1.0 / 12, k30 = 1.0 / 30, k56 = 1.0 / 56;
      const double d2 = d * d;
      const double sin_d = d * (1 - d2 * k6 * (1 - d2 * k20 * (1 - d2 * k42 * (1 - d2 * k72))));
      const double cos_d = 1 - d2 * k2 * (1 - d2 * k12 * (1 - d2 * k30 * (1 - d2 * k56)));
      value_ = {value_.sin * cos_d + value_.cos * sin_d, value_.cos * cos_d - value_.sin * sin_d};
      ++since_exact_;
    }
    half_ = half;
    return value_;
  }

 private:
  double half_ = 0;
  HalfAngle value_;
  int since_exact_ = kExactEvery;  // the first call is exact
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
