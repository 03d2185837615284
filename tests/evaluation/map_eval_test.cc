// EvaluateMap on small hand-made maps, truths and seen grounds: every score counts what it
// claims, the cells the map left empty included.
#include "evaluation/map_eval.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "io/atomic_file.h"
#include "util/errors.h"
#include "util/testing.h"

namespace lunarnav::evaluation {
namespace {

namespace fs = std::filesystem;

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

io::GeoRaster Raster(double x_west, double y_north, const std::vector<std::pair<std::string, cv::Mat>>& bands) {
  io::GeoRaster r;
  r.x_west_m = x_west;
  r.y_north_m = y_north;
  r.cell_m = 0.25;
  for (const auto& [name, pixels] : bands) {
    io::RasterBand b;
    b.description = name;
    b.pixels = pixels.clone();
    r.bands.push_back(std::move(b));
  }
  return r;
}

// A 10 x 10-cell flat truth at z = 0 with one true obstacle cell (a rock at cell (6, 4)), the
// ground seen over all of it, and a map that holds every cell with 5 points at the truth.
struct Scene {
  cv::Mat truth_z = cv::Mat(10, 10, CV_32FC1, cv::Scalar(0));
  cv::Mat truth_obstacle = cv::Mat(10, 10, CV_32FC1, cv::Scalar(0));
  cv::Mat truth_relief = cv::Mat(10, 10, CV_32FC1, cv::Scalar(0.01));
  cv::Mat truth_slope = cv::Mat(10, 10, CV_32FC1, cv::Scalar(2));
  cv::Mat seen = cv::Mat(10, 10, CV_32FC1, cv::Scalar(20));
  cv::Mat z = cv::Mat(10, 10, CV_32FC1, cv::Scalar(0));
  cv::Mat count = cv::Mat(10, 10, CV_32FC1, cv::Scalar(5));
  cv::Mat obstacle = cv::Mat(10, 10, CV_32FC1, cv::Scalar(0));
  std::vector<TrueRock> rocks;
  Scene() {
    truth_obstacle.at<float>(4, 6) = 1;
    truth_relief.at<float>(4, 6) = 0.3;
    obstacle.at<float>(4, 6) = 1;
    TrueRock rock;
    rock.x_m = 6.5 * 0.25;  // the centre of column 6
    rock.y_m = 2.5 - 4.5 * 0.25;  // of row 4 (north edge at 2.5 m)
    rock.height_m = 0.3;
    rock.semi_major_m = 0.1;
    rocks.push_back(rock);
  }
  MapEvalResult Evaluate() const {
    const io::GeoRaster map = Raster(0, 2.5, {{"elevation_m", z}, {"count", count}, {"obstacle", obstacle}});
    const io::GeoRaster truth = Raster(0, 2.5, {{"elevation_m", truth_z}, {"obstacle", truth_obstacle},
                                                {"relief_m", truth_relief}, {"slope_deg", truth_slope}});
    const io::GeoRaster seen_raster = Raster(0, 2.5, {{"count", seen}});
    return EvaluateMap(map, truth, seen_raster, rocks, MapEvalOptions{});
  }
};

TEST(EvaluateMap, APerfectMapScoresPerfectly) {
  const MapEvalResult r = Scene().Evaluate();
  EXPECT_EQ(r.cells_compared, 100);
  EXPECT_EQ(r.rmse_m, 0);
  EXPECT_EQ(r.max_abs_m, 0);
  EXPECT_EQ(r.cells_large_error, 0);
  EXPECT_EQ(r.coverage, 1.0);
  EXPECT_EQ(r.precision, 1.0);
  EXPECT_EQ(r.recall, 1.0);
  EXPECT_EQ(r.rocks, 1);
  EXPECT_EQ(r.rocks_found, 1);
}

TEST(EvaluateMap, AMissedRockLowersRecallEvenWhereTheMapIsEmpty) {
  Scene s;
  // The map holds nothing around the rock: before, a cell the map did not fill was not scored,
  // so the miss went unnoticed; now it counts against coverage, obstacle and rock recall.
  for (int row = 3; row <= 5; ++row) {
    for (int col = 5; col <= 7; ++col) {
      s.count.at<float>(row, col) = 0;
      s.z.at<float>(row, col) = kNaN;
      s.obstacle.at<float>(row, col) = kNaN;
    }
  }
  const MapEvalResult r = s.Evaluate();
  EXPECT_EQ(r.cells_compared, 91);
  EXPECT_NEAR(r.coverage, 91.0 / 100, 1e-12);
  EXPECT_EQ(r.obstacle_true, 1);
  EXPECT_EQ(r.recall, 0.0);
  EXPECT_EQ(r.rocks, 1);
  EXPECT_EQ(r.rocks_found, 0);
  EXPECT_EQ(r.rock_recall, 0.0);
  EXPECT_TRUE(std::isnan(r.precision));  // no obstacle mapped
}

// A rock counts when both cameras saw its upper half (TrueRayCounts's top_rays), not merely a
// sliver of its foot in its centre cell: with fewer than min_points rays on its top it is not
// scored, found or not; with them, a map that misses it loses recall.
TEST(EvaluateMap, ARockCountsWhenItsTopWasSeen) {
  Scene s;
  s.obstacle.at<float>(4, 6) = 0;  // the map misses the rock
  s.rocks[0].top_rays = 2;
  MapEvalResult r = s.Evaluate();
  EXPECT_EQ(r.rocks, 0);
  EXPECT_TRUE(std::isnan(r.rock_recall));
  s.rocks[0].top_rays = 3;
  r = s.Evaluate();
  EXPECT_EQ(r.rocks, 1);
  EXPECT_EQ(r.rocks_found, 0);
  // Uncounted (-1): the centre cell's rays decide, as without top_rays.
  s.rocks[0].top_rays = -1;
  EXPECT_EQ(s.Evaluate().rocks, 1);
  s.seen.at<float>(4, 6) = 0;
  EXPECT_EQ(s.Evaluate().rocks, 0);
}

// The upper half of a rock is where h (1 - q)^2 >= h / 2: q <= 1 - 1 / sqrt(2) = 0.293, along
// its rotated axes.
TEST(TrueRock, UpperHalfFollowsTheRotatedEllipse) {
  TrueRock rock;
  rock.x_m = 1.0;
  rock.y_m = 2.0;
  rock.height_m = 0.3;
  rock.semi_major_m = 0.2;
  rock.semi_minor_m = 0.1;
  rock.angle_deg = 90;  // the major axis along y
  EXPECT_TRUE(rock.InUpperHalf(1.0, 2.0));
  EXPECT_TRUE(rock.InUpperHalf(1.0, 2.1));    // q = 0.25
  EXPECT_FALSE(rock.InUpperHalf(1.0, 2.11));  // q = 0.3025
  EXPECT_FALSE(rock.InUpperHalf(1.1, 2.0));   // q = 1 across the minor axis
  EXPECT_TRUE(rock.InUpperHalf(1.05, 2.0));   // q = 0.25
}

TEST(EvaluateMap, APhantomCellRaisesTheLargestErrorAndIsCounted) {
  Scene s;
  s.z.at<float>(8, 2) = -3.0f;  // three metres below the ground
  s.z.at<float>(1, 1) = 0.1f;
  const MapEvalResult r = s.Evaluate();
  EXPECT_FLOAT_EQ(static_cast<float>(r.max_abs_m), 3.0f);
  EXPECT_EQ(r.cells_large_error, 1);
  EXPECT_NEAR(r.rmse_m, std::sqrt((9.0 + 0.01) / 100), 1e-6);
  // A false obstacle lowers precision, not recall.
  s.obstacle.at<float>(8, 2) = 1;
  const MapEvalResult f = s.Evaluate();
  EXPECT_EQ(f.obstacle_map, 2);
  EXPECT_EQ(f.obstacle_fp, 1);
  EXPECT_EQ(f.precision, 0.5);
  EXPECT_EQ(f.recall, 1.0);
}

TEST(EvaluateMap, PrecisionCountsAnObstacleOnRealReliefThoughNotAnObstacleAsNoFalseAlarm) {
  Scene s;
  // Cell (1, 1): 17 cm of relief (no true obstacle, but real); cell (8, 8): a 27 deg slope;
  // cell (8, 1): 14 cm and 24 deg, below both bars. Obstacles mapped on all three.
  s.truth_relief.at<float>(1, 1) = 0.17f;
  s.truth_slope.at<float>(8, 8) = 27;
  s.truth_relief.at<float>(8, 1) = 0.14f;
  s.truth_slope.at<float>(8, 1) = 24;
  for (auto [row, col] : {std::pair{1, 1}, {8, 8}, {8, 1}}) s.obstacle.at<float>(row, col) = 1;
  const MapEvalResult r = s.Evaluate();
  EXPECT_EQ(r.obstacle_map, 4);
  EXPECT_EQ(r.obstacle_tp, 3);
  EXPECT_EQ(r.obstacle_fp, 1);
  EXPECT_EQ(r.recall, 1.0);  // recall still asks for the true obstacle only
  // Within the tolerance (one cell) of real relief is real: the false alarm moves next to it.
  s.obstacle.at<float>(8, 1) = 0;
  s.obstacle.at<float>(1, 2) = 1;
  EXPECT_EQ(s.Evaluate().obstacle_fp, 0);
}

TEST(EvaluateMap, OnlyTheGroundSeenIsScoredForCoverage) {
  Scene s;
  // The cameras saw the western half only; the map's eastern half is no coverage gain, and
  // an unmapped western cell is a loss.
  s.seen.colRange(5, 10).setTo(0);
  s.count.at<float>(0, 0) = 1;  // below min_points: not covered
  const MapEvalResult r = s.Evaluate();
  EXPECT_EQ(r.cells_seen, 50);
  EXPECT_EQ(r.cells_seen_mapped, 49);
  EXPECT_EQ(r.obstacle_true, 0);  // the rock's cell was not seen
  EXPECT_EQ(r.rocks, 0);
}

TEST(EvaluateMap, RefusesRastersOffTheLattice) {
  Scene s;
  const io::GeoRaster map = Raster(0.1, 2.5, {{"elevation_m", s.z}, {"count", s.count}, {"obstacle", s.obstacle}});
  const io::GeoRaster truth = Raster(0, 2.5, {{"elevation_m", s.truth_z}, {"obstacle", s.truth_obstacle},
                                              {"relief_m", s.truth_relief}, {"slope_deg", s.truth_slope}});
  const io::GeoRaster seen = Raster(0, 2.5, {{"count", s.seen}});
  EXPECT_THROW(EvaluateMap(map, truth, seen, s.rocks, MapEvalOptions{}), InputError);
}


// A straight corridor north from (2.5, 0): the map holds every cell but a strip 0.5 m deep
// across the whole corridor at 5-5.5 m ahead, and a strip nobody saw at 7-7.25 m (occluded:
// no gap). The longest gap is the strip's depth, found in its pair's frame.
TEST(CorridorGaps, TheLongestGapIsTheDepthOfTheStripSeenButNotMapped) {
  util::ScopedTempDir tmp;
  fs::create_directories(tmp.path() / "truth");
  io::WriteFileAtomic(tmp.path() / "truth" / "poses.csv",
                      "stem,t_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg\n000000,0,2.5,0,0,0,0,0\n"
                      "000001,3.2,2.5,0.5,0,0,0,0\n");
  cv::Mat count(40, 20, CV_32FC1, cv::Scalar(5)), seen(40, 20, CV_32FC1, cv::Scalar(20));
  auto row_of = [](double y) { return static_cast<int>(std::floor((10.0 - y) / 0.25)); };  // north edge 10 m
  for (double y = 5.0; y < 5.5; y += 0.25) count.row(row_of(y)).setTo(0);
  count.row(row_of(7.0)).setTo(0);
  seen.row(row_of(7.0)).setTo(0);
  const io::GeoRaster map = Raster(0, 10, {{"count", count}});
  const io::GeoRaster seen_raster = Raster(0, 10, {{"count", seen}});
  MapEvalOptions options;
  options.requested_y_m = {{"000000", {2.0, 6.0}}, {"000001", {6.0, 8.0}}};
  MapEvalResult result;
  MeasureCorridorGaps(map, seen_raster, tmp.path(), options, &result);
  EXPECT_DOUBLE_EQ(result.corridor_gap_m, 0.5);
  EXPECT_EQ(result.corridor_gap_stem, "000000");

  // Mapped again: no gap; without requests: not measured.
  count.setTo(5);
  MeasureCorridorGaps(Raster(0, 10, {{"count", count}}), seen_raster, tmp.path(), options, &result);
  EXPECT_DOUBLE_EQ(result.corridor_gap_m, 0.0);
  MeasureCorridorGaps(map, seen_raster, tmp.path(), MapEvalOptions{}, &result);
  EXPECT_TRUE(std::isnan(result.corridor_gap_m));
}

}  // namespace
}  // namespace lunarnav::evaluation
