#include "mapping/terrain_grid.h"
#include "util/errors.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <tuple>
#include <utility>
#include <vector>

#include "calib/paper_rig.h"
#include "calib/rectify.h"
#include "mapping/elevation_error.h"
#include "mapping/synthetic_frames.h"

namespace lunarnav::mapping {
namespace {

constexpr float kInfinity = std::numeric_limits<float>::infinity();
using testing::BoxOnPlane;
using testing::RenderedXyz;
using testing::SurfaceXyz;

FramePose Pose(double x, double y, double heading_deg, double t_s = 0) {
  FramePose p;
  p.x_m = x;
  p.y_m = y;
  p.heading_rad = heading_deg * M_PI / 180;
  p.t_s = t_s;
  return p;
}

TerrainGrid Fuse(const std::vector<std::pair<cv::Mat, FramePose>>& frames, const TerrainMapOptions& o) {
  TerrainGrid grid(o.cell_m);
  for (const auto& [xyz, pose] : frames) grid.Add(BinFrame(xyz, cv::Mat(), pose.WorldFromVehicle(), pose.t_s, o));
  return grid;
}

// Count of cells of a layer that hold a value (not NaN) and satisfy `pred`.
template <typename Pred>
int CountCells(const cv::Mat& layer, Pred pred) {
  int n = 0;
  for (int r = 0; r < layer.rows; ++r) {
    for (int c = 0; c < layer.cols; ++c) n += std::isfinite(layer.at<float>(r, c)) && pred(r, c);
  }
  return n;
}

TEST(TerrainGrid, FlatPlaneMapsToItsHeightWhereverSeen) {
  constexpr double kHeight = 1.37;  // arbitrary
  const TerrainMapOptions o;
  const FramePose pose = Pose(2.0, -1.0, 30.0);
  const TerrainGrid grid = Fuse({{SurfaceXyz([](double, double) { return kHeight; }, pose), pose}}, o);
  const MapLayers l = ComputeLayers(grid, o.obstacles);
  ASSERT_FALSE(l.elevation_m.empty());
  int mapped = 0;
  for (int r = 0; r < l.elevation_m.rows; ++r) {
    for (int c = 0; c < l.elevation_m.cols; ++c) {
      const float e = l.elevation_m.at<float>(r, c);
      if (!std::isfinite(e)) continue;
      ++mapped;
      EXPECT_NEAR(e, kHeight, 1e-5);
      EXPECT_NEAR(l.roughness_m.at<float>(r, c), 0.0, 1e-3);
      EXPECT_EQ(l.obstacle.at<float>(r, c) > 0, false);
    }
  }
  // The seen area is 6 m x 8 m = 768 cells of 25 cm; cells cut by its rotated edge add some.
  EXPECT_GT(mapped, 768);
  EXPECT_LT(mapped, 768 + 2 * (24 + 32) * 2);
  // A point of the seen area far from its edges (vehicle X = 0, Y = 6) is mapped.
  const Eigen::Vector3d inside = pose.WorldFromVehicle() * Eigen::Vector3d(0, 6, 0);
  int col = 0, row = 0;
  ASSERT_TRUE(l.CellOf(inside.x(), inside.y(), &col, &row));
  EXPECT_NEAR(l.elevation_m.at<float>(row, col), kHeight, 1e-5);
  // Outside the seen area nothing is mapped (vehicle Y = 1 is in front of the nearest point).
  const Eigen::Vector3d behind = pose.WorldFromVehicle() * Eigen::Vector3d(0, 1.0, 0);
  if (l.CellOf(behind.x(), behind.y(), &col, &row)) {
    EXPECT_FALSE(std::isfinite(l.elevation_m.at<float>(row, col)));
  }
}

// SurfaceXyz puts its points on a ground grid, not on an image's rays: a box's face is in none
// of them, so the tests of a box or of stray points turn the support rule (which asks for the
// face) off; AnUnsupportedRiseIsRejected tests it on an image-like column.
// a + b + c and c + b + a: what merging in either order gives.
std::pair<CellStats, CellStats> MergeBothOrders(const CellStats& a, const CellStats& b, const CellStats& c) {
  CellStats abc = a, cba = c;
  abc.Merge(b);
  abc.Merge(c);
  cba.Merge(b);
  cba.Merge(a);
  return {abc, cba};
}

TerrainMapOptions GridFrameOptions() {
  TerrainMapOptions o;
  o.support_rise_m = std::numeric_limits<double>::infinity();
  return o;
}

TEST(TerrainGrid, BoxOfKnownSizeIsAnObstacleOfThatSizeAndNowhereElse) {
  // A 0.5 m x 0.75 m box, 0.3 m tall (above the 0.2 m limit), on cell boundaries: 2 x 3 cells.
  const TerrainMapOptions o = GridFrameOptions();
  const FramePose pose = Pose(0, 0, 0);
  const auto surface = BoxOnPlane(0.0, 1.0, 1.5, 5.0, 5.75, 0.3);
  const TerrainGrid grid = Fuse({{SurfaceXyz(surface, pose, 480, 640), pose}}, o);
  const MapLayers l = ComputeLayers(grid, o.obstacles);
  const int obstacles = CountCells(l.obstacle, [&](int r, int c) { return l.obstacle.at<float>(r, c) > 0; });
  EXPECT_EQ(obstacles, 6);
  for (double x : {1.1, 1.4}) {
    for (double y : {5.1, 5.4, 5.6}) {
      int col = 0, row = 0;
      ASSERT_TRUE(l.CellOf(x, y, &col, &row));
      EXPECT_EQ(l.obstacle.at<float>(row, col), 1.0f) << x << ", " << y;  // a step, not a slope
      EXPECT_NEAR(l.max_m.at<float>(row, col), 0.3, 1e-6);
    }
  }
  // A box lower than the limit is no obstacle.
  const TerrainGrid low = Fuse({{SurfaceXyz(BoxOnPlane(0.0, 1.0, 1.5, 5.0, 5.75, 0.15), pose, 480, 640), pose}}, o);
  const MapLayers ll = ComputeLayers(low, o.obstacles);
  EXPECT_EQ(CountCells(ll.obstacle, [&](int r, int c) { return ll.obstacle.at<float>(r, c) > 0; }), 0);
}

TEST(TerrainGrid, SteepRampIsASlopeObstacleAndAGentleOneIsNot) {
  const TerrainMapOptions o;  // 30 deg limit
  const FramePose pose = Pose(0, 0, 0);
  for (const auto& [slope_deg, expect_obstacle] : {std::pair{20.0, false}, std::pair{40.0, true}}) {
    const double g = std::tan(slope_deg * M_PI / 180);
    const TerrainGrid grid = Fuse({{SurfaceXyz([g](double, double y) { return g * y; }, pose), pose}}, o);
    const MapLayers l = ComputeLayers(grid, o.obstacles);
    int col = 0, row = 0;
    ASSERT_TRUE(l.CellOf(0.1, 6.1, &col, &row));
    EXPECT_EQ((static_cast<int>(l.obstacle.at<float>(row, col)) & 2) != 0, expect_obstacle) << slope_deg;
    if (!expect_obstacle) {
      EXPECT_EQ(l.obstacle.at<float>(row, col), 0.0f) << "an even slope is no step";
    }
  }
}

TEST(TerrainGrid, GateRejectsOutliersAndKeepsTheHeight) {
  const TerrainMapOptions o = GridFrameOptions();
  const FramePose pose = Pose(0, 0, 0);
  cv::Mat xyz = SurfaceXyz([](double, double) { return 0.5; }, pose);
  int outliers = 0;
  for (int r = 3; r < xyz.rows; r += 7) {
    for (int c = 5; c < xyz.cols; c += 11) {
      xyz.at<cv::Vec3f>(r, c)[2] += 1.0f;  // a false match 1 m high
      ++outliers;
    }
  }
  const FrameContribution part = BinFrame(xyz, cv::Mat(), pose.WorldFromVehicle(), 0, o);
  EXPECT_EQ(part.points_rejected, outliers);
  TerrainGrid grid(o.cell_m);
  grid.Add(part);
  const MapLayers l = ComputeLayers(grid, o.obstacles);
  EXPECT_EQ(CountCells(l.max_m, [&](int r, int c) { return l.max_m.at<float>(r, c) > 0.51f; }), 0);
  EXPECT_EQ(CountCells(l.obstacle, [&](int r, int c) { return l.obstacle.at<float>(r, c) > 0; }), 0);
  // With the gate off they stay: the cells' highest points rise 1 m and make step obstacles
  // on the flat plane of the fused extremes (the pair's own steps, which take the top three
  // of its points reach, hold: a cell's one or two false matches are no top of three).
  TerrainMapOptions off = o;
  off.gate_k = std::numeric_limits<double>::infinity();
  ObstacleOptions fused_only = o.obstacles;
  fused_only.pair_step_support = 0;
  const FrameContribution ungated = BinFrame(xyz, cv::Mat(), pose.WorldFromVehicle(), 0, off);
  EXPECT_EQ(ungated.points_rejected, 0);
  TerrainGrid raw(o.cell_m);
  raw.Add(ungated);
  const MapLayers lr = ComputeLayers(raw, fused_only);
  EXPECT_GT(CountCells(lr.max_m, [&](int r, int c) { return lr.max_m.at<float>(r, c) > 1.4f; }), 10);
  EXPECT_GT(CountCells(lr.obstacle, [&](int r, int c) { return lr.obstacle.at<float>(r, c) > 0; }), 10);
  const MapLayers own = ComputeLayers(raw, o.obstacles);
  EXPECT_EQ(CountCells(own.obstacle, [&](int r, int c) { return own.obstacle.at<float>(r, c) > 0; }), 0);
}

TEST(TerrainGrid, PointsOutsideTheRequestedIntervalAreLeftOut) {
  const TerrainMapOptions o;
  const FramePose pose = Pose(0, 0, 0);
  const cv::Mat xyz = SurfaceXyz([](double, double) { return 0.0; }, pose);  // Y from 2 to 10 m
  const FrameContribution all = BinFrame(xyz, cv::Mat(), pose.WorldFromVehicle(), 0, o);
  const FrameContribution band = BinFrame(xyz, cv::Mat(), pose.WorldFromVehicle(), 0, o, nullptr, 4.0, 6.0);
  EXPECT_EQ(band.points_in, all.points_in);
  EXPECT_EQ(band.points_fused + band.points_out_of_range, all.points_fused);
  EXPECT_NEAR(static_cast<double>(band.points_fused) / all.points_fused, 2.0 / 8.0, 0.01);  // 2 m of 8
  for (const auto& [cell, stats] : band.cells) {
    EXPECT_GE(cell.j, 16);  // y >= 4 m
    EXPECT_LT(cell.j, 24);  // y < 6 m
  }
  // A vehicle pitched 19 deg nose down: the interval is of horizontal distance ahead (the level
  // frame, as stereo-batch and the planner take it), not of the vehicle's own Y, which runs
  // down the slope (cos 19 deg: 5 % apart).
  FramePose pitched = Pose(0, 0, 0);
  pitched.pitch_rad = -19 * M_PI / 180;
  cv::Mat line(4000, 1, CV_32FC3);
  for (int r = 0; r < line.rows; ++r) {
    line.at<cv::Vec3f>(r, 0) = cv::Vec3f(0.f, static_cast<float>(7.0 - 4.0 * (r + 0.5) / line.rows), 0.f);  // Y 7..3 m
  }
  TerrainMapOptions plain = o;  // the points on a line: nothing for the column rules to judge
  plain.visibility_k = plain.support_rise_m = std::numeric_limits<double>::infinity();
  const FrameContribution level = BinFrame(line, cv::Mat(), pitched.WorldFromVehicle(), 0, plain, nullptr, 4.0, 6.0);
  const double c = std::cos(19 * M_PI / 180);
  // Kept: vehicle Y in [4 / cos, 6 / cos] = [4.23, 6.35] m, of the line's 4 m.
  EXPECT_NEAR(static_cast<double>(level.points_fused) / line.rows, (6.0 / c - 4.0 / c) / 4.0, 0.002);
  for (const auto& [cell, stats] : level.cells) {
    EXPECT_GE((cell.j + 1) * o.cell_m, 4.0);
    EXPECT_LE(cell.j * o.cell_m, 6.0);
  }
}

// A point whose predicted horizontal error exceeds a cell could belong to any of the cells
// around its own: left out (the map's default range follows from the predicted error).
TEST(TerrainGrid, PointsTooUncertainForACellAreLeftOut) {
  TerrainMapOptions o;  // one cell (25 cm) of horizontal error at most
  o.ground_sigma_cells = o.max_horizontal_sigma_cells;  // and none kept as ground only (below)
  const FramePose pose = Pose(0, 0, 0);
  const cv::Mat xyz = SurfaceXyz([](double, double) { return 0.0; }, pose);  // Y from 2 to 10 m
  // The horizontal error grows as Y^2 / 40: 10 cm at 2 m ... 2.5 m at 10 m; 25 cm at Y = sqrt(10).
  cv::Mat sigma(xyz.size(), CV_32FC3);
  long expected_kept = 0, valid = 0;
  for (int r = 0; r < xyz.rows; ++r) {
    for (int c = 0; c < xyz.cols; ++c) {
      const cv::Vec3f p = xyz.at<cv::Vec3f>(r, c);
      const float h = static_cast<float>(p[1] * p[1] / 40.0);
      sigma.at<cv::Vec3f>(r, c) = cv::Vec3f(0.6f * h, 0.8f * h, 0.01f);
      if (!std::isfinite(p[1])) continue;
      ++valid;
      expected_kept += h <= 0.25f;
    }
  }
  const FrameContribution part = BinFrame(xyz, sigma, pose.WorldFromVehicle(), 0, o);
  EXPECT_EQ(part.points_in, valid);
  EXPECT_NEAR(static_cast<double>(part.points_fused), static_cast<double>(expected_kept), 0.001 * valid);
  EXPECT_GT(part.points_out_of_range, 0.5 * valid);
  for (const auto& [cell, stats] : part.cells) EXPECT_LT(cell.j, 13);  // y < sqrt(10) m, 3.25 m
  // Unbounded: every point in.
  TerrainMapOptions all = o;
  all.max_horizontal_sigma_cells = std::numeric_limits<double>::infinity();
  EXPECT_EQ(BinFrame(xyz, sigma, pose.WorldFromVehicle(), 0, all).points_out_of_range, 0);
}

// The horizontal error the uncertain-point tests predict: Y^2 / 40 (as above), one cell at
// Y = 3.16 m, 1.5 cells at 3.87 m.
cv::Mat QuadraticSigma(const cv::Mat& xyz) {
  cv::Mat sigma(xyz.size(), CV_32FC3);
  for (int r = 0; r < xyz.rows; ++r) {
    for (int c = 0; c < xyz.cols; ++c) {
      const float h = xyz.at<cv::Vec3f>(r, c)[1] * xyz.at<cv::Vec3f>(r, c)[1] / 40.0f;
      sigma.at<cv::Vec3f>(r, c) = cv::Vec3f(0.6f * h, 0.8f * h, 0.01f);
    }
  }
  return sigma;
}

// Points too uncertain for a cell count as ground only: kept where they lie within the gate of
// their pair's ground plane (a robust fit to its other points), so that the ground there is
// mapped while what stands there beside what the pair placed well (a walker's points a cell or
// two off) stays out. A view whose plane misses the vehicle's own ground point keeps none.
TEST(TerrainGrid, PointsTooUncertainForACellCountAsGroundOnlyOnTheirPairsGroundPlane) {
  TerrainMapOptions o;  // one cell of horizontal error; ground only up to 1.5 cells, 10 cm from the plane
  o.visibility_k = std::numeric_limits<double>::infinity();  // the column rules off: this rule alone
  o.support_rise_m = std::numeric_limits<double>::infinity();
  const FramePose pose = Pose(0, 0, 0);
  // A 1 m box stands at Y 3.0-3.7 m: its near part within a cell's error (placed), the rest
  // where the error is 1.0-1.4 cells, within two cells of the placed part.
  auto height = BoxOnPlane(0.0, -1.0, 1.0, 3.0, 3.7, 1.0);
  const cv::Mat xyz = SurfaceXyz(height, pose), sigma = QuadraticSigma(xyz);
  long ground = 0, standing = 0;  // the uncertain points on the ground and on the box
  for (int r = 0; r < xyz.rows; ++r) {
    for (int c = 0; c < xyz.cols; ++c) {
      const cv::Vec3f p = xyz.at<cv::Vec3f>(r, c);
      const double h = p[1] * p[1] / 40.0;
      if (h > 0.25 && h <= 0.375) ++(p[2] == 0 ? ground : standing);
    }
  }
  ASSERT_GT(ground, 1000);
  ASSERT_GT(standing, 100);
  const FrameContribution part = BinFrame(xyz, sigma, pose.WorldFromVehicle(), 0, o);
  EXPECT_EQ(part.points_ground_only, ground);
  EXPECT_EQ(part.points_off_ground, standing);
  EXPECT_EQ(part.points_lone_object, 0);
  TerrainGrid grid(o.cell_m);
  grid.Add(part);
  const MapLayers l = ComputeLayers(grid, o.obstacles);
  // The ground out to 3.87 m is mapped (rows of cells from y = 3.25 m on: 24 cells across each,
  // less the box's 8), at its height; the box's uncertain part is not.
  auto far = [&](int r) { return l.y_north_m - (r + 0.5) * l.cell_m > 3.25; };
  const int far_ground = CountCells(l.elevation_m, [&](int r, int) { return far(r); });
  EXPECT_GE(far_ground, 2 * 24 - 8);
  EXPECT_EQ(CountCells(l.max_m, [&](int r, int c) { return far(r) && std::abs(l.max_m.at<float>(r, c)) > 1e-4f; }), 0);
  EXPECT_GT(CountCells(l.max_m, [&](int r, int c) { return !far(r) && l.max_m.at<float>(r, c) > 0.9f; }), 0);
  // Off: those points are out of range, as before.
  TerrainMapOptions off = o;
  off.ground_sigma_cells = off.max_horizontal_sigma_cells;
  const FrameContribution none = BinFrame(xyz, sigma, pose.WorldFromVehicle(), 0, off);
  EXPECT_EQ(none.points_ground_only, 0);
  EXPECT_EQ(none.points_off_ground, 0);
  EXPECT_EQ(none.points_out_of_range, part.points_out_of_range + ground + standing);
  // The whole view 0.5 m above the vehicle's ground (a car's flank filling it): no ground plane.
  const cv::Mat raised = SurfaceXyz([](double, double) { return 0.5; }, pose);
  const FrameContribution flank = BinFrame(raised, QuadraticSigma(raised), pose.WorldFromVehicle(), 0, o);
  EXPECT_EQ(flank.points_ground_only, 0);
  EXPECT_GT(flank.points_off_ground, 1000);
}

// An object the pair sees only where its points are too uncertain for a cell (a bush at the
// band's far corner) is kept, where the pair placed nothing standing as high within two cells:
// its points stand lone_object_height_m over the pair's ground plane. Off (infinity), they are
// left out; lower ones never count.
TEST(TerrainGrid, AnObjectThePairSeesOnlyTooUncertainForACellIsKeptAsALoneObject) {
  TerrainMapOptions o;
  o.visibility_k = std::numeric_limits<double>::infinity();
  o.support_rise_m = std::numeric_limits<double>::infinity();
  const FramePose pose = Pose(0, 0, 0);
  // A 1 m box at Y 3.4-3.7 m, where the error is 1.2-1.4 cells: none of it placed; beside it a
  // 0.3 m one, lower than lone_object_height_m.
  const testing::HeightFn tall = BoxOnPlane(0.0, -1.0, 1.0, 3.4, 3.7, 1.0), low = BoxOnPlane(0.0, 2.0, 2.5, 3.4, 3.7, 0.3);
  const cv::Mat xyz = SurfaceXyz([&](double x, double y) { return std::max(tall(x, y), low(x, y)); }, pose);
  const cv::Mat sigma = QuadraticSigma(xyz);
  long standing = 0, high = 0;  // its uncertain points, and those more than 0.4 m up
  for (int r = 0; r < xyz.rows; ++r) {
    for (int c = 0; c < xyz.cols; ++c) {
      const cv::Vec3f p = xyz.at<cv::Vec3f>(r, c);
      const double h = p[1] * p[1] / 40.0;
      if (h > 0.25 && h <= 0.375 && p[2] != 0) {
        ++standing;
        high += p[2] > 0.4;
      }
    }
  }
  ASSERT_GT(high, 100);
  ASSERT_GT(standing, high);
  const FrameContribution part = BinFrame(xyz, sigma, pose.WorldFromVehicle(), 0, o);
  EXPECT_EQ(part.points_lone_object, high);
  EXPECT_EQ(part.points_off_ground, standing - high);
  TerrainGrid grid(o.cell_m);
  grid.Add(part);
  const MapLayers l = ComputeLayers(grid, o.obstacles);
  // The tall box's cells (x -1..1, y 3.25..3.75 with a cell of spill) stand a metre up; nothing
  // else stands 0.4 m.
  int box = 0, elsewhere = 0;
  for (int r = 0; r < l.max_m.rows; ++r) {
    for (int c = 0; c < l.max_m.cols; ++c) {
      if (!(l.max_m.at<float>(r, c) > 0.4f)) continue;
      const double x = l.x_west_m + (c + 0.5) * l.cell_m, y = l.y_north_m - (r + 0.5) * l.cell_m;
      ++(std::abs(x) < 1.0 + l.cell_m && y > 3.25 - l.cell_m && y < 3.75 + l.cell_m ? box : elsewhere);
    }
  }
  EXPECT_GE(box, 8);
  EXPECT_EQ(elsewhere, 0);
  TerrainMapOptions off = o;
  off.lone_object_height_m = std::numeric_limits<double>::infinity();
  const FrameContribution out = BinFrame(xyz, sigma, pose.WorldFromVehicle(), 0, off);
  EXPECT_EQ(out.points_lone_object, 0);
  EXPECT_EQ(out.points_off_ground, standing);
  TerrainMapOptions bad = o;
  bad.lone_object_height_m = 0;
  EXPECT_THROW(bad.Validate(), std::invalid_argument);
}

// The visibility rule: a blob of matches nearer than the rays below it in its image column
// floats (those rays reached farther, passing beneath it) and is rejected, counted; a box
// standing on the ground, whose face rises at one distance, is not.
TEST(TerrainGrid, PointsAFartherRayPassesBeneathAreRejectedAsFloating) {
  const TerrainMapOptions o;  // no predicted error (no sigma, no rig): the floor alone, 10 cm
  const FramePose pose = Pose(0, 0, 0);
  cv::Mat xyz = SurfaceXyz([](double, double) { return 0.0; }, pose);  // rows from Y = 10 m (top) to 2 m
  // Near the top of the image (true ground at 9-10 m), a blob matched at Y = 5 m, 0.3 m up.
  long blob = 0;
  for (int r = 2; r < 10; ++r) {
    for (int c = 40; c < 60; ++c) {
      cv::Vec3f& p = xyz.at<cv::Vec3f>(r, c);
      p[1] = 5.0f;
      p[2] = 0.3f;
      ++blob;
    }
  }
  const FrameContribution part = BinFrame(xyz, cv::Mat(), pose.WorldFromVehicle(), 0, o);
  EXPECT_EQ(part.points_floating, blob);
  EXPECT_EQ(part.points_fused, part.points_in - blob);
  TerrainGrid grid(o.cell_m);
  grid.Add(part);
  const MapLayers l = ComputeLayers(grid, o.obstacles);
  EXPECT_EQ(CountCells(l.max_m, [&](int r, int c) { return l.max_m.at<float>(r, c) > 0.01f; }), 0);
  // Off, the blob stands in the map.
  TerrainMapOptions off = o;
  off.visibility_k = std::numeric_limits<double>::infinity();
  EXPECT_EQ(BinFrame(xyz, cv::Mat(), pose.WorldFromVehicle(), 0, off).points_floating, 0);
  // One stray far match below a correct point does not veto it (three in a row are needed).
  cv::Mat stray = SurfaceXyz([](double, double) { return 0.0; }, pose);
  stray.at<cv::Vec3f>(100, 30)[1] = 9.5f;  // at Y of about 3.3 m
  EXPECT_EQ(BinFrame(stray, cv::Mat(), pose.WorldFromVehicle(), 0, o).points_floating, 0);
  // A box on the ground: its face rises at one distance, no ray below reaches past it.
  const cv::Mat box = SurfaceXyz(BoxOnPlane(0.0, -1.0, 1.0, 5.0, 6.0, 0.3), pose);
  EXPECT_EQ(BinFrame(box, cv::Mat(), pose.WorldFromVehicle(), 0, o).points_floating, 0);
}

// A frame's points in a cell are one observation: a frame with many precise points at a wrong
// height does not outvote four frames that agree, and the cell's sigma is that of the frames.
TEST(TerrainGrid, AFramesPointsInACellAreOneObservation) {
  const TerrainMapOptions o;
  const FramePose pose = Pose(0, 0, 0);
  auto frame = [&](double z, float sigma_z) {
    const cv::Mat xyz = SurfaceXyz([z](double, double) { return z; }, pose);
    const cv::Mat sigma(xyz.size(), CV_32FC3, cv::Scalar(0.001f, 0.001f, sigma_z));
    return BinFrame(xyz, sigma, pose.WorldFromVehicle(), 0, o);
  };
  TerrainGrid grid(o.cell_m);
  grid.Add(frame(0.1, 0.001f));  // 1 mm points, 10 cm off
  for (int k = 0; k < 4; ++k) grid.Add(frame(0.0, 0.02f));
  const double w_precise = 1.0 / (1e-6 + o.frame_floor_m * o.frame_floor_m);
  const double w_plain = 1.0 / (4e-4 + o.frame_floor_m * o.frame_floor_m);
  const Eigen::Vector3d centre = pose.WorldFromVehicle() * Eigen::Vector3d(0.1, 6.1, 0);
  const std::optional<CellStats> s = grid.Find({static_cast<std::int64_t>(std::floor(centre.x() / o.cell_m)),
                                                static_cast<std::int64_t>(std::floor(centre.y() / o.cell_m))});
  ASSERT_TRUE(s.has_value());
  EXPECT_NEAR(s->Mean(), 0.1 * w_precise / (w_precise + 4 * w_plain), 1e-6);
  EXPECT_NEAR(s->Sigma(), 1.0 / std::sqrt(w_precise + 4 * w_plain), 1e-9);
  // The roughness holds the frames' disagreement (the points of each frame lie flat).
  const double m = s->Mean();
  EXPECT_NEAR(s->StdDev(),
              std::sqrt((w_precise * (0.1 - m) * (0.1 - m) + 4 * w_plain * m * m) / (w_precise + 4 * w_plain)), 1e-6);
}

// The step rule's extremes lie within extreme_k roughnesses of the cell's mean: a stray high
// point in a flat cell of low roughness makes no step; a rock cell's wide spread keeps its top.
TEST(TerrainGrid, AStrayExtremeIsNoStepButARocksTopIs) {
  const cv::Mat flat(5, 5, CV_32FC1, cv::Scalar(0));
  cv::Mat max_m = flat.clone(), min_m = flat.clone(), roughness(5, 5, CV_32FC1, cv::Scalar(0.02));
  max_m.at<float>(2, 2) = 0.25f;  // one stray point 25 cm up in a cell whose points lie within 2 cm
  ObstacleOptions o;
  const cv::Mat raw = DetectObstacles(flat, min_m, max_m, cv::Mat(), 0.25, o);
  EXPECT_EQ(raw.at<float>(2, 2), 1);  // without the roughness: the raw extremes make a step
  const cv::Mat robust = DetectObstacles(flat, min_m, max_m, cv::Mat(), 0.25, o, roughness);
  EXPECT_EQ(robust.at<float>(2, 2), 0);
  // A rock's cell: mean 15 cm, top 30 cm, points spread 10 cm: still a step.
  cv::Mat elevation = flat.clone();
  elevation.at<float>(2, 2) = 0.15f;
  max_m.at<float>(2, 2) = 0.30f;
  roughness.at<float>(2, 2) = 0.10f;
  EXPECT_EQ(DetectObstacles(elevation, min_m, max_m, cv::Mat(), 0.25, o, roughness).at<float>(2, 2), 1);
  // Raw extremes on request (infinity).
  o.extreme_k = std::numeric_limits<double>::infinity();
  max_m.at<float>(2, 2) = 0.25f;
  EXPECT_EQ(DetectObstacles(flat, min_m, max_m, cv::Mat(), 0.25, o, roughness).at<float>(2, 2), 1);
}

// The lows are the ground's level beside a step, held nearer the mean (1.5 roughnesses) than
// the tops (2): flat ground 5 cm rough, a cell's top 2 roughnesses up and its neighbour's low 2
// down (20 cm apart), is no step; with 2 on both sides it was. A 25 cm rock in it still is.
TEST(TerrainGrid, TheNoiseOfRoughFlatGroundIsNoStepButARockOnItIs) {
  const cv::Mat flat(5, 5, CV_32FC1, cv::Scalar(0)), roughness(5, 5, CV_32FC1, cv::Scalar(0.05));
  cv::Mat max_m(5, 5, CV_32FC1, cv::Scalar(0.10)), min_m(5, 5, CV_32FC1, cv::Scalar(-0.10));
  ObstacleOptions o;
  EXPECT_EQ(DetectObstacles(flat, min_m, max_m, cv::Mat(), 0.25, o, roughness).at<float>(2, 2), 0);
  ObstacleOptions symmetric = o;
  symmetric.low_extreme_k = symmetric.extreme_k;
  EXPECT_EQ(DetectObstacles(flat, min_m, max_m, cv::Mat(), 0.25, symmetric, roughness).at<float>(2, 2), 1);
  // The rock's cell: mean 12 cm, its points spread 8 cm, top 25 cm.
  cv::Mat elevation = flat.clone(), rock_roughness = roughness.clone();
  elevation.at<float>(2, 2) = 0.12f;
  rock_roughness.at<float>(2, 2) = 0.08f;
  max_m.at<float>(2, 2) = 0.25f;
  EXPECT_EQ(DetectObstacles(elevation, min_m, max_m, cv::Mat(), 0.25, o, rock_roughness).at<float>(2, 2), 1);
  // Raw lows on request (infinity): the noise is a step again.
  o.low_extreme_k = std::numeric_limits<double>::infinity();
  EXPECT_EQ(DetectObstacles(flat, min_m, max_m, cv::Mat(), 0.25, o, roughness).at<float>(2, 2), 1);
}

// The support rule on image-like columns: a blob that stands high above the last point below
// it, across rows where nothing was matched, is rejected; a face seen row by row is kept.
TEST(TerrainGrid, AnUnsupportedRiseIsRejectedAndASeenFaceIsNot) {
  const TerrainMapOptions o;
  const FramePose pose = Pose(0, 0, 0);
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
  // 200 rows x 20 columns, bottom row nearest. Rows 199..100: ground from Y = 2 to 7 m.
  cv::Mat xyz(200, 20, CV_32FC3, cv::Scalar::all(kNaN));
  auto set = [&](int row, float y, float z) {
    for (int c = 0; c < xyz.cols; ++c) xyz.at<cv::Vec3f>(row, c) = cv::Vec3f(0.05f * c - 0.5f, y, z);
  };
  for (int row = 199; row >= 100; --row) set(row, 2.0f + 0.05f * (199 - row), 0.0f);
  // Rows 99..60 unmatched; rows 59..50: a blob at 7 m, 0.5 m up.
  for (int row = 59; row >= 50; --row) set(row, 7.0f, 0.5f);
  FrameContribution part = BinFrame(xyz, cv::Mat(), pose.WorldFromVehicle(), 0, o);
  EXPECT_EQ(part.points_unsupported, 10 * 20);
  EXPECT_EQ(part.points_floating, 0);
  // Off, it stays.
  TerrainMapOptions off = o;
  off.support_rise_m = std::numeric_limits<double>::infinity();
  EXPECT_EQ(BinFrame(xyz, cv::Mat(), pose.WorldFromVehicle(), 0, off).points_unsupported, 0);
  // The same rise seen as a face, one row per centimetre, then its top and the ground behind.
  int row = 99;
  for (int k = 1; k <= 50; ++k) set(row--, 7.0f, 0.01f * k);
  for (int k = 1; k <= 10; ++k) set(row--, 7.0f + 0.02f * k, 0.5f);
  for (; row >= 0; --row) set(row, 9.0f + 0.01f * static_cast<float>(39 - row), 0.0f);
  part = BinFrame(xyz, cv::Mat(), pose.WorldFromVehicle(), 0, o);
  EXPECT_EQ(part.points_unsupported, 0);
  EXPECT_EQ(part.points_floating, 0);
}

// The step rule's tops are those a second pair or three points of one pair reach, its bottoms
// those a second pair confirms: one pair's two stray points in a flat cell make no step; a box
// every pair sees does. The confirmed extremes merge exactly. (This checks the rule's threshold,
// kTopSupport; that a patch of wrong matches the size real pairs leave makes no step is
// Carving.ACellOnePairSawHighAndTheOthersSawThroughIsNoStep's, at the defaults.)
TEST(TerrainGrid, ExtremesOfOnePairAloneMakeNoStep) {
  TerrainMapOptions o = GridFrameOptions();
  o.gate_k = std::numeric_limits<double>::infinity();  // the stray points reach the sums
  o.visibility_k = std::numeric_limits<double>::infinity();
  o.obstacles.extreme_k = std::numeric_limits<double>::infinity();  // confirmation alone
  o.obstacles.low_extreme_k = std::numeric_limits<double>::infinity();
  const auto box = BoxOnPlane(0.0, 1.0, 1.5, 5.0, 5.5, 0.3);
  TerrainGrid grid(o.cell_m);
  for (int k = 0; k < 3; ++k) {
    const FramePose p = Pose(0, 0.3 * k, 0);
    cv::Mat xyz = SurfaceXyz(box, p, 480, 640);
    if (k == 1) {  // pair 1: two wrong matches 35 cm up over flat ground at (-1, 7), one 40 cm
                   // down at (-1, 7.5)
      int up = 0, down = 0;
      for (int r = 0; r < xyz.rows; ++r) {
        for (int c = 0; c < xyz.cols; ++c) {
          cv::Vec3f& q = xyz.at<cv::Vec3f>(r, c);
          if (up < 2 && q[0] > -0.95f && q[0] < -0.9f && std::abs(q[1] + 0.3f - 7.1f) < 0.05f) {
            q[2] += 0.35f;
            ++up;
          }
          if (down < 1 && q[0] > -0.95f && q[0] < -0.9f && std::abs(q[1] + 0.3f - 7.6f) < 0.05f) {
            q[2] -= 0.4f;
            ++down;
          }
        }
      }
      ASSERT_EQ(up, 2);
      ASSERT_EQ(down, 1);
    }
    grid.Add(BinFrame(xyz, cv::Mat(), p.WorldFromVehicle(), k, o));
  }
  const MapLayers l = ComputeLayers(grid, o.obstacles, 2);
  int col = 0, row = 0;
  ASSERT_TRUE(l.CellOf(-1.0, 7.1, &col, &row));
  EXPECT_GT(l.max_m.at<float>(row, col), 0.3f);  // the raw extreme holds the stray points
  EXPECT_EQ(l.obstacle.at<float>(row, col), 0);
  ASSERT_TRUE(l.CellOf(-1.0, 7.6, &col, &row));
  EXPECT_LT(l.min_m.at<float>(row, col), -0.3f);
  for (int dr = -1; dr <= 1; ++dr) {  // a stray low point makes no step of its neighbours
    for (int dc = -1; dc <= 1; ++dc) EXPECT_EQ(l.obstacle.at<float>(row + dr, col + dc), 0);
  }
  ASSERT_TRUE(l.CellOf(1.25, 5.25, &col, &row));
  EXPECT_EQ(l.obstacle.at<float>(row, col), 1);
  // Merging in any order keeps the two highest and the two lowest, and the pairs' own tops.
  CellStats a, b, c;
  a.z_max = 0.3f;
  a.z_min = -0.1f;
  b.z_max = 0.01f;
  b.z_min = 0.0f;
  c.z_max = 0.02f;
  c.z_min = -0.05f;
  auto [abc, cba] = MergeBothOrders(a, b, c);
  for (const CellStats* s : {&abc, &cba}) {
    EXPECT_EQ(s->z_max, 0.3f);
    EXPECT_EQ(s->z_max2, 0.02f);
    EXPECT_EQ(s->z_min, -0.1f);
    EXPECT_EQ(s->z_min2, -0.05f);
  }
  a.z_max2 = 0.25f;  // a's pair had three points at 0.25 m or higher
  std::tie(abc, cba) = MergeBothOrders(a, b, c);
  EXPECT_EQ(abc.z_max2, 0.25f);
  EXPECT_EQ(cba.z_max2, 0.25f);
}

// A rock near the edge of the view: one pair sees it whole, the next only its foot (its top has
// left the image). The first pair's many points on the top make it a step without a second
// pair's; a wrong match or two over flat ground still do not.
TEST(TerrainGrid, ARockTopThatOnlyOnePairSawWholeIsAStep) {
  TerrainMapOptions o = GridFrameOptions();
  const auto box = BoxOnPlane(0.0, 1.0, 1.5, 5.0, 5.5, 0.3);
  TerrainGrid grid(o.cell_m);
  for (int k = 0; k < 2; ++k) {
    const FramePose p = Pose(0, 0.3 * k, 0);
    cv::Mat xyz = SurfaceXyz(box, p, 480, 640);
    if (k == 1) {  // pair 1 sees only the box's foot: its points there 4 cm up
      for (int r = 0; r < xyz.rows; ++r) {
        for (int c = 0; c < xyz.cols; ++c) {
          cv::Vec3f& q = xyz.at<cv::Vec3f>(r, c);
          if (q[2] > 0.05f) q[2] = 0.04f;
        }
      }
    }
    grid.Add(BinFrame(xyz, cv::Mat(), p.WorldFromVehicle(), k, o));
  }
  const MapLayers l = ComputeLayers(grid, o.obstacles, 1);
  int col = 0, row = 0;
  ASSERT_TRUE(l.CellOf(1.25, 5.25, &col, &row));
  EXPECT_EQ(l.frames.at<float>(row, col), 2);  // both pairs saw the cell
  EXPECT_EQ(l.obstacle.at<float>(row, col), 1);
  EXPECT_EQ(CountCells(l.obstacle, [&](int r, int c) { return l.obstacle.at<float>(r, c) != 0; }), 4);
}

// Two pairs whose poses disagree in height by 20 cm (a GPS/INS pose's error, larger here than
// on a real drive so that exact surfaces show it): flat ground fused from both is as rough as
// the disagreement, and a cell's top from one pair stands a step over a neighbour's low from the
// other. Each pair's own steps, from its own points only, hold the ground flat; a rock both
// pairs see stays a step.
TEST(TerrainGrid, TwoPairsHeightErrorsMakeNoStepButARockStaysOne) {
  const auto box = BoxOnPlane(0.0, 1.0, 1.5, 5.0, 5.5, 0.3);
  auto map = [&](int pair_step_support) {
    TerrainMapOptions o = GridFrameOptions();
    o.obstacles.pair_step_support = pair_step_support;
    TerrainGrid grid(o.cell_m);
    for (int k = 0; k < 2; ++k) {
      const FramePose truth = Pose(0, 0.3 * k, 0);
      FramePose placed = truth;
      placed.z_m = k == 0 ? 0.0 : -0.2;  // pair 1 placed 20 cm low
      grid.Add(BinFrame(SurfaceXyz(box, truth, 480, 640), cv::Mat(), placed.WorldFromVehicle(), k, o));
    }
    return ComputeLayers(grid, o.obstacles, 1);
  };
  auto on_box = [](const MapLayers& l, int r, int c) {  // the box's cells and those beside them
    const double x = l.x_west_m + (c + 0.5) * l.cell_m, y = l.y_north_m - (r + 0.5) * l.cell_m;
    return x > 0.7 && x < 1.8 && y > 4.7 && y < 5.8;
  };
  const MapLayers fused_only = map(0), own = map(1), confirmed = map(2);
  // Without the pairs' own steps the flat ground both saw is full of steps.
  EXPECT_GT(CountCells(fused_only.obstacle,
                       [&](int r, int c) { return fused_only.obstacle.at<float>(r, c) == 1 && !on_box(fused_only, r, c); }),
            20);
  for (const MapLayers* l : {&own, &confirmed}) {
    EXPECT_EQ(CountCells(l->obstacle, [&](int r, int c) { return l->obstacle.at<float>(r, c) != 0 && !on_box(*l, r, c); }),
              0);
    int col = 0, row = 0;
    ASSERT_TRUE(l->CellOf(1.25, 5.25, &col, &row));
    EXPECT_EQ(l->frames.at<float>(row, col), 2);
    EXPECT_EQ(l->obstacle.at<float>(row, col), 1);
  }
}

// The pairs' steps and the two last times merge as the extremes do (the highest two, in any
// order) and survive the state file; a state written before them reads as one where no pair
// measured a step and the second last time is unknown.
TEST(TerrainGrid, PairStepsMergeInAnyOrderAndSurviveTheState) {
  CellStats a, b, c;
  a.step1 = 0.3f;
  a.step_pairs = 1;
  b.step1 = 0.05f;
  b.step_pairs = 1;
  c.step1 = 0.12f;
  c.step2 = 0.1f;
  c.step_pairs = 2;
  a.last_t_s = 3;  // and the two last times
  b.last_t_s = 1;
  c.last_t_s = 2;
  c.last_t2_s = 0;
  const auto [abc, cba] = MergeBothOrders(a, b, c);
  for (const CellStats* s : {&abc, &cba}) {
    EXPECT_EQ(s->step1, 0.3f);
    EXPECT_EQ(s->step2, 0.12f);
    EXPECT_EQ(s->step_pairs, 4u);
    EXPECT_EQ(s->last_t_s, 3);
    EXPECT_EQ(s->last_t2_s, 2);
  }
  const TerrainMapOptions o = GridFrameOptions();
  const auto box = BoxOnPlane(0.0, 1.0, 1.5, 5.0, 5.5, 0.3);
  const FramePose p0 = Pose(0, 0, 0, 0), p1 = Pose(0, 0.3, 0, 1);
  const TerrainGrid grid = Fuse({{SurfaceXyz(box, p0, 480, 640), p0}, {SurfaceXyz(box, p1, 480, 640), p1}}, o);
  const io::GeoRaster state = grid.ToStateRaster();
  const TerrainGrid back = TerrainGrid::FromStateRaster(state, "test");
  // The same state without the steps' bands, as written before them.
  io::GeoRaster old = state;
  old.bands.clear();
  for (const io::RasterBand& band : state.bands) {
    const std::string& d = band.description;
    auto ends_with = [&](const std::string& tail) {
      return d.size() >= tail.size() && d.compare(d.size() - tail.size(), tail.size(), tail) == 0;
    };
    if (!ends_with("_step1") && !ends_with("_step2") && !ends_with("_step_pairs") && !ends_with("_last_t2_s")) {
      old.bands.push_back(band);
    }
  }
  ASSERT_LT(old.bands.size(), state.bands.size());
  const TerrainGrid before = TerrainGrid::FromStateRaster(old, "old");
  int measured = 0;
  const auto bounds = *grid.MappedBounds();
  for (std::int64_t j = bounds[1]; j <= bounds[3]; ++j) {
    for (std::int64_t i = bounds[0]; i <= bounds[2]; ++i) {
      const std::optional<CellStats> s = grid.Find({i, j}), t = back.Find({i, j}), u = before.Find({i, j});
      ASSERT_EQ(s.has_value(), t.has_value());
      ASSERT_EQ(s.has_value(), u.has_value());
      if (!s) continue;
      EXPECT_EQ(s->step1, t->step1);
      EXPECT_EQ(s->step2, t->step2);
      EXPECT_EQ(s->step_pairs, t->step_pairs);
      EXPECT_EQ(s->last_t2_s, t->last_t2_s);
      measured += s->step_pairs > 0;
      EXPECT_EQ(u->step_pairs, 0u);
      EXPECT_EQ(u->last_t2_s, -std::numeric_limits<double>::infinity());
      EXPECT_EQ(u->sum_wz, s->sum_wz);
    }
  }
  EXPECT_GT(measured, 100);
  // A step with no pair to have measured it is bad input.
  io::GeoRaster bad = state;
  for (io::RasterBand& band : bad.bands) {
    if (band.description == "bin1_step_pairs") band.pixels.setTo(cv::Scalar(0.0));
  }
  EXPECT_THROW(TerrainGrid::FromStateRaster(bad, "bad"), InputError);
}

// A box that two pairs see and that is gone when the next two look (a parked van that drove
// off) is no obstacle: what later pairs saw lower moved on. One that arrives after the flat
// ground was seen stays, in whatever order the pairs are fused.
TEST(TerrainGrid, WhatLaterPairsSawLowerMovedOnWhatArrivedStays) {
  const TerrainMapOptions o = GridFrameOptions();
  const auto box = BoxOnPlane(0.0, 1.0, 1.5, 5.0, 5.5, 0.3);
  const auto flat = [](double, double) { return 0.0; };
  // Pairs k of `order` (at time k), those with has_box(k) seeing the box.
  auto map = [&](auto has_box, const std::vector<int>& order, double moved_height_m, CarveCounts* counts) {
    std::vector<std::pair<cv::Mat, FramePose>> frames;
    for (int k : order) {
      const FramePose p = Pose(0, 0.2 * k, 0, k);
      frames.push_back({has_box(k) ? SurfaceXyz(box, p, 480, 640) : SurfaceXyz(flat, p, 480, 640), p});
    }
    return ComputeLayers(Fuse(frames, o), o.obstacles, 1, kInfinity, moved_height_m, counts);
  };
  const auto first_two = [](int k) { return k < 2; };
  const auto last_two = [](int k) { return k >= 2; };
  auto at_box = [](const MapLayers& l, const cv::Mat& layer) {
    int col = 0, row = 0;
    EXPECT_TRUE(l.CellOf(1.25, 5.25, &col, &row));
    return layer.at<float>(row, col);
  };
  CarveCounts gone, kept;
  const MapLayers left = map(first_two, {0, 1, 2, 3}, o.moved_height_m, &gone);
  EXPECT_EQ(at_box(left, left.obstacle), 0);
  EXPECT_NEAR(at_box(left, left.elevation_m), 0.0, 1e-3);  // the flat ground the later pairs saw
  EXPECT_GT(gone.observations_moved_on, 0);
  EXPECT_EQ(CountCells(left.obstacle, [&](int r, int c) { return left.obstacle.at<float>(r, c) != 0; }), 0);
  // The same pairs fused in another order: the same map.
  const MapLayers shuffled = map(first_two, {3, 1, 2, 0}, o.moved_height_m, nullptr);
  EXPECT_EQ(cv::norm(left.elevation_m, shuffled.elevation_m, cv::NORM_INF), 0.0);
  // Off, the box stays.
  const MapLayers off = map(first_two, {0, 1, 2, 3}, kInfinity, nullptr);
  EXPECT_EQ(at_box(off, off.obstacle), 1);
  // A box that arrived after the ground was seen stays, fused in either order.
  for (const std::vector<int>& order : {std::vector<int>{0, 1, 2, 3}, std::vector<int>{3, 2, 1, 0}}) {
    const MapLayers arrived = map(last_two, order, o.moved_height_m, &kept);
    EXPECT_EQ(at_box(arrived, arrived.obstacle), 1);
  }
  EXPECT_EQ(kept.observations_moved_on, 0);
  // One later pair is not enough: the box seen by pairs 0-2, gone for pair 3 only.
  const MapLayers one_later = map([](int k) { return k < 3; }, {0, 1, 2, 3}, o.moved_height_m, nullptr);
  EXPECT_EQ(at_box(one_later, one_later.obstacle), 1);
}

TEST(TerrainGrid, FusingInTwoHalvesAndMergingEqualsFusingAtOnce) {
  const TerrainMapOptions o;
  const auto surface = [](double x, double y) {
    return 0.1 * std::sin(x) + 0.05 * y + (std::abs(x - 1) < 0.3 && std::abs(y - 7) < 0.3 ? 0.4 : 0.0);
  };
  std::vector<std::pair<cv::Mat, FramePose>> frames;
  for (int k = 0; k < 6; ++k) {
    const FramePose p = Pose(0.1 * k, 0.45 * k, 5.0 * k, 3.2 * k);
    cv::Mat xyz = SurfaceXyz(surface, p);
    xyz.at<cv::Vec3f>(10 + k, 20)[2] += 2.0f;  // an outlier per frame
    frames.push_back({xyz, p});
  }
  const TerrainGrid whole = Fuse(frames, o);
  TerrainGrid first = Fuse({frames.begin(), frames.begin() + 3}, o);
  const TerrainGrid second = Fuse({frames.begin() + 3, frames.end()}, o);
  first.Merge(second);
  const auto b = whole.MappedBounds();
  ASSERT_TRUE(b.has_value());
  ASSERT_EQ(first.MappedBounds(), b);
  ASSERT_EQ(first.MappedCells(), whole.MappedCells());
  for (std::int64_t j = (*b)[1]; j <= (*b)[3]; ++j) {
    for (std::int64_t i = (*b)[0]; i <= (*b)[2]; ++i) {
      const std::optional<CellStats> a = whole.Find({i, j});
      const std::optional<CellStats> m = first.Find({i, j});
      ASSERT_EQ(a.has_value(), m.has_value());
      if (!a) continue;
      EXPECT_EQ(a->count, m->count);
      EXPECT_EQ(a->rejected, m->rejected);
      EXPECT_EQ(a->z_min, m->z_min);
      EXPECT_EQ(a->z_max, m->z_max);
      EXPECT_EQ(a->last_t_s, m->last_t_s);
      EXPECT_NEAR(a->Mean(), m->Mean(), 1e-9);
      EXPECT_NEAR(a->sum_w, m->sum_w, 1e-9 * a->sum_w);
    }
  }
}

TEST(TerrainGrid, PoseErrorOfKnownSizeShiftsTheMapByThatAmount) {
  const TerrainMapOptions o = GridFrameOptions();
  const auto surface = BoxOnPlane(0.0, 1.0, 1.5, 6.0, 6.5, 0.3);
  const FramePose truth = Pose(0, 0, 0);
  const cv::Mat xyz = SurfaceXyz(surface, truth, 480, 640);
  // The same points placed with a pose 0.5 m east, 0.75 m north and 0.1 m high.
  FramePose wrong = Pose(0.5, 0.75, 0);
  wrong.z_m = 0.1;
  TerrainGrid a(o.cell_m), b(o.cell_m);
  a.Add(BinFrame(xyz, cv::Mat(), truth.WorldFromVehicle(), 0, o));
  b.Add(BinFrame(xyz, cv::Mat(), wrong.WorldFromVehicle(), 0, o));
  const MapLayers la = ComputeLayers(a, o.obstacles), lb = ComputeLayers(b, o.obstacles);
  EXPECT_NEAR(lb.x_west_m - la.x_west_m, 0.5, 1e-9);
  EXPECT_NEAR(lb.y_north_m - la.y_north_m, 0.75, 1e-9);
  ASSERT_EQ(la.elevation_m.size(), lb.elevation_m.size());
  for (int r = 0; r < la.elevation_m.rows; ++r) {
    for (int c = 0; c < la.elevation_m.cols; ++c) {
      const float ea = la.elevation_m.at<float>(r, c), eb = lb.elevation_m.at<float>(r, c);
      ASSERT_EQ(std::isfinite(ea), std::isfinite(eb));
      if (std::isfinite(ea)) {
        EXPECT_NEAR(eb - ea, 0.1, 1e-5);
      }
    }
  }
  // The box's obstacle cells moved by (+2, +3) cells.
  int col = 0, row = 0;
  ASSERT_TRUE(lb.CellOf(1.1 + 0.5, 6.1 + 0.75, &col, &row));
  EXPECT_GT(lb.obstacle.at<float>(row, col), 0);
  ASSERT_TRUE(lb.CellOf(1.1, 6.1, &col, &row));
  EXPECT_EQ(lb.obstacle.at<float>(row, col), 0);
}

TEST(TerrainGrid, AStateMovedOutOfTheWorldIsRefused) {
  // A state whose origin was moved 2,000 km (or 2^38 m, where 32-bit tile keys would wrap it
  // onto the unmoved map) is no map of this world: refused naming the file.
  const TerrainMapOptions o;
  const FramePose p = Pose(0.3, 0.2, 10, 4.5);
  const TerrainGrid grid = Fuse({{SurfaceXyz([](double x, double y) { return 0.2 * x - 0.1 * y; }, p), p}}, o);
  for (const double shift : {2e6, 274877906944.0}) {
    io::GeoRaster moved = grid.ToStateRaster();
    moved.x_west_m += shift;
    try {
      TerrainGrid::FromStateRaster(moved, "moved/state.tif");
      ADD_FAILURE() << "accepted a state moved by " << shift << " m";
    } catch (const lunarnav::InputError& e) {
      EXPECT_NE(std::string(e.what()).find("moved/state.tif"), std::string::npos) << e.what();
    }
  }
}

TEST(TerrainGrid, StateRasterRoundTripsExactly) {
  const TerrainMapOptions o;
  const FramePose p = Pose(0.3, 0.2, 10, 4.5);
  const TerrainGrid grid = Fuse({{SurfaceXyz([](double x, double y) { return 0.2 * x - 0.1 * y; }, p), p}}, o);
  const TerrainGrid back = TerrainGrid::FromStateRaster(grid.ToStateRaster(), "test");
  ASSERT_EQ(back.MappedBounds(), grid.MappedBounds());
  const auto b = *grid.MappedBounds();
  for (std::int64_t j = b[1]; j <= b[3]; ++j) {
    for (std::int64_t i = b[0]; i <= b[2]; ++i) {
      const std::optional<CellStats> s = grid.Find({i, j});
      const std::optional<CellStats> t = back.Find({i, j});
      ASSERT_EQ(s.has_value(), t.has_value());
      if (!s) continue;
      EXPECT_EQ(s->sum_w, t->sum_w);
      EXPECT_EQ(s->sum_wz, t->sum_wz);
      EXPECT_EQ(s->count, t->count);
      EXPECT_EQ(s->last_t_s, t->last_t_s);
    }
  }
}

TEST(TerrainGrid, WindowKeepsTheSurroundingsOfTheVehicleOnly) {
  TerrainMapOptions o;
  TerrainGrid grid(o.cell_m);
  for (int k = 0; k < 20; ++k) {
    const FramePose p = Pose(0, 5.0 * k, 0, k);
    grid.Add(BinFrame(SurfaceXyz([](double, double) { return 0.0; }, p, 40, 30), cv::Mat(), p.WorldFromVehicle(), k, o));
    grid.KeepWindow(p.x_m, p.y_m, 30.0);
  }
  // The vehicle is at y = 95 m; nothing 15 m (plus a tile of 16 m) behind it remains.
  const auto b = grid.MappedBounds();
  ASSERT_TRUE(b.has_value());
  EXPECT_GE((*b)[1] * o.cell_m, 95.0 - 15.0 - 16.0);
  EXPECT_LE(grid.TileCount(), 9u);  // a 30 m window touches at most 3 x 3 tiles of 16 m
}

// Free-space carving (the scenes rendered from the paper's rig, what stands in front hiding what
// lies behind, so that no true ray passes through a surface).
class Carving : public ::testing::Test {
 protected:
  Carving()
      : rig_(calib::RectifyRig(calib::testing::PaperRig(), 0.0)),
        model_(rig_, calib::ReferenceImage::kRight, 1.0),
        camera_(model_.ReferenceCamera()) {}

