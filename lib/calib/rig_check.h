// The design calculation of Krotkov & Hebert sec. 3.1 ("Image Acquisition") for a rig on a
// vehicle: lookahead (stopping distance), camera height over the wheels, width of the field
// of view, and resolution, each against its requirement.
//
// Geometry (docs/rig-check.md): the vehicle frame of sec. 3.2 (Y forward, Z up, origin at the
// mast base, flat ground Z = 0). Points are projected with the rig's raw camera models
// (intrinsics and distortion) at their poses on the mast; "seen" means inside both images.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calib/stereo_rig.h"
#include "calib/vehicle.h"

namespace lunarnav::calib {

/// Where the vehicle drives.
enum class Gravity { kEarth, kMoon };
std::string ToString(Gravity gravity);
/// "earth" or "moon". @throws std::invalid_argument otherwise.
Gravity GravityFromString(const std::string& name);
/// Standard gravity: 9.80665 m/s^2 (Earth), 1.625 m/s^2 (the Moon's mean surface gravity).
double GravityMps2(Gravity gravity);

/// d_stop = t_stop v + v^2 / (2 mu g), metres (sec. 3.1, eq. 1): the distance travelled
/// before braking plus the distance travelled while braking.
double StoppingDistanceM(double stop_time_s, double speed_m_s, double sliding_friction, double gravity_m_s2);

/// The lowest camera height whose line of sight to the ground point at `ground_y_m` clears a
/// wheel (a circle of `wheel_radius_m` standing on the ground with its axle at `axle_y_m`),
/// for a camera at `camera_y_m` (all Y in the vehicle frame, side view, flat ground). At this
/// height the line of sight grazes the wheel ("the height at which the line of sight just
/// grazes the top of the wheels"). 0 when the camera is ahead of the wheel.
/// @throws std::invalid_argument unless camera_y < ground_y, axle_y + radius < ground_y and
///         radius > 0.
double MinCameraHeightOverWheelM(double camera_y_m, double axle_y_m, double wheel_radius_m, double ground_y_m);

/// One requirement and whether the rig meets it.
struct RigCheckItem {
  std::string key;          ///< snake_case id, e.g. "camera_height".
  std::string requirement;  ///< What is checked, for the table.
  double value = NAN;       ///< The rig's value (NaN when it cannot be computed).
  std::string comparison;   ///< ">=" or "<=": value `comparison` limit passes.
  double limit = NAN;
  std::string unit;
  bool pass = false;
  std::string note;  ///< Why it fails, or how the value was obtained.
};

/// The result of the design calculation.
struct RigCheckResult {
  double gravity_m_s2 = NAN;
  double stopping_distance_m = NAN;  ///< d_stop.
  /// Y of the ground point d_stop ahead of the front wheels: the lookahead distance from the
  /// mast base, metres.
  double lookahead_y_m = NAN;
  /// The nearest and farthest ground distances on the centre line (X = 0) seen by both
  /// cameras, metres (NaN when none; infinity when the view reaches the horizon).
  double nearest_seen_y_m = NAN, farthest_seen_y_m = NAN;
  std::vector<RigCheckItem> items;  ///< lookahead, camera_height, fov_width, resolution.

  bool AllPass() const;
  /// The design table of sec. 3.1 with pass/fail, one line per requirement, for stdout.
  std::string Table() const;
  nlohmann::json ToJson() const;
};

/// Runs the calculation: d_stop for the vehicle's speed, friction and braking time under
/// `gravity`; then
///  1) lookahead: the ground at d_stop ahead of the front wheels (centre line) is seen by
///     both cameras (the nearest ground seen is no farther);
///  2) camera height: the head is at least as high as MinCameraHeightOverWheelM for a line of
///     sight from the head to that ground point over the front wheel;
///  3) field of view: the width of ground seen by both cameras, least over the band from the
///     lookahead distance to requirements.far_range_m, is at least fov_vehicle_widths
///     vehicle widths;
///  4) resolution: a vertical obstacle of obstacle_height_m standing on the centre line at
///     far_range_m subtends at least obstacle_min_px pixels in both images.
/// @throws InputError (via Validate) for an impossible rig or vehicle.
RigCheckResult CheckRig(const StereoRig& rig, const VehicleSpec& vehicle, Gravity gravity);

}  // namespace lunarnav::calib
