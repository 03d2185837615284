#include "sim/terrain_truth.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "mapping/frame_poses.h"
#include "sim/vehicle_pose.h"

namespace lunarnav::sim {
namespace {

// A terrain without relief over x in [-half_width, half_width], y in [0, length].
TerrainOptions FlatTerrain(double half_width_m, double length_m, double rocks_per_m2) {
  TerrainOptions o;
  o.min_x_m = -half_width_m;
  o.max_x_m = half_width_m;
  o.min_y_m = 0;
  o.max_y_m = length_m;
  o.relief_amplitude_m = 0;
  o.rock_density_per_m2 = rocks_per_m2;
  return o;
}

TEST(TerrainTruthRaster, APlaneGivesItsHeightAtCellCentresAndItsExtremesAtTheEdges) {
  TerrainOptions o = FlatTerrain(3, 5, 0);
  o.slope_x = 0.1;  // 10 cm per metre east
  const Terrain terrain(o);
  const io::GeoRaster r = TerrainTruthRaster(terrain, 0.25);
  ASSERT_EQ(r.Width(), 24);   // 6 m of whole cells
  ASSERT_EQ(r.Height(), 20);  // 5 m
  EXPECT_DOUBLE_EQ(r.x_west_m, -3.0);
  EXPECT_DOUBLE_EQ(r.y_north_m, 5.0);
  const cv::Mat& e = r.bands[r.BandIndex("elevation_m")].pixels;
  const cv::Mat& lo = r.bands[r.BandIndex("min_m")].pixels;
  const cv::Mat& hi = r.bands[r.BandIndex("max_m")].pixels;
  const cv::Mat& ob = r.bands[r.BandIndex("obstacle")].pixels;
  const cv::Mat& relief = r.bands[r.BandIndex("relief_m")].pixels;
  const cv::Mat& slope = r.bands[r.BandIndex("slope_deg")].pixels;
  for (int row = 0; row < r.Height(); ++row) {
    for (int col = 0; col < r.Width(); ++col) {
      const double x = r.CellCentreX(col);
      EXPECT_NEAR(e.at<float>(row, col), 0.1 * x, 1e-5);
      EXPECT_NEAR(lo.at<float>(row, col), 0.1 * (x - 0.125), 1e-5);
      EXPECT_NEAR(hi.at<float>(row, col), 0.1 * (x + 0.125), 1e-5);
      EXPECT_EQ(ob.at<float>(row, col), 0.0f);  // 5.7 deg, no step
      // An even slope: no relief above its own plane, and the plane's slope, atan(0.1).
      EXPECT_NEAR(relief.at<float>(row, col), 0.0, 1e-5);
      EXPECT_NEAR(slope.at<float>(row, col), std::atan(0.1) * 180 / M_PI, 1e-3);
    }
  }
}

TEST(TerrainTruthRaster, RocksTallerThanTheLimitAreObstaclesWhereTheyStand) {
  TerrainOptions o = FlatTerrain(6, 12, 0.5);
  o.seed = 7;
  const Terrain terrain(o);
  const io::GeoRaster r = TerrainTruthRaster(terrain, 0.25);
  const cv::Mat& hi = r.bands[r.BandIndex("max_m")].pixels;
  const cv::Mat& ob = r.bands[r.BandIndex("obstacle")].pixels;
  const cv::Mat& relief = r.bands[r.BandIndex("relief_m")].pixels;
  int tall = 0;
  for (const TerrainRock& rock : terrain.Rocks()) {
    const int col = static_cast<int>(std::floor((rock.x_m - r.x_west_m) / r.cell_m));
    const int row = static_cast<int>(std::floor((r.y_north_m - rock.y_m) / r.cell_m));
    if (col < 1 || row < 1 || col >= r.Width() - 1 || row >= r.Height() - 1) continue;
    if (rock.height_m > 0.25) {
      ++tall;
      // Its top is in its cell (sampled every 2 cm, on a 2 cm height field: within 10 %).
      EXPECT_GE(hi.at<float>(row, col), 0.9 * rock.height_m);
      EXPECT_GT(ob.at<float>(row, col), 0) << rock.x_m << ", " << rock.y_m << ": " << rock.height_m << " m";
    }
    // Every rock's cell has at least its height of relief (the rock covers the cell).
    EXPECT_GE(relief.at<float>(row, col), rock.height_m - 1e-6) << rock.x_m << ", " << rock.y_m;
  }
  EXPECT_GT(tall, 0);  // 72 rocks, 4 % of them above 25 cm (N(>h) ~ h^-2 from 5 cm): a few
}


TEST(TerrainTruthRaster, SlopesSteeperThanTheLimitAreObstaclesAndGentlerOnesAreNot) {
  for (const double slope_deg : {20.0, 40.0}) {
    TerrainOptions o = FlatTerrain(3, 5, 0);
    o.slope_y = std::tan(slope_deg * M_PI / 180);
    const Terrain terrain(o);
    const io::GeoRaster r = TerrainTruthRaster(terrain, 0.25);
    const cv::Mat& ob = r.bands[r.BandIndex("obstacle")].pixels;
    int slopes = 0, steps = 0;
    for (int row = 1; row < r.Height() - 1; ++row) {
      for (int col = 1; col < r.Width() - 1; ++col) {
        const int code = static_cast<int>(ob.at<float>(row, col));
        slopes += (code & 2) != 0;
        steps += (code & 1) != 0;
      }
    }
    const int inner = (r.Height() - 2) * (r.Width() - 2);
    EXPECT_EQ(slopes, slope_deg > 30 ? inner : 0) << slope_deg;
    EXPECT_EQ(steps, 0) << slope_deg;  // an even slope is no step, however steep
  }
}

TEST(TerrainTruthRaster, SmallRocksAreNoObstacles) {
  TerrainOptions o = FlatTerrain(6, 12, 0.5);
  o.seed = 7;
  const Terrain terrain(o);
  const io::GeoRaster r = TerrainTruthRaster(terrain, 0.25);
  const cv::Mat& ob = r.bands[r.BandIndex("obstacle")].pixels;
  // A cell is an obstacle only where a rock at least 20 cm tall stands on it or next to it (its
  // 3 x 3 neighbourhood's relief): count the cells near no such rock that are marked.
  int marked_far_from_tall_rocks = 0, small_rock_cells = 0;
  for (int row = 0; row < r.Height(); ++row) {
    for (int col = 0; col < r.Width(); ++col) {
      const double x = r.CellCentreX(col), y = r.y_north_m - (row + 0.5) * r.cell_m;
      bool near_tall = false, on_small = false;
      for (const TerrainRock& rock : terrain.Rocks()) {
        const double d = std::hypot(x - rock.x_m, y - rock.y_m);
        if (rock.height_m >= 0.2 && d < rock.semi_major_m + 0.6) near_tall = true;
        if (rock.height_m < 0.15 && d < 0.1) on_small = true;
      }
      if (near_tall) continue;
      small_rock_cells += on_small;
      marked_far_from_tall_rocks += ob.at<float>(row, col) > 0;
    }
  }
  EXPECT_GT(small_rock_cells, 10);
  EXPECT_EQ(marked_far_from_tall_rocks, 0);
}

// The simulator writes poses with its own copy of the convention; the mapper reads them with
// its own. They must agree.
TEST(VehiclePose, AgreesWithTheMappersConvention) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI), offset(-50, 50);
  for (int i = 0; i < 100; ++i) {
    VehiclePose p;
    p.x_m = offset(rng);
    p.y_m = offset(rng);
    p.z_m = offset(rng);
    p.heading_rad = angle(rng);
    p.pitch_rad = 0.4 * angle(rng);
    p.roll_rad = 0.4 * angle(rng);
    const Eigen::Isometry3d a = p.WorldFromVehicle();
    const Eigen::Isometry3d b = mapping::WorldFromVehicle(p.x_m, p.y_m, p.z_m, p.heading_rad, p.pitch_rad, p.roll_rad);
    EXPECT_LT((a.matrix() - b.matrix()).norm(), 1e-12);
  }
  // Heading is clockwise from north: 90 deg turns the vehicle's forward axis (Y) east (+x).
  VehiclePose east;
  east.heading_rad = M_PI / 2;
  EXPECT_LT((east.WorldFromVehicle().linear() * Eigen::Vector3d::UnitY() - Eigen::Vector3d::UnitX()).norm(), 1e-12);
}

}  // namespace
}  // namespace lunarnav::sim