  // Six frames driving north 0.5 m apart; frames listed in `with_phantom` also see `phantom`
  // (a slab 0.6 m up over x in [-0.5, 0.5), y in [7, 7.5)), the others `ground`.
  std::vector<std::pair<cv::Mat, FramePose>> Drive(const testing::HeightFn& ground,
                                                   std::vector<int> with_phantom) const {
    std::vector<std::pair<cv::Mat, FramePose>> frames;
    for (int k = 0; k < 6; ++k) {
      const FramePose p = Pose(0, 0.5 * k, 0, k);
      const bool phantom = std::find(with_phantom.begin(), with_phantom.end(), k) != with_phantom.end();
      const testing::HeightFn seen = [&, phantom](double x, double y) {
        return phantom && x >= -0.5 && x < 0.5 && y >= 7 && y < 7.5 ? 0.6 : ground(x, y);
      };
      frames.push_back(
          {RenderedXyz(seen, p, camera_, 120, 200, -3, 3, 2, 16), p});  // to 16 m: the top of what stands at 7 m
    }
    return frames;
  }
  TerrainGrid Fuse(const std::vector<std::pair<cv::Mat, FramePose>>& frames, const TerrainMapOptions& o,
                   std::vector<int> which = {}) const {
    TerrainGrid grid(o.cell_m);
    for (std::size_t k = 0; k < frames.size(); ++k) {
      if (!which.empty() && std::find(which.begin(), which.end(), static_cast<int>(k)) == which.end()) continue;
      const auto& [xyz, pose] = frames[k];
      grid.Add(BinFrame(xyz, cv::Mat(), pose.WorldFromVehicle(), pose.t_s, o, &model_));
    }
    return grid;
  }
  static std::optional<CellStats> At(const TerrainGrid& grid, double x, double y, double tolerance) {
    return grid.Find({static_cast<std::int64_t>(std::floor(x / 0.25)), static_cast<std::int64_t>(std::floor(y / 0.25))},
                     tolerance);
  }

