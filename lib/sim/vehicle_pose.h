// The pose of the vehicle in the simulated world.
#pragma once

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

namespace lunarnav::sim {

/// The vehicle's pose in the world frame, with the conventions of the positioning module
/// (Krotkov & Hebert sec. 4.2): world x east, y north, z up; heading clockwise from north
/// (compass), pitch nose up positive, roll right side down positive. The pose places the
/// vehicle frame of sec. 3.2 (X right, Y forward, Z up, origin at the base of the mast):
/// X_world = T(x, y, z) Rz(-heading) Rx(pitch) Ry(roll) X_vehicle.
struct VehiclePose {
  double x_m = 0, y_m = 0, z_m = 0;
  double heading_rad = 0, pitch_rad = 0, roll_rad = 0;

  /// The rigid transform taking vehicle coordinates to world coordinates.
  Eigen::Isometry3d WorldFromVehicle() const;
  /// {x_m, y_m, z_m, heading_deg, pitch_deg, roll_deg}.
  nlohmann::json ToJson() const;
};

}  // namespace lunarnav::sim
