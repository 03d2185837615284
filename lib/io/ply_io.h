// Point clouds as PLY files (binary little-endian), as CloudCompare, MeshLab, Open3D and PCL
// read them.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace lunarnav::io {

/// A point cloud read from a PLY file.
struct PlyPointCloud {
  std::vector<cv::Point3f> points;
  std::vector<cv::Vec3b> colours;     ///< Red, green, blue per point; empty when the file has none.
  std::vector<std::string> comments;  ///< The header's comment lines, without "comment ".
};

/// Writes the valid points of an XYZ map as a PLY point cloud: header
/// "ply / format binary_little_endian 1.0 / comment ... / element vertex N / property float x,
/// y, z [/ property uchar red, green, blue] / end_header", then one record per point in row
/// order. A point is valid when its three coordinates are finite (NaN marks no point).
/// Written under a hidden temporary name and renamed.
/// @param xyz  CV_32FC3 map.
/// @param colour  empty (no colour), CV_8UC1 (grey, written as equal red, green and blue, which
///        both MeshLab and CloudCompare display) or CV_8UC3 in red, green, blue order; the size
///        of `xyz`.
/// @param comments  header comment lines (no line breaks).
/// @return the number of points written.
/// @throws std::invalid_argument for bad arguments; std::runtime_error when writing fails.
std::int64_t WritePlyAtomic(const std::filesystem::path& path, const cv::Mat& xyz, const cv::Mat& colour = {},
                            const std::vector<std::string>& comments = {});

/// Reads the vertices of a binary little-endian PLY file: float or double x, y, z and, when
/// present, uchar red, green, blue; other scalar vertex properties are skipped.
/// @throws InputError naming the file and the problem (not a PLY, ASCII or big-endian format,
///         no x/y/z, list properties in the vertex element, truncated data).
PlyPointCloud ReadPly(const std::filesystem::path& path);

}  // namespace lunarnav::io