  calib::StereoRig rig_;
  ElevationErrorModel model_;
  Eigen::Vector3d camera_;
};

TEST_F(Carving, WhatLaterRaysPassBeneathIsLeftOut) {
  // The first three frames see something 0.6 m up (a cyclist gone by the fourth); the next
  // three see the ground there, and beyond it, with rays passing low over it.
  const TerrainMapOptions o;
  const auto frames = Drive([](double, double) { return 0.0; }, {0, 1, 2});
  const TerrainGrid grid = Fuse(frames, o);
  CarveCounts carved;
  const MapLayers l = ComputeLayers(grid, o.obstacles, 1, o.carve_tolerance_m, kInfinity, &carved);
  const MapLayers kept = ComputeLayers(grid, o.obstacles, 1);  // no carving
  int phantom_cells = 0;
  for (double y = 7.125; y < 7.5; y += 0.25) {
    for (double x = -0.125; x < 0.5; x += 0.25) {  // (its west column: the support rule's, seen from the east)
      int col = 0, row = 0;
      ASSERT_TRUE(l.CellOf(x, y, &col, &row));
      ++phantom_cells;
      EXPECT_GT(kept.elevation_m.at<float>(row, col), 0.1) << x << ", " << y;  // the scene can fail the test
      EXPECT_NEAR(l.elevation_m.at<float>(row, col), 0.0, 0.01) << x << ", " << y;
      EXPECT_EQ(l.obstacle.at<float>(row, col), 0) << x << ", " << y;
      const auto s = At(grid, x, y, o.carve_tolerance_m);
      ASSERT_TRUE(s.has_value());
      EXPECT_GE(s->carved_frames, 1u) << x << ", " << y;
      EXPECT_LT(s->ceiling2, 0.3);
    }
  }
  EXPECT_GE(carved.cells_changed, phantom_cells);
  EXPECT_EQ(carved.cells_cleared, 0);
  // Outside the slab's cells the ground is flat.
  EXPECT_EQ(CountCells(l.elevation_m,
                       [&](int r, int c) {
                         const double x = l.x_west_m + (c + 0.5) * l.cell_m, y = l.y_north_m - (r + 0.5) * l.cell_m;
                         const bool slab = x > -0.5 && x < 0.5 && y > 7 && y < 7.5;
                         return !slab && std::abs(l.elevation_m.at<float>(r, c)) > 0.01;
                       }),
            0);
}

TEST_F(Carving, WhatEveryFrameSeesStays) {
  // A box 0.3 m high, 0.75 m wide, that every frame sees: its rays pass beside it and over it,
  // never beneath its top, and a frame's rays beside what it sees in the same cell do not carve.
  const TerrainMapOptions o;
  const auto frames = Drive(BoxOnPlane(0.0, -0.6, 0.15, 7.0, 7.5, 0.3), {});
  const TerrainGrid grid = Fuse(frames, o);
  CarveCounts carved;
  const MapLayers l = ComputeLayers(grid, o.obstacles, 1, o.carve_tolerance_m, kInfinity, &carved);
  const MapLayers kept = ComputeLayers(grid, o.obstacles, 1);
  EXPECT_EQ(carved.observations, 0);
  for (int r = 0; r < l.elevation_m.rows; ++r) {
    for (int c = 0; c < l.elevation_m.cols; ++c) {
      const float a = l.elevation_m.at<float>(r, c), b = kept.elevation_m.at<float>(r, c);
      ASSERT_EQ(std::isfinite(a), std::isfinite(b));
      if (std::isfinite(a)) {
        EXPECT_EQ(a, b);
        const float oa = l.obstacle.at<float>(r, c), ob = kept.obstacle.at<float>(r, c);
        EXPECT_TRUE(oa == ob || (std::isnan(oa) && std::isnan(ob)));
      }
    }
  }
  int col = 0, row = 0;
  ASSERT_TRUE(l.CellOf(-0.2, 7.4, &col, &row));
  EXPECT_NEAR(l.elevation_m.at<float>(row, col), 0.3, 0.01);
  EXPECT_GT(l.obstacle.at<float>(row, col), 0);
}

TEST_F(Carving, FusingInPartsMergingAndResumingEqualsFusingAtOnce) {
  const TerrainMapOptions o;
  const auto frames = Drive([](double x, double y) { return 0.05 * x + 0.02 * y; }, {0, 3});
  const TerrainGrid whole = Fuse(frames, o);
  TerrainGrid parts = Fuse(frames, o, {0, 2, 4});
  parts.Merge(Fuse(frames, o, {5, 3, 1}));
  const TerrainGrid back = TerrainGrid::FromStateRaster(parts.ToStateRaster(), "test");
  const auto b = whole.MappedBounds();
  ASSERT_TRUE(b.has_value());
  int carved_cells = 0;
  for (const TerrainGrid* other : {static_cast<const TerrainGrid*>(&parts), &back}) {
    ASSERT_EQ(other->MappedBounds(), b);
    for (std::int64_t j = (*b)[1]; j <= (*b)[3]; ++j) {
      for (std::int64_t i = (*b)[0]; i <= (*b)[2]; ++i) {
        const auto a = whole.Find({i, j}, o.carve_tolerance_m), m = other->Find({i, j}, o.carve_tolerance_m);
        ASSERT_EQ(a.has_value(), m.has_value());
        if (!a) continue;
        carved_cells += a->carved_frames > 0;
        EXPECT_EQ(a->count, m->count);
        EXPECT_EQ(a->frames, m->frames);
        EXPECT_EQ(a->carved_frames, m->carved_frames);
        EXPECT_EQ(a->ceiling, m->ceiling);
        EXPECT_EQ(a->ceiling2, m->ceiling2);
        EXPECT_EQ(a->z_max2, m->z_max2);
        if (a->count > 0) {
          EXPECT_NEAR(a->Mean(), m->Mean(), 1e-9);
        }
      }
    }
  }
  EXPECT_GT(carved_cells, 0);  // the phantom was there to carve
}

TEST_F(Carving, WhatTheRayToItShowsHiddenIsLeftOut) {
  // Flat ground; in a strip 20 cm wide (what one camera sees beside an object's edge), the
  // points of the ground 7-7.5 m ahead matched too far (1.3 times their distance, along their
  // rays: 2.3 m farther and 0.45 m under the ground, where the ground the frame sees 8-9 m ahead
  // beside the strip would have stopped the rays); the true points where they land missing.
  const TerrainMapOptions o;
  const FramePose p = Pose(0, 0, 0);
  cv::Mat xyz = RenderedXyz([](double, double) { return 0.0; }, p, camera_, 120, 160);
  int moved = 0;
  for (auto it = xyz.begin<cv::Vec3f>(); it != xyz.end<cv::Vec3f>(); ++it) {
    const Eigen::Vector3d v((*it)[0], (*it)[1], (*it)[2]);
    if (v.y() >= 9 && v.y() < 10 && v.x() >= -0.5 && v.x() < 0) {
      *it = cv::Vec3f::all(std::numeric_limits<float>::quiet_NaN());
    }
    if (v.y() >= 7 && v.y() < 7.5 && std::abs(v.x()) < 0.1) {
      const Eigen::Vector3d w = camera_ + 1.3 * (v - camera_);
      *it = cv::Vec3f(static_cast<float>(w.x()), static_cast<float>(w.y()), static_cast<float>(w.z()));
      ++moved;
    }
  }
  TerrainMapOptions off = o;
  off.hidden_tolerance_m = std::numeric_limits<double>::infinity();
  const FrameContribution kept = BinFrame(xyz, cv::Mat(), p.WorldFromVehicle(), 0, off, &model_);
  const FrameContribution hid = BinFrame(xyz, cv::Mat(), p.WorldFromVehicle(), 0, o, &model_);
  EXPECT_EQ(kept.points_hidden, 0);
  EXPECT_GE(hid.points_hidden, moved * 9 / 10);
  EXPECT_LE(hid.points_hidden, moved);
  int deep_kept = 0, deep_hid = 0;
  for (const auto& [index, s] : kept.cells) deep_kept += s.count > 0 && s.Mean() < -0.2;
  for (const auto& [index, s] : hid.cells) deep_hid += s.count > 0 && s.Mean() < -0.2;
  EXPECT_GE(deep_kept, 2);  // the wrong matches made a hole without the rule
  EXPECT_EQ(deep_hid, 0);
}

TEST_F(Carving, TheRayIsTestedAgainstTheGroundNotItsNoisesTail) {
  // A road 3 cm rough seen from the right camera (1.5 m up), one point in 23 of it 10 cm low
  // (the tail of its noise); four points of it 6.5 m ahead matched 1.17 times too far along
  // their rays (7.6-7.7 m ahead, 25 cm under the road), where the road went unmatched, as
  // raw 0005's pair 0 did beside the tram rails. The rays back from them pass under the road
  // cells before them by more than the tolerance (10 cm) under the road's 10th percentile, and
  // by less under its lowest points.
  const FramePose p = Pose(0, 0, 0);
  cv::Mat xyz = RenderedXyz([](double, double) { return 0.0; }, p, camera_, 240, 240, -3, 3, 2, 12);
  int moved = 0, k = 0;
  for (auto it = xyz.begin<cv::Vec3f>(); it != xyz.end<cv::Vec3f>(); ++it) {
    if (!std::isfinite((*it)[2])) continue;
    const Eigen::Vector3d v((*it)[0], (*it)[1], (*it)[2]);
    if (v.y() >= 7.5 && v.y() < 8 && v.x() >= 0 && v.x() < 0.25) {
      *it = cv::Vec3f::all(std::numeric_limits<float>::quiet_NaN());
    } else if (v.y() >= 6.5 && v.y() < 6.6 && v.x() >= 0.1 && v.x() < 0.15) {
      const Eigen::Vector3d w = camera_ + 1.17 * (v - camera_);
      *it = cv::Vec3f(static_cast<float>(w.x()), static_cast<float>(w.y()), static_cast<float>(w.z()));
      ++moved;
    } else {
      const int phase = k++ % 23;  // 23: prime to the rows' 240 points
      (*it)[2] += phase == 0 ? -0.10f : 0.05f * static_cast<float>(phase - 11) / 11.0f;
    }
  }
  TerrainMapOptions lowest;
  lowest.hidden_ground_quantile = 0;
  const FrameContribution by_lowest = BinFrame(xyz, cv::Mat(), p.WorldFromVehicle(), 0, lowest, &model_);
  const FrameContribution by_ground = BinFrame(xyz, cv::Mat(), p.WorldFromVehicle(), 0, TerrainMapOptions(), &model_);
  auto deep = [](const FrameContribution& f) {
    int n = 0;
    for (const auto& [index, s] : f.cells) n += s.count > 0 && s.Mean() < -0.15;
    return n;
  };
  ASSERT_EQ(moved, 4);
  EXPECT_EQ(by_lowest.points_hidden, 0);
  EXPECT_EQ(deep(by_lowest), 1);  // the patch
  EXPECT_EQ(by_ground.points_hidden, moved);  // the patch, nothing of the road
  EXPECT_EQ(deep(by_ground), 0);
}

TEST_F(Carving, WhatStandsBehindADepthEdgeIsLeftOutTheGroundBesideItKept) {
  // A box 0.5 m wide and 1 m tall 7-7.5 m ahead on flat ground. The two outermost columns of
  // its points on each side, where a matcher's window straddles the box's silhouette and what
  // lies behind it, matched 0.6 m too far along their rays: standing behind the box, as a
  // pedestrian's edge stood behind him on raw 0005.
  const FramePose p = Pose(0, 0, 0);
  auto box = [](double x, double y) { return std::abs(x) < 0.25 && y >= 7 && y < 7.5 ? 1.0 : 0.0; };
  cv::Mat xyz = RenderedXyz(box, p, camera_, 160, 160, -3, 3, 2, 12);
  int moved = 0;
  for (int r = 0; r < xyz.rows; ++r) {
    auto on_box = [&](int c) {
      const cv::Vec3f& v = xyz.at<cv::Vec3f>(r, c);
      return c >= 0 && c < xyz.cols && std::isfinite(v[2]) && v[2] > 0.05f;
    };
    std::vector<int> edge;
    for (int c = 0; c < xyz.cols; ++c) {
      if (on_box(c) && !(on_box(c - 2) && on_box(c + 2))) edge.push_back(c);
    }
    for (int c : edge) {
      cv::Vec3f& v = xyz.at<cv::Vec3f>(r, c);
      const Eigen::Vector3d at(v[0], v[1], v[2]), ray = at - camera_;
      const Eigen::Vector3d far = at + 0.6 * ray / std::hypot(ray.x(), ray.y());  // 0.6 m farther, horizontally
      moved += far.z() > 0.25;
      v = cv::Vec3f(static_cast<float>(far.x()), static_cast<float>(far.y()), static_cast<float>(far.z()));
    }
  }
  ASSERT_GT(moved, 20);
  TerrainMapOptions off;
  off.edge_margin_px = 0;
  const FrameContribution with = BinFrame(xyz, cv::Mat(), p.WorldFromVehicle(), 0, TerrainMapOptions(), &model_);
  const FrameContribution without = BinFrame(xyz, cv::Mat(), p.WorldFromVehicle(), 0, off, &model_);
  auto count_cells = [](const FrameContribution& f, auto&& which) {
    int n = 0;
    for (const auto& [index, s] : f.cells) {
      n += s.count > 0 && which((static_cast<double>(index.i) + 0.5) * 0.25, (static_cast<double>(index.j) + 0.5) * 0.25, s);
    }
    return n;
  };
  // Behind the box (7.5-8.5 m) nothing stands: the ground there is hidden, or flat.
  auto standing_behind = [](double, double y, const CellStats& s) { return y > 7.5 && y < 8.5 && s.z_max > 0.25; };
  auto box_top = [](double, double y, const CellStats& s) { return y > 7 && y < 7.5 && s.count >= 3 && s.z_max > 0.4; };
  EXPECT_GE(count_cells(without, standing_behind), 2);  // the phantoms, without the rule
  EXPECT_EQ(count_cells(with, standing_behind), 0);
  EXPECT_EQ(without.points_edge, 0);
  EXPECT_GT(with.points_edge, 20);
  EXPECT_GE(count_cells(with, box_top), 2);  // the box stays
  EXPECT_EQ(count_cells(with, box_top), count_cells(without, box_top));
  // And the ground beside it: every flat cell stays, with its points.
  std::map<std::pair<std::int64_t, std::int64_t>, std::uint32_t> flat;
  for (const auto& [index, s] : without.cells) {
    if (s.count > 0 && s.z_max < 0.05) flat[{index.i, index.j}] = s.count;
  }
  int kept = 0;
  for (const auto& [index, s] : with.cells) {
    const auto it = flat.find({index.i, index.j});
    kept += it != flat.end() && s.count == it->second;
  }
  EXPECT_EQ(kept, static_cast<int>(flat.size()));
}

TEST_F(Carving, BinningReadsNoRowsIndex) {
  // terrain-map bins only the rows of a pair's map that hold points (a rig's search matches a
  // band of rows): a frame with rows of NaN above and below its points bins exactly as its rows
  // with points alone, every rule on (depth edges at the box's silhouette, carving, hidden).
  const FramePose p = Pose(0, 0, 0);
  auto box = [](double x, double y) { return std::abs(x) < 0.25 && y >= 7 && y < 7.5 ? 1.0 : 0.0; };
  const cv::Mat points = RenderedXyz(box, p, camera_, 160, 160, -3, 3, 2, 12);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cv::Mat padded(points.rows + 30, points.cols, CV_32FC3, cv::Scalar(nan, nan, nan));
  points.copyTo(padded.rowRange(10, 10 + points.rows));
  const TerrainMapOptions o;
  const FrameContribution whole = BinFrame(padded, cv::Mat(), p.WorldFromVehicle(), 0, o, &model_);
  const FrameContribution rows = BinFrame(padded.rowRange(10, 10 + points.rows), cv::Mat(), p.WorldFromVehicle(), 0, o, &model_);
  const FrameContribution none = BinFrame(padded.rowRange(0, 10), cv::Mat(), p.WorldFromVehicle(), 0, o, &model_);
  ASSERT_GT(whole.points_in, 1000);
  ASSERT_GT(whole.points_edge, 0);
  ASSERT_GT(whole.rays_cast, 0);
  EXPECT_EQ(none.points_in, 0);
  EXPECT_TRUE(none.cells.empty());
  EXPECT_EQ(BinFrame(padded.rowRange(0, 0), cv::Mat(), p.WorldFromVehicle(), 0, o, &model_).points_in, 0);  // no row
  EXPECT_EQ(rows.points_in, whole.points_in);
  EXPECT_EQ(rows.points_fused, whole.points_fused);
  EXPECT_EQ(rows.points_rejected, whole.points_rejected);
  EXPECT_EQ(rows.points_edge, whole.points_edge);
  EXPECT_EQ(rows.points_hidden, whole.points_hidden);
  EXPECT_EQ(rows.rays_cast, whole.rays_cast);
  ASSERT_EQ(rows.cells.size(), whole.cells.size());
  for (std::size_t k = 0; k < rows.cells.size(); ++k) {
    const auto& [a, sa] = rows.cells[k];
    const auto& [b, sb] = whole.cells[k];
    ASSERT_TRUE(a.i == b.i && a.j == b.j) << k;
    EXPECT_EQ(sa.sum_w, sb.sum_w) << k;
    EXPECT_EQ(sa.sum_wz, sb.sum_wz) << k;
    EXPECT_EQ(sa.sum_wzz, sb.sum_wzz) << k;
    EXPECT_EQ(sa.z_min, sb.z_min) << k;
    EXPECT_EQ(sa.z_max2, sb.z_max2) << k;
    EXPECT_EQ(sa.count, sb.count) << k;
    EXPECT_EQ(sa.ceiling, sb.ceiling) << k;
  }
}

TEST_F(Carving, InsideAHedgeWithNoGroundInSightTheDepthEdgeRuleKeepsThePoints) {
  // A hedge's face as a pair sees it where no ground shows: leaves at two depths, 7.0 and 7.8 m
  // ahead in stripes 8 px wide, 0-2 m up. Every far leaf lies within the margin of a near
  // stripe, more than a pixel of disparity behind it: at a depth edge, standing. With no
  // ground in its cell or within two cells around it, the rule has nothing to judge such a
  // point by, and the hedge's back is real: it stays. Where the pair sees ground beside them
  // (7.3-7.7 m ahead, below the face in the image), the same points stand over that ground
  // behind a nearer surface, as a walker's edge did on raw 0005: left out.
  const FramePose p = Pose(0, 0, 0);
  const int rows = 60, cols = 248;  // 31 stripes, near ones at both ends
  auto far_column = [](int c) { return (c / 8) % 2 == 1; };
  auto hedge = [&](bool ground_below) {
    const int ground_rows = ground_below ? 20 : 0;
    cv::Mat xyz(rows + ground_rows, cols, CV_32FC3, cv::Scalar::all(std::numeric_limits<float>::quiet_NaN()));
    for (int r = 0; r < xyz.rows; ++r) {
      for (int c = 0; c < cols; ++c) {
        const double x = -3.0 + 6.0 * c / cols;
        double y = far_column(c) ? 7.8 : 7.0, z = 2.0 - 2.0 * r / (rows - 1);
        if (r >= rows) {  // below the face in the image: ground, 7.3-7.7 m ahead
          y = 7.7 - 0.4 * (r - rows) / (ground_rows - 1);
          z = 0;
        }
        xyz.at<cv::Vec3f>(r, c) = cv::Vec3f(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z));
      }
    }
    return xyz;
  };
  TerrainMapOptions off;
  off.edge_margin_px = 0;
  auto far_points = [](const FrameContribution& f) {
    std::uint32_t n = 0;
    for (const auto& [index, s] : f.cells) n += (static_cast<double>(index.j) + 0.5) * 0.25 > 7.75 ? s.count : 0;
    return n;
  };
  const cv::Mat alone = hedge(false), over_ground = hedge(true);
  const FrameContribution kept = BinFrame(alone, cv::Mat(), p.WorldFromVehicle(), 0, TerrainMapOptions(), &model_);
  const FrameContribution all = BinFrame(alone, cv::Mat(), p.WorldFromVehicle(), 0, off, &model_);
  ASSERT_GT(far_points(all), 3000u);
  EXPECT_EQ(kept.points_edge, 0);
  EXPECT_EQ(far_points(kept), far_points(all));
  const FrameContribution judged =
      BinFrame(over_ground, cv::Mat(), p.WorldFromVehicle(), 0, TerrainMapOptions(), &model_);
  const FrameContribution judged_off = BinFrame(over_ground, cv::Mat(), p.WorldFromVehicle(), 0, off, &model_);
  ASSERT_GT(far_points(judged_off), 3000u);
  EXPECT_GT(judged.points_edge, 3000);
  EXPECT_LT(far_points(judged), far_points(judged_off) / 4);
}

TEST_F(Carving, ASlantedSideIsNoDepthEdge) {
  // A parked car's side seen along the road: a box 1.8 m wide and 1.5 m tall, 5-10 m ahead, its
  // near side 2 m to the right of the camera, in a level perspective image of the rig's focal
  // length, with a matcher's noise. Along a row its side's disparity changes by more than the
  // edge step within the margin (0.46 px per pixel at 7 m), linearly: no point of it is at a
  // depth edge but where the side ends against what lies beyond.
  const FramePose p = Pose(0, 0, 0);
  const double f = rig_.rectified->P_left(0, 0), x0 = camera_.x() + 2.0, x1 = x0 + 1.8, y0 = 5, y1 = 10, top = 1.5;
  const int cols = 2 * static_cast<int>(f), rows = static_cast<int>(f) / 2;
  cv::Mat xyz(rows, cols, CV_32FC3, cv::Scalar::all(std::numeric_limits<float>::quiet_NaN()));
  int side = 0;
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const Eigen::Vector3d ray((c + 0.5 - cols / 2.0) / f, 1.0, -(r + 0.5 - rows / 2.0) / f);
      double t = ray.z() < 0 ? -camera_.z() / ray.z() : std::numeric_limits<double>::infinity();  // the ground
      bool on_side = false;
      if (ray.x() > 0) {  // the box's near side, x = x0
        const double ts = (x0 - camera_.x()) / ray.x();
        const Eigen::Vector3d at = camera_ + ts * ray;
        if (ts < t && at.y() >= y0 && at.y() <= y1 && at.z() >= 0 && at.z() <= top) {
          t = ts;
          on_side = true;
        }
      }
      const double tb = (y0 - camera_.y()) / ray.y();  // its rear, y = y0
      const Eigen::Vector3d rear = camera_ + tb * ray;
      if (tb < t && rear.x() >= x0 && rear.x() <= x1 && rear.z() >= 0 && rear.z() <= top) {
        t = tb;
        on_side = false;
      }
      if (!std::isfinite(t) || t * ray.y() > 14) continue;
      t *= 1 + 0.002 * std::sin(1.7 * c + r);  // a matcher's noise: 0.2 % of the depth, 0.2 px at 7 m
      const Eigen::Vector3d at = camera_ + t * ray;
      xyz.at<cv::Vec3f>(r, c) = cv::Vec3f(static_cast<float>(at.x()), static_cast<float>(at.y()), static_cast<float>(at.z()));
      side += on_side && at.z() > 0.3;
    }
  }
  ASSERT_GT(side, 500);
  // The side's disparity 6 px apart along a row differs by more than the step (1 px).
  const TerrainMapOptions o;
  const double lateral = x0 - camera_.x(), y_beside = lateral / (lateral / 7 + 6 / f);  // 6 px to the right
  ASSERT_GT(model_.DisparityPx(x0, y_beside, 0.5) - model_.DisparityPx(x0, 7, 0.5), o.edge_step_px);
  const FrameContribution with = BinFrame(xyz, cv::Mat(), p.WorldFromVehicle(), 0, o, &model_);
  EXPECT_LT(with.points_edge, side / 20);
}

