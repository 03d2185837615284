#include "sim/terrain_truth.h"

#include <cmath>
#include <cstdio>

#include <tbb/parallel_for.h>

namespace lunarnav::sim {

io::GeoRaster TerrainTruthRaster(const Terrain& terrain, double cell_m, const mapping::ObstacleOptions& obstacles) {
  const TerrainOptions& o = terrain.options();
  const double x1 = o.min_x_m + (terrain.GridWidth() - 1) * o.cell_m;
  const double y1 = o.min_y_m + (terrain.GridHeight() - 1) * o.cell_m;
  // Whole cells inside the height field.
  const auto i0 = static_cast<std::int64_t>(std::ceil(o.min_x_m / cell_m - 1e-9));
  const auto i1 = static_cast<std::int64_t>(std::floor(x1 / cell_m + 1e-9)) - 1;
  const auto j0 = static_cast<std::int64_t>(std::ceil(o.min_y_m / cell_m - 1e-9));
  const auto j1 = static_cast<std::int64_t>(std::floor(y1 / cell_m + 1e-9)) - 1;
  const int w = static_cast<int>(i1 - i0 + 1), h = static_cast<int>(j1 - j0 + 1);
  cv::Mat mean(h, w, CV_32FC1), lo(h, w, CV_32FC1), hi(h, w, CV_32FC1);
  constexpr int kSamples = 13;
  tbb::parallel_for(0, h, [&](int row) {
    const std::int64_t j = j1 - row;
    for (int col = 0; col < w; ++col) {
      const std::int64_t i = i0 + col;
      double sum = 0, zmin = 1e300, zmax = -1e300;
      for (int b = 0; b < kSamples; ++b) {
        // Inside the cell by a hair at the edges, so that HeightAt never leaves the grid.
        const double y = (static_cast<double>(j) + (b + 1e-6) / (kSamples - 1 + 2e-6)) * cell_m;
        for (int a = 0; a < kSamples; ++a) {
          const double x = (static_cast<double>(i) + (a + 1e-6) / (kSamples - 1 + 2e-6)) * cell_m;
          const double z = terrain.HeightAt(x, y);
          sum += z;
          zmin = std::min(zmin, z);
          zmax = std::max(zmax, z);
        }
      }
      mean.at<float>(row, col) = static_cast<float>(sum / (kSamples * kSamples));
      lo.at<float>(row, col) = static_cast<float>(zmin);
      hi.at<float>(row, col) = static_cast<float>(zmax);
    }
  });
  io::GeoRaster r;
  r.x_west_m = static_cast<double>(i0) * cell_m;
  r.y_north_m = static_cast<double>(j1 + 1) * cell_m;
  r.cell_m = cell_m;
  r.metadata["lunarnav_frame"] = "world: x east, y north, z up; metres";
  r.metadata["lunarnav_content"] = "simulate stereo: the true terrain";
  const cv::Mat obstacle = mapping::DetectObstacles(mean, lo, hi, cv::Mat(), cell_m, obstacles);
  const std::array<std::pair<cv::Mat, const char*>, 4> bands = {{{mean, "elevation_m"}, {lo, "min_m"}, {hi, "max_m"},
                                                                  {obstacle, "obstacle"}}};
  for (const auto& [pixels, name] : bands) {
    io::RasterBand b;
    b.pixels = pixels;
    b.description = name;
    r.bands.push_back(std::move(b));
  }
  r.bands[0].metadata["meaning"] = "mean of the true surface over the cell, m";
  r.bands[1].metadata["meaning"] = "lowest point of the true surface in the cell, m";
  r.bands[2].metadata["meaning"] = "highest point of the true surface in the cell, m";
  r.bands[3].metadata["meaning"] = "terrain-map's obstacle rule on the true surface: 0 free, 1 step, 2 slope, 3 both";
  r.metadata["lunarnav_obstacles"] = mapping::ObstacleOptions(obstacles).ToJson().dump();
  return r;
}

std::string RocksCsv(const Terrain& terrain) {
  std::string s =
      "# lunarnav simulated rocks: centre (world x east, y north, m), height above the relief (m), semi-axes (m),\n"
      "# angle of the major axis from x towards y (deg); surface h (1 - q)^2, q the squared elliptical radius\n"
      "x_m,y_m,height_m,semi_major_m,semi_minor_m,angle_deg\n";
  char buf[160];
  for (const TerrainRock& r : terrain.Rocks()) {
    std::snprintf(buf, sizeof buf, "%.4f,%.4f,%.4f,%.4f,%.4f,%.3f\n", r.x_m, r.y_m, r.height_m, r.semi_major_m,
                  r.semi_minor_m, r.angle_rad * 180 / M_PI);
    s += buf;
  }
  return s;
}

}  // namespace lunarnav::sim
