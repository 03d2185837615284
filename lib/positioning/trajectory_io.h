// Trajectory files: CSV with units, and the TUM format that evo and similar tools read.
#pragma once

#include <filesystem>
#include <vector>

#include "positioning/dead_reckoning.h"

namespace lunarnav::positioning {

/// CSV: '#' lines describing frame and units, then the header
/// t_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg,speed_mps; heading in [0, 360).
void WriteTrajectoryCsv(const std::filesystem::path& path, const std::vector<TrajectorySample>& trajectory);

/// TUM: "t x y z qx qy qz qw" per line. The quaternion rotates the body frame (x forward,
/// y left, z up) into the ENU frame: yaw = 90 deg - heading about z, then -pitch about y
/// (nose up), then -roll about x (right side down).
void WriteTrajectoryTum(const std::filesystem::path& path, const std::vector<TrajectorySample>& trajectory);

/// Reads a file written by WriteTrajectoryCsv. @throws InputError with file:line.
std::vector<TrajectorySample> ReadTrajectoryCsv(const std::filesystem::path& path);

}  // namespace lunarnav::positioning