TEST_F(Carving, ADitchSeenOverItsLipIsNotHidden) {
  // A ditch 0.4 m deep from 6 m ahead on, its bottom seen over the lip from 7.6 m: true low
  // ground, which no ray reaches through the ground.
  const TerrainMapOptions o;
  const FramePose p = Pose(0, 0, 0);
  const cv::Mat xyz = RenderedXyz([](double, double y) { return y >= 6 ? -0.4 : 0.0; }, p, camera_, 120, 160);
  const FrameContribution f = BinFrame(xyz, cv::Mat(), p.WorldFromVehicle(), 0, o, &model_);
  EXPECT_EQ(f.points_hidden, 0);
  int bottom = 0;
  for (const auto& [index, s] : f.cells) bottom += s.count > 0 && std::abs(s.Mean() + 0.4) < 0.02;
  EXPECT_GT(bottom, 8);
}

TEST_F(Carving, ACellOnePairSawHighAndTheOthersSawThroughIsNoStep) {
  // Three pairs over flat ground at the defaults; pair 1's points in the cell at (0.1, 7.1), all
  // of them (a wrong-match patch the speckle filter keeps: a cell's worth, past the gate and the
  // three points a pair's top needs), 35 cm up. Pairs 0 and 2 see the ground there and beyond it.
  const TerrainMapOptions o;
  std::vector<std::pair<cv::Mat, FramePose>> frames;
  int raised = 0;
  for (int k = 0; k < 3; ++k) {
    const FramePose p = Pose(0, 0.3 * k, 0, k);
    cv::Mat xyz = RenderedXyz([](double, double) { return 0.0; }, p, camera_, 120, 200, -3, 3, 2, 12);
    if (k == 1) {
      for (auto it = xyz.begin<cv::Vec3f>(); it != xyz.end<cv::Vec3f>(); ++it) {
        const Eigen::Vector3d w = p.WorldFromVehicle() * Eigen::Vector3d((*it)[0], (*it)[1], (*it)[2]);
        if (w.x() >= 0 && w.x() < 0.25 && w.y() >= 7 && w.y() < 7.25) {
          (*it)[2] += 0.35f;
          ++raised;
        }
      }
    }
    frames.push_back({xyz, p});
  }
  ASSERT_GE(raised, 3);
  // At the defaults: no step there or around (pair 1's own support rule sees a rise no face led
  // to; the other pairs' rays pass beneath it).
  const MapLayers l = ComputeLayers(Fuse(frames, o), o.obstacles, o.min_frames, o.carve_tolerance_m);
  int col = 0, row = 0;
  ASSERT_TRUE(l.CellOf(0.1, 7.1, &col, &row));
  EXPECT_NEAR(l.elevation_m.at<float>(row, col), 0.0, 0.01);
  for (int dr = -1; dr <= 1; ++dr) {
    for (int dc = -1; dc <= 1; ++dc) EXPECT_EQ(l.obstacle.at<float>(row + dr, col + dc), 0) << dr << ", " << dc;
  }
  // Carving alone does it too (the support rule off); with neither, the patch is a step.
  TerrainMapOptions no_support = o;
  no_support.support_rise_m = std::numeric_limits<double>::infinity();
  const TerrainGrid grid = Fuse(frames, no_support);
  EXPECT_EQ(ComputeLayers(grid, o.obstacles, o.min_frames, o.carve_tolerance_m).obstacle.at<float>(row, col), 0);
  EXPECT_EQ(ComputeLayers(grid, o.obstacles, o.min_frames).obstacle.at<float>(row, col), 1);
}

