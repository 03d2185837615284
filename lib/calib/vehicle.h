// The vehicle a stereo rig is designed for: what the design calculation of Krotkov & Hebert
// sec. 3.1 needs (speed, braking, size, wheels) and the imaging requirements it checks.
// File format: docs/formats.md, "Vehicle file".
#pragma once

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

namespace lunarnav::calib {

/// The imaging requirements of sec. 3.1, with the paper's values as defaults.
struct ImagingRequirements {
  /// 2) The cameras see at least this many vehicle widths at every distance beyond the
  /// lookahead distance ("at least 3 vehicle widths (about 400 cm)").
  double fov_vehicle_widths = 3.0;
  /// 3) An obstacle this tall, metres ("20 cm tall") ...
  double obstacle_height_m = 0.2;
  /// ... must subtend at least this many pixels ("at least 6 pixels").
  double obstacle_min_px = 6.0;
  /// Far end of the distance band the rig serves, metres from the mast base (Y); the
  /// resolution requirement is checked there. Default: Y_max of the paper's typical planner
  /// interval I_Y = [4.2, 7.5] m (sec. 3.3, fig. 3).
  double far_range_m = 7.5;
};

/// A vehicle, in the vehicle frame of sec. 3.2 (Y forward, Z up, origin at the mast base).
struct VehicleSpec {
  std::string name;
  double max_speed_m_s = 0.7;          ///< v, maximum speed of travel, m/s, > 0.
  double sliding_friction = 0.25;      ///< mu, coefficient of sliding friction, > 0.
  double stop_time_s = 2.0;            ///< t_stop, time before braking starts, s, >= 0.
  double width_m = 4.0 / 3.0;          ///< Vehicle width, m, > 0.
  double wheel_diameter_m = 0.5;       ///< Front wheel diameter, m, > 0.
  double front_axle_y_m = 0.5;         ///< Y of the front axle (from the mast base), m.
  /// Steepest ground slope the vehicle may drive, degrees, in (0, 90); optional in the file
  /// (the paper gives none; 30 deg by default). terrain-map marks steeper cells as obstacles.
  double max_slope_deg = 30.0;
  ImagingRequirements requirements;

  /// Y of the front of the front wheels (front axle + wheel radius), m.
  double FrontOfWheelsY() const { return front_axle_y_m + 0.5 * wheel_diameter_m; }
  /// @throws InputError naming `source` and the field for an impossible value.
  void Validate(const std::string& source) const;
};

/// The vehicle as JSON ("format": "lunarnav.vehicle/1").
nlohmann::json VehicleSpecToJson(const VehicleSpec& vehicle);

/// Parses and validates a vehicle. Unknown fields, missing fields (all but "name",
/// "description", "sources" and "requirements", whose fields default to the paper's) and
/// impossible values are InputErrors naming `source` and the field.
VehicleSpec VehicleSpecFromJson(const nlohmann::json& j, const std::string& source);

VehicleSpec ReadVehicleSpec(const std::filesystem::path& path);

}  // namespace lunarnav::calib
