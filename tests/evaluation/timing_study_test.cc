#include "evaluation/timing_study.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "calib/rectified_rig.h"
#include "sim/layered_scene.h"
#include "util/errors.h"

namespace lunarnav::evaluation {
namespace {

// A quarter-size version of the paper's rig (160 x 120, f = 185 px, B = 0.9 m, 1.5 m up,
// 25 deg down), its rectified frame rolled and yawed and its principal points 3 px apart.
calib::StereoRig QuarterRig() {
  return calib::testing::IdealRectifiedRig(160, 120, 185, 0.9, calib::testing::RollYaw(1.0, -2.0), -3.0);
}

TEST(NormaliseToLargest, DividesByTheLargestFiniteValue) {
  const std::vector<double> n = NormaliseToLargest({2, 4, NAN, 1});
  ASSERT_EQ(n.size(), 4u);
  EXPECT_DOUBLE_EQ(n[0], 0.5);
  EXPECT_DOUBLE_EQ(n[1], 1.0);
  EXPECT_TRUE(std::isnan(n[2]));
  EXPECT_DOUBLE_EQ(n[3], 0.25);
  for (double v : NormaliseToLargest({NAN, NAN})) EXPECT_TRUE(std::isnan(v));
  for (double v : NormaliseToLargest({0, 0})) EXPECT_TRUE(std::isnan(v));  // no scale, not a silent 0
  EXPECT_TRUE(NormaliseToLargest({}).empty());
}

TEST(Median, OddEvenAndEmpty) {
  EXPECT_DOUBLE_EQ(Median({3, 1, 2}), 2);
  EXPECT_DOUBLE_EQ(Median({4, 1, 3, 2}), 2.5);
  EXPECT_DOUBLE_EQ(Median({7}), 7);
  EXPECT_TRUE(std::isnan(Median({})));
}

TEST(PlanTimingStudy, WindowsAreWindowSelectionsAndTheirWorkGrowsWithDeltaY) {
  const calib::StereoRig rig = QuarterRig();
  TimingStudyOptions options;
  options.delta_y_m = {0.5, 1, 2, 4, 8};
  options.matcher.max_disparity_px = 99;  // the whole-image search: 0..99
  const TimingStudy study = PlanTimingStudy(rig, options);
  ASSERT_EQ(study.points.size(), 5u);
  EXPECT_EQ(study.height_px, 120);
  double previous_work = 0;
  const calib::ImageWindow* previous = nullptr;
  for (const TimingPoint& p : study.points) {
    const calib::RegionOfInterest region{5.0, 5.0 + *p.delta_y_m, -0.5, 1.0};
    const calib::ImageWindow w = calib::SelectWindow(rig, region, calib::ReferenceImage::kRight);
    EXPECT_EQ(p.window.min_row, w.min_row);
    EXPECT_EQ(p.window.max_row, w.max_row);
    EXPECT_EQ(p.window.min_disparity_px, w.min_disparity_px);
    EXPECT_EQ(p.window.max_disparity_px, w.max_disparity_px);
    EXPECT_DOUBLE_EQ(p.work_share, static_cast<double>(w.Rows()) * w.Disparities() / (120.0 * 100.0));
    // A wider interval contains the narrower one: its band and range contain the other's.
    EXPECT_GE(p.work_share, previous_work);
    if (previous != nullptr) {
      EXPECT_LE(p.window.min_row, previous->min_row);
      EXPECT_GE(p.window.max_row, previous->max_row);
      EXPECT_LE(p.window.min_disparity_px, previous->min_disparity_px);
      EXPECT_GE(p.window.max_disparity_px, previous->max_disparity_px);
    }
    previous_work = p.work_share;
    previous = &p.window;
  }
  // Far intervals reach smaller disparities: 8 m more reaches well below 1 m more.
  EXPECT_LT(study.points.back().window.min_disparity_px, study.points[1].window.min_disparity_px);
  EXPECT_LT(study.points.back().work_share, 1.0);
  EXPECT_EQ(study.full.window.Rows(), 120);
  EXPECT_EQ(study.full.window.Disparities(), 100);
  EXPECT_DOUBLE_EQ(study.full.work_share, 1.0);

  TimingStudyOptions bad = options;
  bad.delta_y_m = {-1};
  EXPECT_THROW(PlanTimingStudy(rig, bad), std::invalid_argument);
  bad = options;
  bad.repeat = 0;
  EXPECT_THROW(PlanTimingStudy(rig, bad), std::invalid_argument);
  bad = options;
  bad.y_min_m = -50;  // behind the rover: not seen
  EXPECT_THROW(PlanTimingStudy(rig, bad), std::invalid_argument);
  calib::StereoRig raw = rig;
  raw.rectified.reset();
  EXPECT_THROW(PlanTimingStudy(raw, options), std::invalid_argument);
}

TEST(Quantile, InterpolatesBetweenTheSortedValues) {
  // Sorted: 1, 2, 4, 8. h = 3 p: p = 0.25 -> 0.75 of the way from 1 to 2; 0.75 -> h = 2.25,
  // a quarter of the way from 4 to 8.
  EXPECT_DOUBLE_EQ(Quantile({8, 1, 4, 2}, 0.25), 1.75);
  EXPECT_DOUBLE_EQ(Quantile({8, 1, 4, 2}, 0.75), 5.0);
  EXPECT_DOUBLE_EQ(Quantile({8, 1, 4, 2}, 0.5), Median({8, 1, 4, 2}));
  EXPECT_DOUBLE_EQ(Quantile({8, 1, 4, 2}, 1.0), 8.0);
  EXPECT_DOUBLE_EQ(Quantile({3}, 0.25), 3.0);
  EXPECT_TRUE(std::isnan(Quantile({}, 0.5)));
}

TEST(NormaliseTimingStudy, TimesOverTheLargestAndOverTheWholeImage) {
  TimingStudyOptions options;
  options.delta_y_m = {1, 2, 3};
  TimingStudy study = PlanTimingStudy(QuarterRig(), options);
  const double seconds[3] = {0.001, 0.004, 0.002};
  for (int i = 0; i < 3; ++i) study.points[i].seconds = seconds[i];
  study.full.seconds = 0.008;
  NormaliseTimingStudy(&study);
  EXPECT_DOUBLE_EQ(study.points[0].time_normalised, 0.25);
  EXPECT_DOUBLE_EQ(study.points[1].time_normalised, 1.0);  // the largest, not the last
  EXPECT_DOUBLE_EQ(study.points[2].time_normalised, 0.5);
  EXPECT_DOUBLE_EQ(study.points[0].time_share, 0.125);
  EXPECT_DOUBLE_EQ(study.full.time_normalised, 2.0);
  const double largest_work = study.points[2].work_share;  // the widest interval's
  EXPECT_DOUBLE_EQ(study.points[0].work_normalised, study.points[0].work_share / largest_work);
  EXPECT_DOUBLE_EQ(study.full.work_normalised, 1.0 / largest_work);

  // The table: one row per dY and the whole image, n/a (not 0) where there is no dY.
  const Table table = TimingTable(study);
  ASSERT_EQ(table.rows.size(), 4u);
  EXPECT_DOUBLE_EQ(table.rows[1][0].number(), 2.0);
  EXPECT_DOUBLE_EQ(table.rows[1][1].number(), 7.0);  // Y_max = Y_min + dY
  EXPECT_DOUBLE_EQ(table.rows[0][9].number(), 1.0);  // ms
  EXPECT_TRUE(table.rows[3][0].IsNotAvailable());
  EXPECT_DOUBLE_EQ(table.rows[3][4].number(), 120);
  EXPECT_FALSE(table.notes.empty());
  const std::string csv = TimingCurveCsv(study);
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 4);
  EXPECT_NE(csv.find("\n2,7,1,"), std::string::npos) << csv;
}

TEST(RunTimingStudy, TimesTheMatcherOnEveryWindow) {
  const calib::StereoRig rig = QuarterRig();
  sim::LayeredSceneOptions scene;
  scene.width = 160;
  scene.height = 120;
  sim::PlaneLayer plane;
  plane.d0_px = 30;
  scene.layers = {plane};
  const sim::RenderedPair pair = sim::RenderLayeredPair(scene);
  TimingStudyOptions options;
  options.delta_y_m = {0.5, 4};
  options.repeat = 5;  // the median of 5 interleaved rounds: a load spike spoils one round, not the result
  options.matcher.half_window_x_px = 5;
  options.matcher.half_window_y_px = 3;
  int calls = 0;
  const TimingStudy study = RunTimingStudy(rig, {{pair.left, pair.right}, {pair.left, pair.right}}, options,
                                           [&] { ++calls; });
  EXPECT_EQ(calls, 5 * 3);
  EXPECT_EQ(study.pairs, 2);
  for (const TimingPoint* p : {&study.points[0], &study.points[1], &study.full}) {
    ASSERT_EQ(p->repeat_seconds.size(), 5u);
    EXPECT_GT(p->seconds, 0);
    // The matcher evaluated exactly the window's rows (every column, step 1), on both pairs.
    EXPECT_EQ(p->evaluated_pixels, 2LL * 160 * p->window.Rows());
  }
  // Each window keeps the median of its five runs and their quartiles (with five runs, type 7
  // puts them on the 2nd and 4th smallest). (The normalised times and shares are checked on
  // hand-made times above, not recomputed here from the same formula.)
  for (const TimingPoint* p : {&study.points[0], &study.points[1], &study.full}) {
    std::vector<double> runs = p->repeat_seconds;
    std::sort(runs.begin(), runs.end());
    EXPECT_EQ(p->seconds, runs[2]);
    EXPECT_EQ(p->seconds_q1, runs[1]);
    EXPECT_EQ(p->seconds_q3, runs[3]);
  }
  // The narrowest window does a small part of the whole image's work, and takes less time
  // (a wide margin: timing on a loaded machine is noisy).
  ASSERT_LT(study.points[0].work_share, 0.25);
  EXPECT_LT(study.points[0].seconds, study.full.seconds);

  const cv::Mat small(60, 80, CV_8UC1, cv::Scalar(0));
  EXPECT_THROW(RunTimingStudy(rig, {{small, small}}, options), InputError);
  EXPECT_THROW(RunTimingStudy(rig, {}, options), InputError);
}

}  // namespace
}  // namespace lunarnav::evaluation