TEST_F(Carving, ABoxIsAnObstacleAtTheDefaultsEvenWithPartOfItsFaceUnmatched) {
  // What a user runs (support rule, visibility, gate, carving, hidden observations all at
  // their defaults) on a box 0.3 m tall seen by six pairs, rendered with its faces; in every
  // pair the lower half of its front face matched nothing (NaN), as a dark or shadowed face does.
  const TerrainMapOptions o;
  const auto box = BoxOnPlane(0.0, -0.5, 0.25, 7.0, 7.5, 0.3);
  auto frames = Drive(box, {});
  int dropped = 0;
  for (auto& [xyz, pose] : frames) {
    for (auto it = xyz.begin<cv::Vec3f>(); it != xyz.end<cv::Vec3f>(); ++it) {
      const Eigen::Vector3d w = pose.WorldFromVehicle() * Eigen::Vector3d((*it)[0], (*it)[1], (*it)[2]);
      if (std::abs(w.y() - 7.0) < 0.01 && w.z() > 0.005 && w.z() < 0.15) {
        *it = cv::Vec3f::all(std::numeric_limits<float>::quiet_NaN());
        ++dropped;
      }
    }
  }
  ASSERT_GT(dropped, 50);
  const TerrainGrid grid = Fuse(frames, o);
  const MapLayers l = ComputeLayers(grid, o.obstacles, o.min_frames, o.carve_tolerance_m);
  // The box's top cells are steps at its height; nothing a cell beyond its footprint is.
  int steps_on_box = 0, steps_elsewhere = 0;
  for (int r = 0; r < l.obstacle.rows; ++r) {
    for (int c = 0; c < l.obstacle.cols; ++c) {
      const float kind = l.obstacle.at<float>(r, c);
      if (!(kind > 0)) continue;
      const double x = l.x_west_m + (c + 0.5) * l.cell_m, y = l.y_north_m - (r + 0.5) * l.cell_m;
      const bool near_box = x > -0.5 - l.cell_m && x < 0.25 + l.cell_m && y > 7.0 - l.cell_m && y < 7.5 + l.cell_m;
      ++(near_box ? steps_on_box : steps_elsewhere);
    }
  }
  EXPECT_EQ(steps_elsewhere, 0);
  // Its front row, above the ground the pairs see before it, is a step at the box's height (the
  // ground behind it is hidden: the back row's top has no lower neighbour to step from).
  for (double x : {-0.375, -0.125, 0.125}) {
    int col = 0, row = 0;
    ASSERT_TRUE(l.CellOf(x, 7.125, &col, &row));
    EXPECT_GT(l.obstacle.at<float>(row, col), 0) << x;
  }
  EXPECT_GE(steps_on_box, 3);
  int col = 0, row = 0;
  ASSERT_TRUE(l.CellOf(-0.125, 7.375, &col, &row));
  EXPECT_NEAR(l.elevation_m.at<float>(row, col), 0.3, 0.02);
}

