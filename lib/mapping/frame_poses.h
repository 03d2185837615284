// The vehicle's pose for each stereo pair, for accumulating the pairs' vehicle-frame points
// into a world map (Krotkov & Hebert sec. 3): from the simulator's truth/poses.csv, or from a
// trajectory (posfilter's trajectory.csv or TUM) interpolated at each pair's time.
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "positioning/dead_reckoning.h"

namespace lunarnav::mapping {

/// The pose of the vehicle frame of sec. 3.2 (X right, Y forward, Z up) in the world frame
/// (x east, y north, z up) for a position (m) and heading (clockwise from north), pitch (nose
/// up), roll (right side down), radians: T(x, y, z) Rz(-heading) Rx(pitch) Ry(roll).
Eigen::Isometry3d WorldFromVehicle(double x_m, double y_m, double z_m, double heading_rad, double pitch_rad,
                                   double roll_rad);

/// A vehicle pose in the world frame (x east, y north, z up, metres) with the conventions of
/// the positioning module: heading clockwise from north, pitch nose up, roll right side down
/// (radians). It places the vehicle frame of sec. 3.2 (X right, Y forward, Z up, origin at the
/// mast base): X_world = T(x, y, z) Rz(-heading) Rx(pitch) Ry(roll) X_vehicle.
/// The vehicle's heading laid level: the horizontal unit vector of its Y axis in the world (the
/// level frame's Y: a point's horizontal distance ahead is its world offset along this).
Eigen::Vector2d HeadingDirection(const Eigen::Isometry3d& world_from_vehicle);

struct FramePose {
  std::string stem;
  double t_s = 0;
  double x_m = 0, y_m = 0, z_m = 0;
  double heading_rad = 0, pitch_rad = 0, roll_rad = 0;

  /// The rigid transform taking vehicle coordinates to world coordinates.
  Eigen::Isometry3d WorldFromVehicle() const;
  /// True when all six values and the time are finite.
  bool IsFinite() const;
  /// Throws InputError "stem S: ..." (`source`, when given, in brackets: the file the pose came from) when a
  /// value is not finite, the position is farther than kMaxWorldCoordinateM from the origin
  /// along an axis, or an angle exceeds kMaxPoseAngleDeg.
  void Validate(const std::string& source) const;
};

/// The farthest a pose (and a mapped point) may lie from the world origin along x, y or z,
/// metres: 1,000 km, beyond any traverse in one local frame, and within the maps' integer
/// cell indices at the smallest cell (1 cm). docs/reliability.md.
inline constexpr double kMaxWorldCoordinateM = 1e6;
/// The largest heading, pitch or roll a pose may give (an unwrapped heading of many turns is
/// fine; 1e300 deg is no angle), degrees.
inline constexpr double kMaxPoseAngleDeg = 1e6;

/// Reads the simulator's poses file (docs/formats.md, "Simulated poses"): '#' lines, a header
/// starting `stem,t_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg` (more columns allowed), one
/// row per pair. Values may be non-finite ("nan"): such a pose is reported when it is used.
/// @throws InputError naming the file and line: unreadable, wrong header, a malformed row, a
///         stem listed twice.
std::vector<FramePose> ReadPosesCsv(const std::filesystem::path& path);

/// Reads a frame-times file: a header `stem,t_s` ('#' lines and extra columns allowed), one
/// row per pair; or KITTI's times.txt or timestamps.txt (ReadKittiFrameTimes: stems the
/// frames' numbers as KITTI names their images). @throws InputError naming the file and line.
std::vector<FramePose> ReadFrameTimes(const std::filesystem::path& path);

/// What reading a trajectory may need besides the file: KITTI's pose files take their times
/// from the frame-times file (times.txt), and camera poses (KITTI's pose files, its GPS/INS
/// packets through its calibration) the rig's camera in the vehicle frame
/// (StereoRig::VehicleFromLeft).
struct TrajectoryContext {
  std::filesystem::path frame_times;
  std::optional<Eigen::Isometry3d> vehicle_from_camera;
};

/// Reads a trajectory of the vehicle in any of the forms DetectTrajectoryFormat tells apart:
/// posfilter's trajectory.csv, TUM ("t x y z qx qy qz qw", body x forward, y left, z up),
/// a KITTI pose file or a KITTI raw oxts/ directory (kitti_trajectory.h; these need
/// `context.vehicle_from_camera`, a usage error without). Times increase.
/// @throws InputError naming the file (and line).
std::vector<positioning::TrajectorySample> ReadTrajectory(const std::filesystem::path& trajectory,
                                                          const TrajectoryContext& context);

/// The poses of the pairs listed in `frame_times` from a trajectory (ReadTrajectory),
/// interpolated linearly in time (angles along the shorter arc).
/// @throws InputError naming the stem when its time lies outside the trajectory, and naming
///         the file for an unreadable trajectory.
std::vector<FramePose> InterpolateTrajectory(const std::filesystem::path& trajectory,
                                             const std::vector<FramePose>& frame_times,
                                             const TrajectoryContext& context = {});

/// Poses by stem.
std::map<std::string, FramePose> IndexByStem(const std::vector<FramePose>& poses);

/// The poses of the pairs `stems`, by time (a stable sort): from a poses file (`poses_csv`), or
/// from a trajectory interpolated at a frame-times file (`poses_csv` empty). Each is validated.
/// @throws InputError naming the stem and the file for a pair the file does not list, and as
///         the readers, InterpolateTrajectory and FramePose::Validate do.
/// `vehicle_from_camera`: the rig's left camera in the vehicle frame, for trajectories of
/// camera poses (TrajectoryContext).
std::vector<FramePose> PosesOfPairs(const std::filesystem::path& poses_csv, const std::filesystem::path& trajectory,
                                    const std::filesystem::path& frame_times, const std::vector<std::string>& stems,
                                    const std::optional<Eigen::Isometry3d>& vehicle_from_camera = std::nullopt);

}  // namespace lunarnav::mapping
