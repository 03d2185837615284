#include "sim/vehicle_pose.h"

#include <cmath>

namespace lunarnav::sim {

Eigen::Isometry3d VehiclePose::WorldFromVehicle() const {
  // Written here from the convention (vehicle_pose.h), not taken from the mapping module, so
  // that a change on either side shows up as a disagreement (tests/sim/terrain_truth_test.cc).
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = (Eigen::AngleAxisd(-heading_rad, Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(pitch_rad, Eigen::Vector3d::UnitX()) *
                Eigen::AngleAxisd(roll_rad, Eigen::Vector3d::UnitY()))
                   .toRotationMatrix();
  t.translation() = Eigen::Vector3d(x_m, y_m, z_m);
  return t;
}

nlohmann::json VehiclePose::ToJson() const {
  constexpr double kDeg = 180.0 / M_PI;
  return {{"x_m", x_m},
          {"y_m", y_m},
          {"z_m", z_m},
          {"heading_deg", heading_rad * kDeg},
          {"pitch_deg", pitch_rad * kDeg},
          {"roll_deg", roll_rad * kDeg}};
}

}  // namespace lunarnav::sim