TEST(TerrainGrid, HeightBinsDependOnTheObservationsNotTheirOrder) {
  // One cell, observations at heights spread over 2 m (more than kMaxHeightBins bins of
  // kHeightBinM): the bins coarsen; added in any order or merged from parts, the same cell,
  // and a ceiling leaves out the same observations.
  const std::vector<double> heights = {0.0, 0.05, 1.9, 0.31, -0.12, 0.74, 0.75, 1.2, 0.02, -0.4};
  auto frame = [](double z, float ceiling) {
    CellStats s;
    s.sum_w = 1;
    s.sum_wz = z;
    s.sum_wzz = z * z;
    s.z_min = s.z_max = s.z_max2 = static_cast<float>(z);
    s.count = 1;
    s.frames = 1;
    s.ceiling = ceiling;
    FrameContribution f;
    f.cells.push_back({CellIndex{3, -2}, s});
    return f;
  };
  auto fuse = [&](const std::vector<int>& order) {
    TerrainGrid g(0.25);
    for (int k : order) g.Add(frame(heights[k], k == 4 ? 0.5f : k == 6 ? 0.6f : kInfinity));
    return g;
  };
  const TerrainGrid forward = fuse({0, 1, 2, 3, 4, 5, 6, 7, 8, 9});
  const TerrainGrid backward = fuse({9, 8, 7, 6, 5, 4, 3, 2, 1, 0});
  TerrainGrid merged = fuse({2, 7, 5});
  merged.Merge(fuse({0, 1, 3, 4, 6, 8, 9}));
  for (double tolerance : {0.0, 0.1, 0.5, 2.0, static_cast<double>(kInfinity)}) {
    const auto a = forward.Find({3, -2}, tolerance);
    ASSERT_TRUE(a.has_value());
    for (const TerrainGrid* g : {&backward, static_cast<const TerrainGrid*>(&merged)}) {
      const auto b = g->Find({3, -2}, tolerance);
      ASSERT_TRUE(b.has_value());
      EXPECT_EQ(a->count, b->count) << tolerance;
      EXPECT_EQ(a->carved_points, b->carved_points) << tolerance;
      EXPECT_EQ(a->z_max, b->z_max) << tolerance;
      if (a->count > 0) {
        EXPECT_NEAR(a->Mean(), b->Mean(), 1e-12) << tolerance;
      }
    }
    if (std::isinf(tolerance)) {
      EXPECT_EQ(a->count, heights.size());
    }
  }
  // The ceiling 0.6 m (the second lowest) leaves out what stands more than the tolerance above
  // it, at the coarsened bins' resolution: the observation at 1.9 m at least.
  const auto carved = forward.Find({3, -2}, 0.1);
  EXPECT_GE(carved->carved_points, 1u);
  EXPECT_LT(carved->z_max, 1.9f);
}

