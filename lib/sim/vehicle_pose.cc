#include "sim/vehicle_pose.h"

#include <cmath>

#include "mapping/frame_poses.h"

namespace lunarnav::sim {

Eigen::Isometry3d VehiclePose::WorldFromVehicle() const {
  return mapping::WorldFromVehicle(x_m, y_m, z_m, heading_rad, pitch_rad, roll_rad);  // the one convention
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
