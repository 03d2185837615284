// KITTI's poses, frame times and LiDAR mounting (Geiger et al. 2012, 2013) in the project's
// frames: the odometry benchmark's pose files (camera 0's pose per frame, 3 x 4 row-major), the
// raw format's GPS/INS packets (oxts/), the frame-time files of both (times.txt: seconds;
// timestamps.txt: dates), and the Velodyne's pose in the vehicle frame (calib.txt's Tr, or
// calib_velo_to_cam.txt with calib_cam_to_cam.txt's R_rect_00). docs/formats.md, "KITTI".
//
// World frame of a KITTI trajectory: z up, origin at the mast base of the trajectory's first
// pose; x east, y north for GPS/INS packets (the devkit's Mercator projection), and the first
// vehicle's X (right) and Y (forward) for pose files, which hold no north.
#pragma once

#include <Eigen/Geometry>
#include <filesystem>
#include <string>
#include <vector>

#include "mapping/frame_poses.h"
#include "positioning/dead_reckoning.h"

namespace lunarnav::mapping {

/// What a trajectory file is, told from its shape (DetectTrajectoryFormat).
enum class TrajectoryFormat {
  kPosfilterCsv,  ///< posfilter's trajectory.csv (a .csv file).
  kTum,           ///< TUM: "t x y z qx qy qz qw" per line.
  kKittiPoses,    ///< KITTI odometry poses: 12 numbers per line, camera 0 of frame i in camera 0 of frame 0.
  kKittiOxts      ///< KITTI raw oxts/ directory: data/NNNNNNNNNN.txt packets and timestamps.txt.
};
std::string ToString(TrajectoryFormat format);

/// A directory is KITTI's oxts/ (InputError naming it when it holds no data/ and
/// timestamps.txt); a .csv file posfilter's; a file whose first line that is not blank or a
/// '#' comment holds 12 numbers KITTI's poses; anything else TUM (its reader names the line
/// that is not). @throws InputError naming a path that does not exist.
TrajectoryFormat DetectTrajectoryFormat(const std::filesystem::path& path);

/// True when a frame-times file is one of KITTI's (its first line that is not blank or a '#'
/// comment is a single number, or a date "YYYY-MM-DD HH:MM:SS[.fraction]").
bool IsKittiFrameTimes(const std::filesystem::path& path);

/// Reads KITTI's frame times: the odometry times.txt (seconds per line; stems "%06d" of the
/// line's index, as image_0/ names them) or the raw format's timestamps.txt (dates, as seconds
/// since 1970 UTC; stems "%010d"). @throws InputError naming the file and line.
std::vector<FramePose> ReadKittiFrameTimes(const std::filesystem::path& path);

/// Reads a KITTI pose file: 12 numbers per line (blank lines ignored), the rotation made exact
/// (the nearest rotation; a matrix farther than calib's printed tolerance from one is refused).
/// @throws InputError naming the file and line.
std::vector<Eigen::Isometry3d> ReadKittiPoses(const std::filesystem::path& path);

/// A KITTI pose file as a trajectory of the vehicle: pose i at times[i] (the odometry
/// times.txt: `frame_times`, which must have at least as many rows), taken from camera 0 to the
/// vehicle frame by the rig's `vehicle_from_camera` (StereoRig::VehicleFromLeft): world from
/// vehicle_i = V P_0^-1 P_i V^-1, V = vehicle_from_camera.
/// @throws InputError naming the files and line.
std::vector<positioning::TrajectorySample> ReadKittiPoseTrajectory(const std::filesystem::path& poses,
                                                                   const std::filesystem::path& frame_times,
                                                                   const Eigen::Isometry3d& vehicle_from_camera);

/// The calibration chain of a KITTI raw drive from its IMU to its rectified camera 0:
/// R_rect_00 (calib_cam_to_cam.txt) T_cam_velo (calib_velo_to_cam.txt) T_velo_imu
/// (calib_imu_to_velo.txt), the three files read from `calib_dir`.
Eigen::Isometry3d KittiCameraFromImu(const std::filesystem::path& calib_dir);

/// The folder holding a raw drive's calib_*.txt for its oxts/ directory: the drive's folder or
/// the date's folder above it (KITTI's layout). @throws InputError when neither holds them.
std::filesystem::path KittiCalibDirOfOxts(const std::filesystem::path& oxts_dir);

/// The time constant with which ReadKittiOxtsTrajectory draws the integrated vertical velocity
/// to the packets' altitude, seconds. The altitude is GPS's and wanders by decimetres within
/// seconds (raw drive 2011_09_26_0005: +0.43 m in 3.6 s while the INS's vertical velocity says
/// the car descended 0.1 m, as its pitch does; the packets give a position accuracy of 0.5 m):
/// a map placed by it stands that far off the LiDAR of a few seconds before.
inline constexpr double kOxtsAltitudeTimeConstantS = 60.0;

/// A raw drive's GPS/INS packets (oxts/data/*.txt present, times from oxts/timestamps.txt, as
/// seconds since 1970 UTC) as a trajectory of the vehicle: the IMU's pose by the devkit's
/// convertOxtsToPose (Mercator scale from the first packet's latitude; R = Rz(yaw) Ry(pitch)
/// Rx(roll), IMU x forward, y left, z up), except its height: the INS's vertical velocity (vu)
/// integrated (trapezoids), drawn to the altitude by a first-order filter of time constant
/// kOxtsAltitudeTimeConstantS (the altitude's level over minutes, the INS's shape over
/// seconds; the altitude alone for packets without vu). To rectified camera 0 by
/// KittiCameraFromImu, to the vehicle by `vehicle_from_camera`; x east, y north, the first
/// pose's mast base the origin.
/// @throws InputError naming the file and line.
std::vector<positioning::TrajectorySample> ReadKittiOxtsTrajectory(const std::filesystem::path& oxts_dir,
                                                                   const Eigen::Isometry3d& vehicle_from_camera);

/// The Velodyne's pose in the vehicle frame for a KITTI calibration file: the odometry
/// calib.txt (Tr: Velodyne to camera 0) or the raw format's calib_velo_to_cam.txt (R, T:
/// Velodyne to unrectified camera 0, with R_rect_00 of calib_cam_to_cam.txt in the same
/// folder): vehicle_from_camera T_camera_velodyne.
/// @throws InputError naming the file and field.
Eigen::Isometry3d KittiLidarInVehicle(const std::filesystem::path& calib_file,
                                      const Eigen::Isometry3d& vehicle_from_camera);

/// The pose (FramePose's angles) of a rigid transform taking vehicle coordinates to world
/// coordinates: the inverse of WorldFromVehicle (pitch within +-90 deg).
FramePose FramePoseOf(const Eigen::Isometry3d& world_from_vehicle);

}  // namespace lunarnav::mapping