constexpr float kNaNF = std::numeric_limits<float>::quiet_NaN();

// The depth-edge test as its definition reads, one column at a time with bounds checks: the
// reference for the row-at-a-time DepthEdgeRow.
bool DepthEdgeReference(const std::vector<float>& d, int col, int margin, float step) {
  const int cols = static_cast<int>(d.size());
  auto at = [&](int k) { return k >= 0 && k < cols ? d[static_cast<std::size_t>(k)] : kNaNF; };
  auto nearest = [&](int dir) {  // the farthest valid column 2-4 px away that way, or col
    for (int k = col + 4 * dir; std::abs(k - col) >= 2; k -= dir) {
      if (!std::isnan(at(k))) return k;
    }
    return col;
  };
  const int l = nearest(-1), r = nearest(1);
  const float own = at(col);
  float slope = 0.0f;
  if (l != col && r != col) {
    const float left = (own - at(l)) / static_cast<float>(col - l), right = (at(r) - own) / static_cast<float>(r - col);
    if (std::abs(left - right) <= 0.3f) slope = 0.5f * (left + right);
  }
  for (int k = std::max(0, col - margin); k <= std::min(cols - 1, col + margin); ++k) {
    if (at(k) - own - slope * static_cast<float>(k - col) > step) return true;
  }
  return false;
}

