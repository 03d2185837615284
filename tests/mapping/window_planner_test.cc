#include "mapping/window_planner.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "util/errors.h"

namespace lunarnav::mapping {
namespace {

// A straight run north at `speed` m/s, a pair every `interval` s.
std::vector<FramePose> StraightRun(double speed, double interval, int n) {
  std::vector<FramePose> poses;
  for (int k = 0; k < n; ++k) {
    FramePose p;
    p.stem = std::to_string(k);
    p.t_s = k * interval;
    p.y_m = speed * p.t_s;
    poses.push_back(p);
  }
  return poses;
}

TEST(PlanWindows, IntervalGrowsWithSpeedAsTheStoppingDistanceDoes) {
  const calib::VehicleSpec ratler;  // the paper's: t_stop 2 s, mu 0.25
  const WindowPlannerOptions o;
  const double g = calib::GravityMps2(o.gravity);
  std::vector<double> y_need, y_max;
  for (double v : {0.15, 0.4, 0.7}) {
    const auto plan = PlanWindows(StraightRun(v, 3.2, 20), ratler, o);
    const PlannedWindow& w = plan[10];
    EXPECT_NEAR(w.speed_mps, v, 1e-9);
    const double d_stop = ratler.stop_time_s * v + v * v / (2 * ratler.sliding_friction * g);
    EXPECT_NEAR(w.d_stop_m, d_stop, 1e-12);
    EXPECT_NEAR(w.y_need_m, ratler.FrontOfWheelsY() + d_stop + v * o.stereo_delay_s, 1e-12);
    // Steady state: the ground of one cycle plus the overlap, beyond the horizon.
    EXPECT_NEAR(w.y_max_m, w.y_need_m + o.horizon_m + v * 3.2, 1e-9);
    EXPECT_NEAR(w.y_min_m, w.y_need_m + o.horizon_m - o.overlap_m, 1e-9);
    y_need.push_back(w.y_need_m);
    y_max.push_back(w.y_max_m);
  }
  // From 0.15 to 0.7 m/s the near edge moves out by the growth of d_stop plus the delay's share.
  const double d015 = 2 * 0.15 + 0.15 * 0.15 / (2 * 0.25 * g), d07 = 2 * 0.7 + 0.7 * 0.7 / (2 * 0.25 * g);
  EXPECT_NEAR(y_need[2] - y_need[0], d07 - d015 + (0.7 - 0.15) * o.stereo_delay_s, 1e-9);
  EXPECT_LT(y_max[0], y_max[1]);
  EXPECT_LT(y_max[1], y_max[2]);
  // The paper's 0.7 m/s: 1.5 m of stopping distance (sec. 3.1).
  EXPECT_NEAR(d07, 1.5, 0.01);
}

TEST(PlanWindows, FirstRequestIsWiderThanTheSteadyOnes) {
  const auto plan = PlanWindows(StraightRun(0.15, 3.2, 5), calib::VehicleSpec(), WindowPlannerOptions());
  EXPECT_TRUE(std::isnan(plan[0].covered_to_m));
  const double first = plan[0].y_max_m - plan[0].y_min_m, steady = plan[3].y_max_m - plan[3].y_min_m;
  EXPECT_NEAR(steady, 0.15 * 3.2 + WindowPlannerOptions().overlap_m, 1e-9);
  EXPECT_GT(first, steady);
}

// A rover's planner knows only the past: the requests of pairs 0..k are the same whether or
// not the pairs after k are in the input (an uneven run: speeds, intervals and heading vary).
TEST(PlanWindows, IsCausalThePlanOfAPairIgnoresLaterPairs) {
  std::vector<FramePose> poses;
  double x = 0, y = 0, heading = 0, t = 0;
  for (int k = 0; k < 12; ++k) {
    FramePose p;
    p.stem = std::to_string(k);
    p.t_s = t;
    p.x_m = x;
    p.y_m = y;
    p.heading_rad = heading;
    poses.push_back(p);
    const double dt = 2.5 + 0.4 * (k % 3), v = 0.1 + 0.05 * (k % 4);
    heading += 0.05 * ((k % 5) - 2);
    x += v * dt * std::sin(heading);
    y += v * dt * std::cos(heading);
    t += dt;
  }
  WindowPlannerOptions o;
  o.initial_speed_mps = 0.15;
  o.initial_cycle_s = 3.2;
  const auto full = PlanWindows(poses, calib::VehicleSpec(), o);
  for (std::size_t k = 0; k < poses.size(); ++k) {
    const auto part = PlanWindows(std::vector<FramePose>(poses.begin(), poses.begin() + k + 1), calib::VehicleSpec(), o);
    ASSERT_EQ(part.size(), k + 1);
    for (std::size_t i = 0; i <= k; ++i) {
      EXPECT_EQ(part[i].speed_mps, full[i].speed_mps) << k << " " << i;
      EXPECT_EQ(part[i].cycle_s, full[i].cycle_s) << k << " " << i;
      EXPECT_EQ(part[i].y_min_m, full[i].y_min_m) << k << " " << i;
      EXPECT_EQ(part[i].y_max_m, full[i].y_max_m) << k << " " << i;
    }
  }
  // The speed is the last leg's (poses k-1 and k), the first pair's the assumed one.
  EXPECT_EQ(full[0].speed_mps, 0.15);
  EXPECT_EQ(full[0].cycle_s, 3.2);
  const double leg = std::hypot(poses[5].x_m - poses[4].x_m, poses[5].y_m - poses[4].y_m);
  EXPECT_NEAR(full[5].speed_mps, leg / (poses[5].t_s - poses[4].t_s), 1e-12);
  EXPECT_NEAR(full[5].cycle_s, poses[5].t_s - poses[4].t_s, 1e-12);
}

// The closed loop: with the map so far, a request starts from the far edge of what the map
// holds in the corridor ahead. A map mapped 0-20 m north over the corridor but for a gap at
// 8-9 m (a blank pair) makes the request reach back to the gap; without the gap the request
// is the least one (its far end less the overlap). The corridor's width is the vehicle's: a
// gap off to the side, beyond it, changes nothing.
TEST(PlanWindows, WithAMapTheRequestReachesBackToItsFirstGap) {
  MapLayers map;  // the elevation layer is all the planner reads
  map.x_west_m = -5;
  map.y_north_m = 20;
  map.cell_m = 0.25;
  map.elevation_m = cv::Mat(80, 40, CV_32FC1, cv::Scalar(0));  // x -5..5, y 0..20
  const calib::VehicleSpec vehicle;
  WindowPlannerOptions o;
  o.horizon_m = 10;
  const auto poses = StraightRun(0.15, 3.2, 3);
  const auto full = PlanWindows(poses, vehicle, o, &map);
  EXPECT_NEAR(full[2].y_min_m, full[2].y_max_m - o.overlap_m, 1e-9);
  cv::Mat side = map.elevation_m.clone();
  side(cv::Rect(0, 44, 10, 4)).setTo(std::numeric_limits<float>::quiet_NaN());  // x -5..-2.5, y 8-9
  std::swap(side, map.elevation_m);
  const auto off_corridor = PlanWindows(poses, vehicle, o, &map);
  EXPECT_EQ(off_corridor[2].y_min_m, full[2].y_min_m);
  map.elevation_m = side.clone();
  map.elevation_m.rowRange(44, 48).setTo(std::numeric_limits<float>::quiet_NaN());  // y 8-9, all across
  const auto gap = PlanWindows(poses, vehicle, o, &map);
  for (const PlannedWindow& w : gap) {
    SCOPED_TRACE(w.stem);
    const double gap_at = 8.0 - poses[std::stoi(w.stem)].y_m;  // in this pair's vehicle frame
    EXPECT_NEAR(w.covered_to_m, gap_at, 0.5 * map.cell_m + 1e-9);
    EXPECT_NEAR(w.y_min_m, std::max(w.y_need_m, w.covered_to_m - o.overlap_m), 1e-9);
    EXPECT_LT(w.y_min_m, gap_at);
    EXPECT_GT(w.y_max_m, gap_at + 1.0);
  }
}

// Causal with a map too: a map that also holds later pairs' ground (cells whose last pair came
// at or after a pair's time) is read, for that pair, without those cells.
TEST(PlanWindows, AMapWithLaterPairsIsReadOnlyWithWhatCameBeforeEachPair) {
  MapLayers map;
  map.x_west_m = -5;
  map.y_north_m = 20;
  map.cell_m = 0.25;
  map.elevation_m = cv::Mat(80, 40, CV_32FC1, cv::Scalar(0));  // x -5..5, y 0..20: all mapped
  const calib::VehicleSpec vehicle;
  WindowPlannerOptions o;
  o.horizon_m = 10;
  const auto poses = StraightRun(0.15, 3.2, 3);  // t 0, 3.2, 6.4 s
  const auto untimed = PlanWindows(poses, vehicle, o, &map);
  // The ground beyond y = 8 m was first added by a pair at 5 s: pair 2 (6.4 s) has it, pairs 0
  // and 1 do not (their plans are those of a map without it).
  map.last_t_exact_s = cv::Mat(map.elevation_m.size(), CV_64FC1, cv::Scalar(-1.0));  // before the run
  map.last_t_exact_s.rowRange(0, 48).setTo(5.0);                                     // rows 0-47: y 8..20
  const auto timed = PlanWindows(poses, vehicle, o, &map);
  MapLayers before = map;
  before.elevation_m = map.elevation_m.clone();
  before.elevation_m.rowRange(0, 48).setTo(std::numeric_limits<float>::quiet_NaN());
  before.last_t_exact_s = cv::Mat();
  const auto cut = PlanWindows(poses, vehicle, o, &before);
  for (int k : {0, 1}) {
    EXPECT_EQ(timed[k].covered_to_m, cut[k].covered_to_m) << k;
    EXPECT_EQ(timed[k].y_min_m, cut[k].y_min_m) << k;
    EXPECT_LT(timed[k].covered_to_m, untimed[k].covered_to_m) << k;  // the later ground was counted before
  }
  EXPECT_EQ(timed[2].y_min_m, untimed[2].y_min_m);
}

TEST(PlanWindows, NonFinitePoseNamesTheStem) {
  auto poses = StraightRun(0.15, 3.2, 4);
  poses[2].x_m = std::nan("");
  try {
    PlanWindows(poses, calib::VehicleSpec(), WindowPlannerOptions());
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("stem 2"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace lunarnav::mapping
