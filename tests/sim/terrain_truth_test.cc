#include "sim/terrain_truth.h"

#include <cmath>

#include <gtest/gtest.h>

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
  const io::GeoRaster r = TerrainTruthRaster(terrain, 0.25, mapping::ObstacleOptions());
  ASSERT_EQ(r.Width(), 24);   // 6 m of whole cells
  ASSERT_EQ(r.Height(), 20);  // 5 m
  EXPECT_DOUBLE_EQ(r.x_west_m, -3.0);
  EXPECT_DOUBLE_EQ(r.y_north_m, 5.0);
  const cv::Mat& e = r.bands[r.BandIndex("elevation_m")].pixels;
  const cv::Mat& lo = r.bands[r.BandIndex("min_m")].pixels;
  const cv::Mat& hi = r.bands[r.BandIndex("max_m")].pixels;
  const cv::Mat& ob = r.bands[r.BandIndex("obstacle")].pixels;
  for (int row = 0; row < r.Height(); ++row) {
    for (int col = 0; col < r.Width(); ++col) {
      const double x = r.CellCentreX(col);
      EXPECT_NEAR(e.at<float>(row, col), 0.1 * x, 1e-5);
      EXPECT_NEAR(lo.at<float>(row, col), 0.1 * (x - 0.125), 1e-5);
      EXPECT_NEAR(hi.at<float>(row, col), 0.1 * (x + 0.125), 1e-5);
      EXPECT_EQ(ob.at<float>(row, col), 0.0f);  // 5.7 deg, no step
    }
  }
}

TEST(TerrainTruthRaster, RocksTallerThanTheLimitAreObstaclesWhereTheyStand) {
  TerrainOptions o = FlatTerrain(6, 12, 0.5);
  o.seed = 7;
  const Terrain terrain(o);
  const io::GeoRaster r = TerrainTruthRaster(terrain, 0.25, mapping::ObstacleOptions());
  const cv::Mat& hi = r.bands[r.BandIndex("max_m")].pixels;
  const cv::Mat& ob = r.bands[r.BandIndex("obstacle")].pixels;
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
  }
  EXPECT_GT(tall, 0);  // 72 rocks, 4 % of them above 25 cm (N(>h) ~ h^-2 from 5 cm): a few
}

}  // namespace
}  // namespace lunarnav::sim
