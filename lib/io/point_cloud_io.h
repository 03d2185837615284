// LiDAR sweeps and other point clouds in: KITTI's Velodyne .bin files, PLY (binary
// little-endian, through ply_io) and PCD (PCL's: DATA ascii or binary). docs/formats.md,
// "Point clouds".
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <vector>

namespace lunarnav::io {

/// The most points a cloud file may hold (a KITTI sweep holds ~120,000).
inline constexpr std::int64_t kMaxCloudPoints = 50'000'000;

/// True for the extensions ReadPointCloud reads: .bin, .ply, .pcd.
bool HasPointCloudExtension(const std::filesystem::path& path);

/// Reads the x, y, z of every point of a cloud, by its extension:
/// - `.bin`: KITTI's Velodyne sweeps, float32 x, y, z, reflectance per point, little-endian;
/// - `.ply`: ReadPly;
/// - `.pcd`: PCL's format, version 0.7 or older header, FIELDS with x, y and z (float32 or
///   float64), DATA ascii or binary (binary_compressed is refused by name).
/// Points with a non-finite coordinate (PCL's NaN for no return) are dropped.
/// @throws InputError naming the file: unreadable, of another size than its header or record
///         size says, more than kMaxCloudPoints points, a malformed header or line.
std::vector<Eigen::Vector3f> ReadPointCloud(const std::filesystem::path& path);

}  // namespace lunarnav::io
