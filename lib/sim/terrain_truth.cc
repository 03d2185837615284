#include "sim/terrain_truth.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <vector>

#include <tbb/parallel_for.h>

#include "util/check.h"

namespace lunarnav::sim {

void TrueObstacleOptions::Validate() const {
  LN_CHECK_ARG(std::isfinite(step_height_m) && step_height_m > 0) << "true obstacles: step height must be > 0 m";
  LN_CHECK_ARG(std::isfinite(max_slope_deg) && max_slope_deg > 0 && max_slope_deg < 90)
      << "true obstacles: max slope must be in (0, 90) deg";
}

nlohmann::json TrueObstacleOptions::ToJson() const {
  return {{"step_height_m", step_height_m}, {"max_slope_deg", max_slope_deg}};
}

io::GeoRaster TerrainTruthRaster(const Terrain& terrain, double cell_m, const TrueObstacleOptions& obstacles) {
  obstacles.Validate();
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
  constexpr int kSamples = 13, kPerCell = kSamples * kSamples;
  // Every cell's samples (world x, y of sample (a, b) of cell (row, col) follow from the indices).
  std::vector<float> samples(static_cast<std::size_t>(w) * h * kPerCell);
  auto sample_x = [&](int col, int a) {
    return (static_cast<double>(i0 + col) + (a + 1e-6) / (kSamples - 1 + 2e-6)) * cell_m;
  };
  auto sample_y = [&](int row, int b) {
    return (static_cast<double>(j1 - row) + (b + 1e-6) / (kSamples - 1 + 2e-6)) * cell_m;
  };
  tbb::parallel_for(0, h, [&](int row) {
    for (int col = 0; col < w; ++col) {
      float* z = &samples[(static_cast<std::size_t>(row) * w + col) * kPerCell];
      double sum = 0, zmin = 1e300, zmax = -1e300;
      for (int b = 0; b < kSamples; ++b) {
        // Inside the cell by a hair at the edges, so that HeightAt never leaves the grid.
        const double y = sample_y(row, b);
        for (int a = 0; a < kSamples; ++a) {
          const double v = terrain.HeightAt(sample_x(col, a), y);
          z[b * kSamples + a] = static_cast<float>(v);
          sum += v;
          zmin = std::min(zmin, v);
          zmax = std::max(zmax, v);
        }
      }
      mean.at<float>(row, col) = static_cast<float>(sum / kPerCell);
      lo.at<float>(row, col) = static_cast<float>(zmin);
      hi.at<float>(row, col) = static_cast<float>(zmax);
    }
  });

  // Relief and slope: the least-squares plane of the 3 x 3 neighbourhood's cell means (x, y
  // in cells from the centre); the cell's highest sample against the neighbourhood's lowest,
  // both above that plane; the plane's slope.
  cv::Mat obstacle(h, w, CV_32FC1, cv::Scalar(0)), relief(h, w, CV_32FC1), slope(h, w, CV_32FC1);
  const double tan_max = std::tan(obstacles.max_slope_deg * M_PI / 180);
  tbb::parallel_for(0, h, [&](int row) {
    for (int col = 0; col < w; ++col) {
      double s1 = 0, sx = 0, sy = 0, sxx = 0, syy = 0, sz = 0, sxz = 0, syz = 0;
      for (int dr = -1; dr <= 1; ++dr) {
        for (int dc = -1; dc <= 1; ++dc) {
          const int r = row + dr, c = col + dc;
          if (r < 0 || c < 0 || r >= h || c >= w) continue;
          const double x = dc, y = -dr, z = mean.at<float>(r, c);
          s1 += 1;
          sx += x;
          sy += y;
          sxx += x * x;
          syy += y * y;
          sz += z;
          sxz += x * z;
          syz += y * z;
        }
      }
      // Normal equations of z = p + q x + t y on a (possibly clipped) 3 x 3 lattice: x and y
      // are uncorrelated on it, so each slope is its own regression.
      const double q = (sxx - sx * sx / s1) > 0 ? (sxz - sx * sz / s1) / (sxx - sx * sx / s1) : 0;
      const double t = (syy - sy * sy / s1) > 0 ? (syz - sy * sz / s1) / (syy - sy * sy / s1) : 0;
      const double p = (sz - q * sx - t * sy) / s1;
      auto plane = [&](double x_cells, double y_cells) { return p + q * x_cells + t * y_cells; };
      double cell_top = -1e300, around_bottom = 1e300;
      for (int dr = -1; dr <= 1; ++dr) {
        for (int dc = -1; dc <= 1; ++dc) {
          const int r = row + dr, c = col + dc;
          if (r < 0 || c < 0 || r >= h || c >= w) continue;
          const float* z = &samples[(static_cast<std::size_t>(r) * w + c) * kPerCell];
          for (int b = 0; b < kSamples; ++b) {
            for (int a = 0; a < kSamples; ++a) {
              // Sample position in cells from the centre of the middle cell.
              const double x = dc + (a / (kSamples - 1.0) - 0.5), y = -dr + (b / (kSamples - 1.0) - 0.5);
              const double above = z[b * kSamples + a] - plane(x, y);
              around_bottom = std::min(around_bottom, above);
              if (dr == 0 && dc == 0) cell_top = std::max(cell_top, above);
            }
          }
        }
      }
      int code = 0;
      if (cell_top - around_bottom >= obstacles.step_height_m) code |= 1;
      if (std::hypot(q, t) / cell_m > tan_max) code |= 2;
      obstacle.at<float>(row, col) = static_cast<float>(code);
      relief.at<float>(row, col) = static_cast<float>(cell_top - around_bottom);
      slope.at<float>(row, col) = static_cast<float>(std::atan(std::hypot(q, t) / cell_m) * 180 / M_PI);
    }
  });
  // Rocks: every cell one of whose samples their footprint covers has at least the rock's
  // height of relief, and is a step when the rock is at least a step tall.
  for (const TerrainRock& rock : terrain.Rocks()) {
    const double ca = std::cos(rock.angle_rad), sa = std::sin(rock.angle_rad);
    const int c_lo = std::max(0, static_cast<int>(std::floor((rock.x_m - rock.semi_major_m) / cell_m - i0)));
    const int c_hi = std::min(w - 1, static_cast<int>(std::floor((rock.x_m + rock.semi_major_m) / cell_m - i0)));
    const int r_lo = std::max(0, static_cast<int>(j1 - std::floor((rock.y_m + rock.semi_major_m) / cell_m)));
    const int r_hi = std::min(h - 1, static_cast<int>(j1 - std::floor((rock.y_m - rock.semi_major_m) / cell_m)));
    for (int row = r_lo; row <= r_hi; ++row) {
      for (int col = c_lo; col <= c_hi; ++col) {
        bool covered = false;
        for (int b = 0; b < kSamples && !covered; ++b) {
          for (int a = 0; a < kSamples && !covered; ++a) {
            const double dx = sample_x(col, a) - rock.x_m, dy = sample_y(row, b) - rock.y_m;
            const double u = (ca * dx + sa * dy) / rock.semi_major_m, v = (-sa * dx + ca * dy) / rock.semi_minor_m;
            covered = u * u + v * v < 1;
          }
        }
        if (!covered) continue;
        relief.at<float>(row, col) = std::max(relief.at<float>(row, col), static_cast<float>(rock.height_m));
        if (rock.height_m >= obstacles.step_height_m) {
          obstacle.at<float>(row, col) = static_cast<float>(static_cast<int>(obstacle.at<float>(row, col)) | 1);
        }
      }
    }
  }

  io::GeoRaster r;
  r.x_west_m = static_cast<double>(i0) * cell_m;
  r.y_north_m = static_cast<double>(j1 + 1) * cell_m;
  r.cell_m = cell_m;
  r.metadata["lunarnav_frame"] = "world: x east, y north, z up; metres";
  r.metadata["lunarnav_content"] = "simulate stereo: the true terrain";
  const std::array<std::pair<cv::Mat, const char*>, 6> bands = {
      {{mean, "elevation_m"}, {lo, "min_m"}, {hi, "max_m"}, {obstacle, "obstacle"}, {relief, "relief_m"}, {slope, "slope_deg"}}};
  for (const auto& [pixels, name] : bands) {
    io::RasterBand b;
    b.pixels = pixels;
    b.description = name;
    r.bands.push_back(std::move(b));
  }
  r.bands[0].metadata["meaning"] = "mean of the true surface over the cell, m";
  r.bands[1].metadata["meaning"] = "lowest point of the true surface in the cell, m";
  r.bands[2].metadata["meaning"] = "highest point of the true surface in the cell, m";
  r.bands[3].metadata["meaning"] =
      "true obstacles from the scene: 0 free, 1 step (a rock at least a step tall, or a step of the relief), "
      "2 slope, 3 both";
  r.bands[4].metadata["meaning"] =
      "true relief: the cell's highest point above the lowest of its 3 x 3 neighbourhood, both from the "
      "neighbourhood's least-squares plane, or the height of a rock whose footprint covers the cell if more, m";
  r.bands[5].metadata["meaning"] = "slope of the 3 x 3 neighbourhood's least-squares plane, deg";
  r.metadata["lunarnav_obstacles"] = obstacles.ToJson().dump();
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
