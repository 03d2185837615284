// The map in the pairs' own frames on hand-made truths: a drift common to every pair costs
// nothing there (though much globally), a pair whose pose disagrees with the map costs.
#include "evaluation/map_vehicle_eval.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

namespace lunarnav::evaluation {
namespace {

constexpr double kCell = 0.25;
constexpr int kSize = 40;  // 10 m squares

io::GeoRaster Raster(double x_west, const std::vector<std::pair<std::string, cv::Mat>>& bands) {
  io::GeoRaster r;
  r.x_west_m = x_west;
  r.y_north_m = kSize * kCell;
  r.cell_m = kCell;
  for (const auto& [name, pixels] : bands) {
    io::RasterBand b;
    b.description = name;
    b.pixels = pixels.clone();
    r.bands.push_back(std::move(b));
  }
  return r;
}

mapping::FramePose Pose(const std::string& stem, double x, double y, double z, double pitch_deg = 0) {
  mapping::FramePose p;
  p.stem = stem;
  p.x_m = x;
  p.y_m = y;
  p.z_m = z;
  p.pitch_rad = pitch_deg * M_PI / 180.0;
  return p;
}

// A sloping plane z = 0.1 x + 0.05 y with one rock cell (relief 0.3 m) at column 20, row 20;
// two pairs at x = 5 m, y = 0.5 and 1 m, heading north, each seeing the cells 2-6 m ahead
// over 3 m of width.
struct Fixture {
  cv::Mat z = cv::Mat(kSize, kSize, CV_32FC1);
  cv::Mat relief = cv::Mat(kSize, kSize, CV_32FC1, cv::Scalar(0.01));
  cv::Mat slope = cv::Mat(kSize, kSize, CV_32FC1, cv::Scalar(6));
  cv::Mat obstacle = cv::Mat(kSize, kSize, CV_32FC1, cv::Scalar(0));
  cv::Mat count = cv::Mat(kSize, kSize, CV_32FC1, cv::Scalar(9));
  std::vector<mapping::FramePose> truth = {Pose("a", 5, 0.5, 0.55), Pose("b", 5, 1.0, 0.55)};
  std::vector<std::string> stems = {"a", "b"};
  std::vector<std::vector<std::pair<std::int64_t, std::int64_t>>> cells;
  std::vector<TrueRock> rocks;
  Fixture() {
    for (int r = 0; r < kSize; ++r) {
      for (int c = 0; c < kSize; ++c) {
        z.at<float>(r, c) = static_cast<float>(0.1 * (c + 0.5) * kCell + 0.05 * (kSize - r - 0.5) * kCell);
      }
    }
    relief.at<float>(20, 20) = 0.3;
    obstacle.at<float>(20, 20) = 1;
    for (const mapping::FramePose& p : truth) {
      std::vector<std::pair<std::int64_t, std::int64_t>> seen;
      for (double y = p.y_m + 2; y < p.y_m + 6; y += kCell) {
        for (double x = 3.5; x < 6.5; x += kCell) {
          for (int ray = 0; ray < 5; ++ray) seen.emplace_back(std::floor(x / kCell), std::floor(y / kCell));
        }
      }
      cells.push_back(seen);
    }
    TrueRock rock;
    rock.x_m = 20.5 * kCell;
    rock.y_m = (kSize - 20.5) * kCell;
    rock.height_m = 0.3;
    rock.semi_major_m = rock.semi_minor_m = 0.1;
    rock.top_rays = 10;
    rocks.push_back(rock);
  }
  io::GeoRaster Truth() const { return Raster(0, {{"elevation_m", z}, {"relief_m", relief}, {"slope_deg", slope}}); }
  // The map the pairs make when every pose is off by the same (dx, 0, dz): the truth moved.
  io::GeoRaster MapMovedBy(double dx, double dz) const {
    cv::Mat moved = z + dz;
    return Raster(dx, {{"elevation_m", moved}, {"count", count}, {"obstacle", obstacle}});
  }
  VehicleFrameMapScore Score(const io::GeoRaster& map, const std::vector<mapping::FramePose>& estimated) const {
    return EvaluateMapInVehicleFrames(map, Truth(), estimated, truth, stems, cells, rocks, MapEvalOptions{}, 1);
  }
};

TEST(EvaluateMapInVehicleFrames, ADriftCommonToEveryPairCostsNothingInTheirFrames) {
  const Fixture f;
  std::vector<mapping::FramePose> estimated = f.truth;
  for (mapping::FramePose& p : estimated) {
    p.x_m += 1.0;
    p.z_m += 0.3;
  }
  const VehicleFrameMapScore v = f.Score(f.MapMovedBy(1.0, 0.3), estimated);
  EXPECT_EQ(v.pairs, 2);
  EXPECT_EQ(v.seen, 2 * 16 * 12);
  EXPECT_EQ(v.coverage, 1.0);
  EXPECT_EQ(v.samples, v.seen);
  EXPECT_LT(v.rmse_m, 1e-5);
  EXPECT_EQ(v.large_error, 0);
  EXPECT_EQ(v.obstacle_samples, 2);  // the rock's cell, once per pair
  EXPECT_EQ(v.precision, 1.0);
  EXPECT_EQ(v.rocks, 1);
  EXPECT_EQ(v.rocks_every_view, 1);
  EXPECT_EQ(v.rock_view_recall, 1.0);

  // Globally the same map is 20 cm too high and its obstacle is a metre from the rock.
  const cv::Mat seen(kSize, kSize, CV_32FC1, cv::Scalar(9));
  io::GeoRaster seen_raster = f.Truth();
  seen_raster.bands.assign(1, io::RasterBand{seen, "count", {}});
  io::GeoRaster truth = f.Truth();
  truth.bands.push_back(io::RasterBand{f.obstacle, "obstacle", {}});
  const MapEvalResult g = EvaluateMap(f.MapMovedBy(1.0, 0.3), truth, seen_raster, f.rocks, MapEvalOptions{});
  EXPECT_NEAR(g.bias_m, 0.2, 1e-5);
  EXPECT_EQ(g.precision, 0.0);

  const FramePoseErrors e = CompareFramePoses(estimated, f.truth);
  EXPECT_EQ(e.frames, 2);
  EXPECT_NEAR(e.final_horizontal_m, 1.0, 1e-12);
  EXPECT_NEAR(e.max_vertical_m, 0.3, 1e-12);
  EXPECT_NEAR(e.path_m, 0.5, 1e-12);
  EXPECT_NEAR(e.drift_pct, 200.0, 1e-9);
  EXPECT_EQ(e.pitch_rms_deg, 0.0);
}

TEST(EvaluateMapInVehicleFrames, APairWhosePoseDisagreesWithTheMapCostsInItsFrame) {
  const Fixture f;
  std::vector<mapping::FramePose> estimated = f.truth;
  estimated[1].pitch_rad = 2 * M_PI / 180;  // pair b believes it is nosed up by 2 deg
  const VehicleFrameMapScore v = f.Score(f.MapMovedBy(0, 0), estimated);
  // Ground 2-6 m ahead read 2 deg off: 7-21 cm, on half the samples.
  EXPECT_GT(v.rmse_m, 0.07);
  EXPECT_LT(v.rmse_m, 0.16);
  EXPECT_GT(v.max_abs_m, 0.18);
  EXPECT_EQ(v.worst_stem, "b");
  const FramePoseErrors e = CompareFramePoses(estimated, f.truth);
  EXPECT_NEAR(e.pitch_max_deg, 2.0, 1e-9);
  EXPECT_NEAR(e.pitch_rms_deg, std::sqrt(2.0), 1e-9);

  // Without a pose error the map is exact in every frame.
  EXPECT_LT(f.Score(f.MapMovedBy(0, 0), f.truth).rmse_m, 1e-5);
}

TEST(EvaluateMapInVehicleFrames, APoseThatIsNotFinitePlacesNothing) {
  const Fixture f;
  std::vector<mapping::FramePose> estimated = f.truth;
  estimated[1].x_m = std::nan("");
  const VehicleFrameMapScore v = f.Score(f.MapMovedBy(0, 0), estimated);
  EXPECT_EQ(v.pairs, 1);
  EXPECT_EQ(v.seen, 16 * 12);
  EXPECT_LT(v.rmse_m, 1e-5);
}

TEST(EvaluateMapInVehicleFrames, AnObstacleWhereThePairBelievesNoReliefIsAFalseAlarm) {
  Fixture f;
  f.obstacle.at<float>(20, 20) = 0;
  f.obstacle.at<float>(12, 24) = 1;  // flat ground
  const VehicleFrameMapScore v = f.Score(f.MapMovedBy(0, 0), f.truth);
  EXPECT_EQ(v.obstacle_samples, 1);  // only pair b sees row 12 (8 m north... within its 2-6 m)
  EXPECT_EQ(v.precision, 0.0);
  EXPECT_EQ(v.rocks_every_view, 0);
  EXPECT_EQ(v.rock_view_recall, 0.0);
}

}  // namespace
}  // namespace lunarnav::evaluation
