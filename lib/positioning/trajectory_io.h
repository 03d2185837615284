// Trajectory files: CSV with units, and the TUM format that evo and similar tools read.
#pragma once

#include <filesystem>
#include <memory>
#include <vector>

#include <Eigen/Geometry>

#include "positioning/dead_reckoning.h"

namespace lunarnav::positioning {

/// CSV: '#' lines describing frame and units, then the header
/// t_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg,speed_mps; heading in [0, 360).
void WriteTrajectoryCsv(const std::filesystem::path& path, const std::vector<TrajectorySample>& trajectory);

/// TUM: "t x y z qx qy qz qw" per line. The quaternion rotates the body frame (x forward,
/// y left, z up) into the ENU frame: yaw = 90 deg - heading about z, then -pitch about y
/// (nose up), then -roll about x (right side down).
void WriteTrajectoryTum(const std::filesystem::path& path, const std::vector<TrajectorySample>& trajectory);

/// Writes a trajectory pose by pose, as it is computed, to the CSV and/or the TUM file (an
/// empty path skips that file); the text is that of WriteTrajectoryCsv and WriteTrajectoryTum.
/// Both files are atomic: they appear under their names at Commit(), and a writer destroyed
/// without Commit() (an exception on the way) leaves nothing behind.
class TrajectoryWriter {
 public:
  TrajectoryWriter(const std::filesystem::path& csv_path, const std::filesystem::path& tum_path);
  ~TrajectoryWriter();
  TrajectoryWriter(const TrajectoryWriter&) = delete;
  TrajectoryWriter& operator=(const TrajectoryWriter&) = delete;

  void Add(const TrajectorySample& pose);
  /// The same with the pose's attitude already at hand (EnuFromBody of its angles).
  void Add(const TrajectorySample& pose, const Eigen::Quaterniond& enu_from_body);
  /// Flushes and renames the files onto their names.
  void Commit();

 private:
  class Output;
  std::unique_ptr<Output> csv_, tum_;
};

/// Reads a file written by WriteTrajectoryCsv. @throws InputError with file:line.
std::vector<TrajectorySample> ReadTrajectoryCsv(const std::filesystem::path& path);

/// One line of a TUM file: time, position, and the rotation taking the body frame to the world.
struct TumPose {
  double t_s = 0;
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();
  Eigen::Quaterniond world_from_body = Eigen::Quaterniond::Identity();  ///< Normalised.
};

/// Reads a TUM file ("t x y z qx qy qz qw" per line, '#' and blank lines skipped).
/// @throws InputError with file:line: not 8 numbers, more than 8 fields, a quaternion of norm
///         far from 1, time stamps that do not increase.
std::vector<TumPose> ReadTumPoses(const std::filesystem::path& path);

/// Reads a TUM trajectory ("t x y z qx qy qz qw" per line, '#' lines skipped; the quaternion
/// takes the body frame, x forward, y left, z up, to the world frame) into samples: heading,
/// pitch and roll are the angles of EnuFromBody (valid for |pitch| < 90 deg); speed 0.
/// @throws InputError with file:line for a malformed line or a quaternion of norm far from 1.
std::vector<TrajectorySample> ReadTrajectoryTum(const std::filesystem::path& path);

}  // namespace lunarnav::positioning