TEST(DepthEdgeRow, AgreesWithTheTestAsDefinedOnEveryColumn) {
  // Rows of level and slanted surfaces with holes, steps up and down and noise, of widths that
  // are and are not multiples of four, for margins up to the padding's.
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  long edges = 0, columns = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const int cols = 1 + static_cast<int>(unit(rng) * 300);
    const int margin = trial % 10 == 0 ? internal::kEdgeRowPad : 1 + static_cast<int>(unit(rng) * 12);
    const float step = 0.25f + 2.0f * unit(rng);
    std::vector<float> d(static_cast<std::size_t>(cols));
    float level = 20 + 40 * unit(rng), slope = unit(rng) < 0.5f ? 0.0f : unit(rng) - 0.5f;
    for (int c = 0; c < cols; ++c) {
      if (unit(rng) < 0.05f) level += (unit(rng) - 0.5f) * 8;  // a depth edge
      if (unit(rng) < 0.03f) slope = unit(rng) < 0.5f ? 0.0f : unit(rng) - 0.5f;
      d[static_cast<std::size_t>(c)] = unit(rng) < 0.15f ? kNaNF : level + slope * c + 0.4f * (unit(rng) - 0.5f);
    }
    std::vector<float> padded(static_cast<std::size_t>(cols + 2 * internal::kEdgeRowPad), kNaNF);
    std::copy(d.begin(), d.end(), padded.begin() + internal::kEdgeRowPad);
    std::vector<std::uint8_t> edge(static_cast<std::size_t>(cols), 2);
    internal::DepthEdgeRow(padded.data() + internal::kEdgeRowPad, cols, margin, step, edge.data());
    for (int c = 0; c < cols; ++c) {
      if (std::isnan(d[static_cast<std::size_t>(c)])) continue;  // no point: the answer is unused
      const bool expected = DepthEdgeReference(d, c, margin, step);
      ASSERT_EQ(edge[static_cast<std::size_t>(c)], expected ? 1 : 0)
          << "trial " << trial << " column " << c << " of " << cols << ", margin " << margin;
      edges += expected;
      ++columns;
    }
  }
  // Both answers were exercised.
  EXPECT_GT(edges, columns / 20);
  EXPECT_LT(edges, columns - columns / 20);
}

}  // namespace
}  // namespace lunarnav::mapping
