// What the map scores (map_eval, lidar_map_eval) share about reading rasters on one lattice:
// a band by name, a cell's value, and where one raster's cells fall in another's.
#pragma once

#include <cmath>
#include <limits>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "io/geotiff_io.h"
#include "mapping/frame_poses.h"
#include "sim/vehicle_pose.h"
#include "util/check.h"

namespace lunarnav::evaluation::internal {

/// The Float32 band `name` of `r`. @throws InputError naming `what` when it has none.
inline const cv::Mat& FloatBand(const io::GeoRaster& r, const std::string& name, const std::string& what) {
  const int i = r.BandIndex(name);
  LN_CHECK_INPUT(i >= 0) << what << ": no band '" << name << "'";
  const cv::Mat& pixels = r.bands[static_cast<std::size_t>(i)].pixels;
  LN_CHECK_INPUT(pixels.type() == CV_32FC1) << what << ": band '" << name << "' is not Float32";
  return pixels;
}

/// The value of a CV_32FC1 raster at (col, row), NaN outside it.
inline float ValueAt(const cv::Mat& m, int col, int row) {
  if (col < 0 || row < 0 || col >= m.cols || row >= m.rows) return std::numeric_limits<float>::quiet_NaN();
  return m.at<float>(row, col);
}

/// Where raster b's cells fall in raster a's: b(col, row) = a(col + dc, row + dr).
/// @throws InputError naming `what` (b) when the cell sizes differ or b is off a's lattice.
inline void LatticeOffset(const io::GeoRaster& a, const io::GeoRaster& b, const std::string& what, int* dc, int* dr) {
  LN_CHECK_INPUT(std::abs(a.cell_m - b.cell_m) <= 1e-9 * a.cell_m)
      << what << ": cell " << b.cell_m << " m, the map's is " << a.cell_m << " m";
  const double fc = (b.x_west_m - a.x_west_m) / a.cell_m, fr = (a.y_north_m - b.y_north_m) / a.cell_m;
  LN_CHECK_INPUT(std::abs(fc - std::round(fc)) < 1e-6 && std::abs(fr - std::round(fr)) < 1e-6)
      << what << ": not on the map's cell lattice";
  *dc = static_cast<int>(std::lround(fc));
  *dr = static_cast<int>(std::lround(fr));
}

/// a / b, NaN when b is 0.
inline double Ratio(long a, long b) {
  return b > 0 ? static_cast<double>(a) / static_cast<double>(b) : std::numeric_limits<double>::quiet_NaN();
}

/// A number for summary.json: null when not finite.
inline nlohmann::json Number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

/// A pose placed with the simulator's convention, with which it wrote the truth (code of the
/// evaluation's own, not the mapper's).
inline Eigen::Isometry3d TrueWorldFromVehicle(const mapping::FramePose& p) {
  sim::VehiclePose pose;
  pose.x_m = p.x_m;
  pose.y_m = p.y_m;
  pose.z_m = p.z_m;
  pose.heading_rad = p.heading_rad;
  pose.pitch_rad = p.pitch_rad;
  pose.roll_rad = p.roll_rad;
  return pose.WorldFromVehicle();
}

}  // namespace lunarnav::evaluation::internal
