#include "evaluation/lidar_map_eval.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

namespace lunarnav::evaluation {
namespace {

constexpr double kCell = 0.25;

// A band of a raster: its pixels and name.
io::RasterBand NamedBand(const cv::Mat& pixels, const char* name) {
  io::RasterBand band;
  band.pixels = pixels;
  band.description = name;
  return band;
}

// A level KITTI-like rectified rig: 1242 x 375, f = 721 px, 0.54 m baseline, 1.65 m up.
calib::StereoRig KittiLikeRig() {
  calib::StereoRig rig;
  rig.width_px = 1242;
  rig.height_px = 375;
  Eigen::Matrix3d k;
  k << 721, 0, 609, 0, 721, 173, 0, 0, 1;
  rig.left.K = rig.right.K = k;
  rig.right_from_left_t_m = Eigen::Vector3d(-0.54, 0, 0);
  rig.mast = calib::MastPose{1.65, 0.0, 0.0, 0.0};
  calib::RectifiedGeometry g;
  g.P_left.leftCols<3>() = k;
  g.P_right.leftCols<3>() = k;
  g.P_right(0, 3) = -721 * 0.54;
  g.width_px = 1242;
  g.height_px = 375;
  rig.rectified = g;
  return rig;
}

// Two sweeps of flat ground z = 0 over x in [-12, 12], y in [-2, 22] (a return every 5 cm)
// with a box 1 m square and 0.5 m tall at x 1.5..2.5, y 7.5..8.5 (its top and faces).
std::vector<LidarSweep> Sweeps() {
  std::vector<LidarSweep> sweeps(2);
  sweeps[0].stem = "a";
  sweeps[1].stem = "b";
  int k = 0;
  for (double x = -12; x < 12; x += 0.05) {
    for (double y = -2; y < 22; y += 0.05) {
      const bool on_box = x > 1.5 && x < 2.5 && y > 7.5 && y < 8.5;
      sweeps[static_cast<std::size_t>(k++ % 2)].points.emplace_back(x + 0.001, y + 0.001, on_box ? 0.5f : 0.0f);
    }
  }
  for (double z = 0; z < 0.5; z += 0.05) {
    for (double x = 1.5; x < 2.5; x += 0.05) sweeps[0].points.emplace_back(x + 0.001, 7.501, z);
  }
  return sweeps;
}

// A map on the lattice of world-anchored 25 cm cells, x in [-12, 12), y in [-2, 22): the true
// surface everywhere (the box's top on its cells, which are obstacles), 10 points a cell.
io::GeoRaster TrueMap() {
  io::GeoRaster map;
  map.cell_m = kCell;
  map.x_west_m = -12;
  map.y_north_m = 22;
  const int n = 96;
  cv::Mat elevation(n, n, CV_32FC1, cv::Scalar(0)), count(n, n, CV_32FC1, cv::Scalar(10)),
      obstacle(n, n, CV_32FC1, cv::Scalar(0));
  for (int row = 0; row < n; ++row) {
    for (int col = 0; col < n; ++col) {
      const double x = map.CellCentreX(col), y = map.CellCentreY(row);
      if (x > 1.5 && x < 2.5 && y > 7.5 && y < 8.5) {
        elevation.at<float>(row, col) = 0.5f;
        obstacle.at<float>(row, col) = 1;
      }
    }
  }
  map.bands.push_back(NamedBand(elevation, "elevation_m"));
  map.bands.push_back(NamedBand(count, "count"));
  map.bands.push_back(NamedBand(obstacle, "obstacle"));
  return map;
}

cv::Mat& MapBand(io::GeoRaster* map, const std::string& name) {
  return map->bands[static_cast<std::size_t>(map->BandIndex(name))].pixels;
}

// The map cell holding world (x, y).
cv::Point CellAt(const io::GeoRaster& map, double x, double y) {
  return {static_cast<int>(std::floor((x - map.x_west_m) / kCell)),
          static_cast<int>(std::floor((map.y_north_m - y) / kCell))};
}

struct Scene {
  LidarEvalOptions options;
  std::vector<LidarSweep> sweeps = Sweeps();
  io::GeoRaster map = TrueMap();
  io::GeoRaster truth;
  std::vector<mapping::FramePose> pairs;
  calib::StereoRig rig = KittiLikeRig();
  Scene() {
    options.band_min_y_m = 5;
    options.band_max_y_m = 12;
    truth = GridLidarTruth(sweeps, map, options);
    mapping::FramePose p;
    p.stem = "000000";
    pairs.push_back(p);
  }
  LidarEvalResult Score() const { return EvaluateMapAgainstLidar(map, truth, pairs, rig, options); }
};

TEST(EvaluateMapAgainstLidar, AMapOfTheTrueSurfaceScoresPerfectly) {
  const Scene s;
  const LidarEvalResult r = s.Score();
  EXPECT_GT(r.flat_cells, 5000);
  EXPECT_GT(r.cells_compared, 5000);
  EXPECT_LT(r.max_abs_m, 1e-6);
  EXPECT_EQ(r.cells_large_error, 0);
  EXPECT_GT(r.band_cells, 500);
  EXPECT_DOUBLE_EQ(r.coverage, 1.0);
  EXPECT_EQ(r.obstacle_map, 16);  // the box's 4 x 4 cells
  EXPECT_DOUBLE_EQ(r.precision, 1.0);
  EXPECT_EQ(r.objects, 1);
  EXPECT_EQ(r.objects_found, 1);
  // The box and the cells beside it are not flat ground.
  const cv::Point box = CellAt(s.truth, 2.0, 8.0);
  EXPECT_TRUE(std::isnan(s.truth.bands[0].pixels.at<float>(box)));
}

TEST(EvaluateMapAgainstLidar, APhantomRaisesTheLargestErrorAndACellOff) {
  Scene s;
  MapBand(&s.map, "elevation_m").at<float>(CellAt(s.map, -3.1, 9.1)) = 0.6f;
  const LidarEvalResult r = s.Score();
  EXPECT_NEAR(r.max_abs_m, 0.6, 1e-6);
  EXPECT_EQ(r.cells_large_error, 1);
  EXPECT_NEAR(r.large_error_x_m, -3.125, 1e-9);
  EXPECT_NEAR(r.large_error_y_m, 9.125, 1e-9);
  EXPECT_GT(r.rmse_m, 0);
  EXPECT_DOUBLE_EQ(r.median_m, 0);
}

TEST(EvaluateMapAgainstLidar, AMissedObjectLowersRecallAndAFalseObstacleLowersPrecision) {
  Scene s;
  MapBand(&s.map, "obstacle").setTo(0);
  MapBand(&s.map, "obstacle").at<float>(CellAt(s.map, -5.1, 10.1)) = 1;  // on flat ground
  const LidarEvalResult r = s.Score();
  EXPECT_EQ(r.objects, 1);
  EXPECT_EQ(r.objects_found, 0);
  EXPECT_EQ(r.obstacle_judged, 1);
  EXPECT_DOUBLE_EQ(r.precision, 0.0);
}

TEST(EvaluateMapAgainstLidar, TheLateralProfileShowsWhereTheErrorGrows) {
  // A map whose ground rises 1 cm a metre to the right of the path (the pair drives north from
  // the origin: right is east) and is true on the left.
  Scene s;
  cv::Mat& elevation = MapBand(&s.map, "elevation_m");
  for (int row = 0; row < elevation.rows; ++row) {
    for (int col = 0; col < elevation.cols; ++col) {
      const double x = s.map.CellCentreX(col);
      if (x > 0 && elevation.at<float>(row, col) == 0) elevation.at<float>(row, col) = static_cast<float>(0.01 * x);
    }
  }
  const LidarEvalResult r = s.Score();
  ASSERT_FALSE(r.lateral_profile.empty());
  long cells = 0;
  for (const LateralBin& b : r.lateral_profile) {
    cells += b.cells;
    ASSERT_GT(b.cells, 0);
    EXPECT_DOUBLE_EQ(b.to_m - b.from_m, 1.0);
    // Every cell of a band to the right is off by 1 cm a metre of its offset; to the left, true.
    const double low = b.from_m >= 0 ? 0.01 * b.from_m - 1e-6 : -1e-6, high = b.from_m >= 0 ? 0.01 * b.to_m : 1e-6;
    EXPECT_TRUE(b.median_m >= low && b.median_m <= high) << b.from_m << ": " << b.median_m;
    EXPECT_TRUE(b.rmse_m >= low && b.rmse_m <= high) << b.from_m << ": " << b.rmse_m;
  }
  EXPECT_EQ(cells, r.cells_compared);
  EXPECT_LT(r.lateral_profile.front().from_m, -5);
  EXPECT_GT(r.lateral_profile.back().to_m, 5);
}

TEST(EvaluateMapAgainstLidar, CoverageCountsTheBandsGroundInSightOnly) {
  Scene s;
  cv::Mat& count = MapBand(&s.map, "count");
  // Ground hidden behind the box (from the camera 1.65 m up) and ground outside the band:
  // neither counts when the map leaves it empty.
  count.at<float>(CellAt(s.map, 2.1, 9.6)) = 0;
  count.at<float>(CellAt(s.map, 0.1, 3.1)) = 0;
  EXPECT_DOUBLE_EQ(s.Score().coverage, 1.0);
  // Ground in sight within the band does.
  count.at<float>(CellAt(s.map, -2.1, 9.6)) = 0;
  const LidarEvalResult r = s.Score();
  EXPECT_EQ(r.band_mapped, r.band_cells - 1);
}

TEST(EvaluateMapAgainstLidar, CellsAPairFarInTimeFromEverySweepSawAreNotJudged) {
  Scene s;
  // A second pair 3 m on, 5 s after the only sweep, saw a cyclist 0.6 m up at 13 m: no sweep
  // shows what stood there then.
  mapping::FramePose later;
  later.stem = "000050";
  later.t_s = 5;
  later.y_m = 3;
  s.pairs.push_back(later);
  MapBand(&s.map, "elevation_m").at<float>(CellAt(s.map, -3.1, 13.1)) = 0.6f;
  const LidarEvalResult untimed = s.Score();
  EXPECT_EQ(untimed.cells_large_error, 1);
  const LidarEvalResult timed = EvaluateMapAgainstLidar(s.map, s.truth, s.pairs, s.rig, s.options, {0.0});
  EXPECT_EQ(timed.cells_large_error, 0);
  EXPECT_GT(timed.flat_cells_untimely, 100);
  EXPECT_LT(timed.cells_compared, untimed.cells_compared);
  // With a sweep at the second pair's time too, the cell is judged again.
  EXPECT_EQ(EvaluateMapAgainstLidar(s.map, s.truth, s.pairs, s.rig, s.options, {0.0, 5.1}).cells_large_error, 1);
}

TEST(EvaluateMapAgainstLidar, AnObjectCountsForRecallWhereItStoodWhenThePairSawIt) {
  Scene s;
  // A second box, 0.6 m tall, that only sweep "b" (0.5 s later) shows, at x -3.5..-2.5, y 9..10:
  // a car that drove in after the pair at 0 s looked.
  for (double x = -3.5; x < -2.5; x += 0.05) {
    for (double y = 9; y < 10; y += 0.05) s.sweeps[1].points.emplace_back(x + 0.001, y + 0.001, 0.6f);
  }
  s.sweeps[0].t_s = 0;
  s.sweeps[1].t_s = 0.5;
  std::vector<std::vector<int>> stood;
  s.truth = GridLidarTruth(s.sweeps, s.map, s.options, &stood);
  const std::vector<double> times = {0.0, 0.5};
  const LidarEvalResult r = EvaluateMapAgainstLidar(s.map, s.truth, s.pairs, s.rig, s.options, times, nullptr, &stood);
  EXPECT_EQ(r.objects, 1);  // the first box, which both sweeps show
  EXPECT_EQ(r.objects_found, 1);
  // Seen by a pair at 0.5 s, the new box is an object the map missed.
  s.pairs[0].t_s = 0.5;
  const LidarEvalResult later =
      EvaluateMapAgainstLidar(s.map, s.truth, s.pairs, s.rig, s.options, times, nullptr, &stood);
  EXPECT_EQ(later.objects, 2);
  EXPECT_EQ(later.objects_found, 1);
}

// A block standing on the ground at x0..x1, y0..y1, `height` tall, in both sweeps: its top and
// its face towards the vehicle (south), the ground's returns under it removed.
void AddBlock(std::vector<LidarSweep>* sweeps, double x0, double x1, double y0, double y1, double height) {
  for (LidarSweep& sweep : *sweeps) {
    std::erase_if(sweep.points,
                  [&](const Eigen::Vector3f& p) { return p.x() > x0 && p.x() < x1 && p.y() > y0 && p.y() < y1; });
    for (double x = x0 + 0.001; x < x1; x += 0.05) {
      for (double y = y0 + 0.001; y < y1; y += 0.05) sweep.points.emplace_back(x, y, height);
      for (double z = 0; z < height; z += 0.05) sweep.points.emplace_back(x, y0 + 0.001, z);
    }
  }
}

// An object is in the band where a pair saw its part within the heights the search matches
// (the region's Z_max, 1 m by default), over everything in front of it however near.
TEST(EvaluateMapAgainstLidar, AnObjectCountsWhereAPairSawItsPartWithinTheSearchsHeights) {
  Scene s;
  // A hedge 1.2 m tall at x -3..-1, y 8.5..8.75, flagged in the map; behind it a post 2 m
  // tall at x -2.25..-1.75, y 9..9.5, which the map misses. The post's top shows over the hedge
  // from the cameras 1.65 m up; its part up to 1 m does not.
  AddBlock(&s.sweeps, -3, -1, 8.5, 8.75, 1.2);
  AddBlock(&s.sweeps, -2.25, -1.75, 9, 9.5, 2.0);
  cv::Mat& obstacle = MapBand(&s.map, "obstacle");
  for (double x = -2.875; x < -1; x += kCell) obstacle.at<float>(CellAt(s.map, x, 8.625)) = 1;
  s.truth = GridLidarTruth(s.sweeps, s.map, s.options);
  LidarEvalResult r = s.Score();
  EXPECT_EQ(r.objects, 2);  // the box and the hedge
  EXPECT_EQ(r.objects_found, 2);
  // A search up to 2.5 m matches the post's top: a missed object.
  s.options.band_max_z_m = 2.5;
  r = s.Score();
  EXPECT_EQ(r.objects, 3);
  EXPECT_EQ(r.objects_found, 2);
  // Behind a hedge 2.5 m tall the post is hidden whole, though it stands within a metre of it.
  AddBlock(&s.sweeps, -3, -1, 8.5, 8.75, 2.5);
  s.truth = GridLidarTruth(s.sweeps, s.map, s.options);
  r = s.Score();
  EXPECT_EQ(r.objects, 2);
  EXPECT_EQ(r.objects_found, 2);
}

// Ground is in the band where both cameras see it: a walker half a metre in front of a cell
// hides it (however near), and so does a post that only the right camera's ray meets.
TEST(EvaluateMapAgainstLidar, GroundOneCameraCannotSeeIsNotInTheBand) {
  Scene s;
  AddBlock(&s.sweeps, -3.1, -2.9, 9, 9.2, 1.7);  // the walker
  AddBlock(&s.sweeps, 0.6, 0.8, 5, 5.25, 2.0);   // the post, right of the left camera's ray
  s.truth = GridLidarTruth(s.sweeps, s.map, s.options);
  cv::Mat& count = MapBand(&s.map, "count");
  const LidarEvalResult all = s.Score();
  EXPECT_DOUBLE_EQ(all.coverage, 1.0);
  const cv::Point behind_walker = CellAt(s.map, -3.1, 9.6), behind_post = CellAt(s.map, 1.1, 10.1);
  ASSERT_EQ(s.truth.bands[static_cast<std::size_t>(s.truth.BandIndex("class"))].pixels.at<float>(behind_walker), 1.0f);
  ASSERT_EQ(s.truth.bands[static_cast<std::size_t>(s.truth.BandIndex("class"))].pixels.at<float>(behind_post), 1.0f);
  count.at<float>(behind_walker) = 0;
  count.at<float>(behind_post) = 0;
  const LidarEvalResult r = s.Score();
  EXPECT_EQ(r.band_cells, all.band_cells);  // neither is in the band
  EXPECT_DOUBLE_EQ(r.coverage, 1.0);
  // A cell beside them that both cameras see is.
  count.at<float>(CellAt(s.map, -1.1, 9.6)) = 0;
  EXPECT_EQ(s.Score().band_mapped, all.band_cells - 1);
}

TEST(GridLidarTruth, ASlopeIsReliefButNoStandingObject) {
  Scene s;
  // An embankment of 20 deg (gentler than a vehicle's 30 deg limit) rising 0.5 m from x = 4 to
  // a terrace, the whole length of the scene.
  const double rise = std::tan(20 * M_PI / 180);
  for (LidarSweep& sweep : s.sweeps) {
    for (Eigen::Vector3f& p : sweep.points) {
      if (p.x() > 4) p.z() = static_cast<float>(std::min(0.5, rise * (p.x() - 4)));
    }
  }
  s.truth = GridLidarTruth(s.sweeps, s.map, s.options);
  const cv::Mat& relief = s.truth.bands[static_cast<std::size_t>(s.truth.BandIndex("relief_m"))].pixels;
  const cv::Mat& standing = s.truth.bands[static_cast<std::size_t>(s.truth.BandIndex("standing_m"))].pixels;
  const cv::Point slope = CellAt(s.truth, 4.9, 11.1);
  EXPECT_GT(relief.at<float>(slope), 0.2f);     // rises: precision's relief
  EXPECT_LT(standing.at<float>(slope), 0.15f);  // stands on nothing: no object to find
  const cv::Point box = CellAt(s.truth, 2.0, 8.0);
  EXPECT_GT(standing.at<float>(box), 0.4f);
  EXPECT_EQ(s.Score().objects, 1);  // the box; the slope is none
}

TEST(GridLidarTruth, AnOverhangWithTheGroundSeenBeneathIsNoObject) {
  Scene s;
  // A canopy 2.2-2.6 m over the road at x -4..-3, y 9..10, the road seen beneath it, and beside
  // it a post (0-2.4 m) at x -2.1..-1.9, y 9.4..9.6.
  for (double x = -4; x < -3; x += 0.05) {
    for (double y = 9; y < 10; y += 0.05) {
      s.sweeps[0].points.emplace_back(x + 0.001, y + 0.001, 2.2f);
      s.sweeps[1].points.emplace_back(x + 0.001, y + 0.001, 2.6f);
    }
  }
  for (double z = 0; z < 2.4; z += 0.05) {
    for (LidarSweep& sweep : s.sweeps) sweep.points.emplace_back(-2.0f, 9.5f, static_cast<float>(z));
  }
  s.truth = GridLidarTruth(s.sweeps, s.map, s.options);
  const cv::Mat& standing = s.truth.bands[static_cast<std::size_t>(s.truth.BandIndex("standing_m"))].pixels;
  EXPECT_LT(standing.at<float>(CellAt(s.truth, -3.5, 9.5)), 0.15f);  // stands on nothing
  EXPECT_GT(standing.at<float>(CellAt(s.truth, -2.0, 9.5)), 2.0f);   // the post stands
  EXPECT_EQ(s.Score().objects, 2);                                   // the box and the post
  LidarEvalOptions tall = s.options;
  tall.overhang_m = 3.0;  // a vehicle 3 m tall: the canopy is in its way
  s.truth = GridLidarTruth(s.sweeps, s.map, tall);
  EXPECT_GT(s.truth.bands[static_cast<std::size_t>(s.truth.BandIndex("standing_m"))].pixels.at<float>(
                CellAt(s.truth, -3.5, 9.5)),
            2.0f);
}

TEST(GridLidarTruth, AReflectionBelowTheRoadIsNeitherGroundNorRelief) {
  Scene s;
  // A mirror image in a window: the returns of a 0.75 m square 3 m below the road.
  for (LidarSweep& sweep : s.sweeps) {
    for (Eigen::Vector3f& p : sweep.points) {
      if (p.x() > -6 && p.x() < -5.25 && p.y() > 14 && p.y() < 14.75) p.z() = -3;
    }
  }
  s.truth = GridLidarTruth(s.sweeps, s.map, s.options);
  const cv::Mat& ground = s.truth.bands[static_cast<std::size_t>(s.truth.BandIndex("ground_m"))].pixels;
  const cv::Mat& relief = s.truth.bands[static_cast<std::size_t>(s.truth.BandIndex("relief_m"))].pixels;
  EXPECT_TRUE(std::isnan(ground.at<float>(CellAt(s.truth, -5.6, 14.4))));  // not flat ground
  const cv::Point beside = CellAt(s.truth, -4.9, 14.4);
  EXPECT_NEAR(ground.at<float>(beside), 0, 1e-6);  // its neighbours still are
  EXPECT_NEAR(relief.at<float>(beside), 0, 1e-6);  // and stand on the road, not 3 m above a mirror
  const LidarEvalResult r = s.Score();
  EXPECT_EQ(r.cells_large_error, 0);  // the map's road there is not scored against the mirror
}

TEST(MeasureSweepConsistency, IsZeroForAgreeingSweepsAndSeesAShiftedOne) {
  Scene s;
  LidarEvalResult r;
  MeasureSweepConsistency(s.sweeps, s.truth, s.options, &r);
  EXPECT_GT(r.sweep_pairs, 1000);
  EXPECT_NEAR(r.sweep_median_abs_m, 0, 1e-6);
  for (Eigen::Vector3f& p : s.sweeps[1].points) p.z() += 0.03f;
  MeasureSweepConsistency(s.sweeps, s.truth, s.options, &r);
  EXPECT_NEAR(r.sweep_median_abs_m, 0.03, 1e-5);
}

// The flat ground is also scored where the sweeps agree: a stretch where the second sweep
// stands 5 cm higher (its pose off) raises the error there, not where the truth agrees.
TEST(MeasureSweepConsistency, TheMapIsAlsoScoredWhereTheSweepsAgree) {
  Scene s;
  for (Eigen::Vector3f& p : s.sweeps[1].points) {
    if (p.x() < -4) p.z() += 0.05f;
  }
  s.truth = GridLidarTruth(s.sweeps, s.map, s.options);
  LidarEvalResult r;
  cv::Mat spread;
  MeasureSweepConsistency(s.sweeps, s.truth, s.options, &r, &spread);
  EXPECT_NEAR(spread.at<float>(CellAt(s.truth, -6.1, 10.1)), 0.05, 1e-5);
  EXPECT_NEAR(spread.at<float>(CellAt(s.truth, 4.1, 10.1)), 0.0, 1e-6);
  const LidarEvalResult without = s.Score();
  EXPECT_EQ(without.agree_cells, 0);  // no spread given: no cell known to agree
  EXPECT_TRUE(std::isnan(without.agree_rmse_m));
  s.truth.bands.push_back(NamedBand(spread, "sweep_spread_m"));
  const LidarEvalResult with = s.Score();
  EXPECT_GT(with.rmse_m, 0.01);  // the map (z = 0) against the mixed sweeps left of x = -4
  EXPECT_GT(with.agree_cells, 1000);
  EXPECT_LT(with.agree_cells, with.cells_compared);
  EXPECT_NEAR(with.agree_rmse_m, 0.0, 1e-6);
  EXPECT_NEAR(with.agree_median_m, 0.0, 1e-6);
}

// The bucketed search finds what the scan of every segment finds, on a winding path with
// repeated points and long straight ends, for points near it and far from it.
TEST(PathOffsets, AgreesWithTheScanOfEverySegment) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> turn(-0.6, 0.6), step(0.0, 3.0), spread(-40.0, 40.0);
  std::vector<Eigen::Vector2d> path = {Eigen::Vector2d(0, -100)};
  Eigen::Vector2d p(0, 0);
  double heading = 0;
  for (int i = 0; i < 300; ++i) {
    path.push_back(p);
    if (i % 17 == 0) path.push_back(p);  // a pair taken standing still
    heading += turn(rng);
    p += step(rng) * Eigen::Vector2d(std::sin(heading), std::cos(heading));
  }
  path.push_back(p + 100 * Eigen::Vector2d(std::sin(heading), std::cos(heading)));
  auto scan = [&](const Eigen::Vector2d& w) {
    double best = std::numeric_limits<double>::infinity(), offset = std::nan("");
    for (std::size_t k = 0; k + 1 < path.size(); ++k) {
      const Eigen::Vector2d a = path[k], d = path[k + 1] - a;
      const double len2 = d.squaredNorm();
      if (!(len2 > 0)) continue;
      const double t = std::clamp((w - a).dot(d) / len2, 0.0, 1.0);
      const Eigen::Vector2d r = w - (a + t * d);
      if (r.squaredNorm() < best) {
        best = r.squaredNorm();
        offset = (d.x() * r.y() - d.y() * r.x() > 0 ? -1.0 : 1.0) * r.norm();
      }
    }
    return offset;
  };
  for (const double bucket : {0.5, 4.0, 25.0}) {
    const internal::PathOffsets offsets(path, bucket);
    for (int i = 0; i < 3000; ++i) {
      const Eigen::Vector2d& near = path[static_cast<std::size_t>(i) % path.size()];
      const Eigen::Vector2d w = near + Eigen::Vector2d(spread(rng), spread(rng)) * (i % 30 == 0 ? 5.0 : 0.25);
      ASSERT_EQ(offsets.Offset(w), scan(w)) << "bucket " << bucket << ", point " << w.transpose();
    }
  }
  EXPECT_TRUE(std::isnan(internal::PathOffsets({Eigen::Vector2d(1, 1), Eigen::Vector2d(1, 1)}).Offset({0, 0})));
  EXPECT_TRUE(std::isnan(internal::PathOffsets({}).Offset({0, 0})));
}

// A pair against its sweep: its points 3 cm over the flat ground the sweep saw are 3 cm off
// (the box and the cells the pair did not see aside); the summary's signed median takes only
// the pairs taken within the sweep gap, the |offsets| every pair.
TEST(PairOffset, IsThePairsHeightOverItsSweepOnFlatGround) {
  const Scene s;
  std::vector<Eigen::Vector3f> stereo;
  for (double x = -3; x < 3; x += 0.05) {
    for (double y = 5; y < 10; y += 0.05) {
      const bool on_box = x > 1.5 && x < 2.5 && y > 7.5 && y < 8.5;
      stereo.emplace_back(x + 0.001, y + 0.001, on_box ? 0.2f : 0.03f);
    }
  }
  EXPECT_NEAR(PairOffset(stereo, s.sweeps[0], s.truth, s.options), 0.03, 1e-5);
  // Fewer than ten flat cells both saw (the first 15 points: x -3, y 5..5.7, three cells): not
  // measured.
  const std::vector<Eigen::Vector3f> few(stereo.begin(), stereo.begin() + 15);
  EXPECT_TRUE(std::isnan(PairOffset(few, s.sweeps[0], s.truth, s.options)));

  LidarEvalResult r;
  SummarizePairOffsets({0.03, -0.05, std::nan(""), 0.02, 0.01}, {0.0, 2.0, 0.0, 0.1, 0.2}, s.options, &r);
  EXPECT_EQ(r.pairs_measured, 4);
  EXPECT_NEAR(r.pair_offset_median_abs_m, 0.025, 1e-12);
  EXPECT_NEAR(r.pair_offset_max_abs_m, 0.05, 1e-12);
  EXPECT_NEAR(r.pair_offset_median_m, 0.02, 1e-12);  // the pair 2 s from its sweep left out
  SummarizePairOffsets({0.03}, {1.0}, s.options, &r);
  EXPECT_EQ(r.pairs_measured, 1);
  EXPECT_TRUE(std::isnan(r.pair_offset_median_m));  // no pair at a sweep's time
}

TEST(PairDisparityOffset, IsTheStereosDisparityOverTheLidarsAtTheSameInstant) {
  // The rig's right-referenced disparity of the level ground (d = B (y - c_y) / 1.65 under the
  // horizon) plus 0.4 px, every third column a gross error 8 px off: the pair's offset from
  // the sweep is 0.4 px, whatever the gross errors and the box on the ground.
  const Scene s;
  cv::Mat disparity(375, 1242, CV_32FC1, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  for (int y = 174; y < disparity.rows; ++y) {
    for (int x = 0; x < disparity.cols; ++x) {
      disparity.at<float>(y, x) = static_cast<float>(0.54 * (y - 173) / 1.65 + (x % 3 == 0 ? 8.4 : 0.4));
    }
  }
  const Eigen::Isometry3d at_origin = Eigen::Isometry3d::Identity();
  EXPECT_NEAR(PairDisparityOffset(disparity, calib::ReferenceImage::kRight, s.sweeps[0], s.truth, at_origin, s.rig,
                                  s.options),
              0.4, 0.05);
  // Taken at a pose 3 cm higher, the sweep's ground lies 1.68 m under the cameras, not the
  // 1.65 m the map's disparities show: the pose's error joins the offset (1.8 % of d).
  Eigen::Isometry3d higher = Eigen::Isometry3d::Identity();
  higher.translation().z() = 0.03;
  EXPECT_GT(PairDisparityOffset(disparity, calib::ReferenceImage::kRight, s.sweeps[0], s.truth, higher, s.rig,
                                s.options),
            0.4 + 0.5);
  // A handful of returns: not measured.
  LidarSweep few;
  few.points.assign(s.sweeps[0].points.begin(), s.sweeps[0].points.begin() + 200);
  EXPECT_TRUE(std::isnan(
      PairDisparityOffset(disparity, calib::ReferenceImage::kRight, few, s.truth, at_origin, s.rig, s.options)));
}

// The options' limits: a band or a LiDAR range beyond 1000 m is refused (a band 1e300 m ahead
// scored nothing, exit 0), the defaults pass.
TEST(LidarEvalOptions, RefusesDistancesBeyondAThousandMetres) {
  LidarEvalOptions valid;
  valid.band_min_y_m = 5;  // the band is the rig's or --band's (none by default)
  valid.band_max_y_m = 10;
  EXPECT_NO_THROW(valid.Validate());
  LidarEvalOptions o = valid;
  o.band_min_y_m = 1e300;
  o.band_max_y_m = 1e301;
  EXPECT_THROW(o.Validate(), std::invalid_argument);
  o = valid;
  o.max_range_m = 1e300;
  EXPECT_THROW(o.Validate(), std::invalid_argument);
}

}  // namespace
}  // namespace lunarnav::evaluation
