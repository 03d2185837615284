#include "evaluation/trials_eval.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "positioning/attitude.h"
#include "util/errors.h"
#include "util/testing.h"

namespace lunarnav::evaluation {
namespace {

constexpr double kDeg = M_PI / 180;

StampedPose Pose(double t, double x, double y, double heading_deg) {
  StampedPose p;
  p.t_s = t;
  p.world_from_body.linear() = positioning::EnuFromBody(heading_deg * kDeg, 0, 0).toRotationMatrix();
  p.world_from_body.translation() = Eigen::Vector3d(x, y, 0);
  return p;
}

// A rover that drives 10 m north-east (heading 45) in 10 s, rests, then turns in place by
// +90 deg in 10 s; its odometry reads 10 % long and its heading turns 95 deg for 90.
std::vector<StampedPose> Estimate() {
  std::vector<StampedPose> poses;
  const double s = 1.1 * 10 / std::sqrt(2.0);
  for (int k = 0; k <= 10; ++k) poses.push_back(Pose(k, s * k / 10, s * k / 10, 45));
  for (int k = 1; k <= 10; ++k) poses.push_back(Pose(10 + k, s, s, 45 + 95.0 * k / 10));
  return poses;
}

std::vector<Trial> Trials() {
  const double s = 10 / std::sqrt(2.0);
  Trial straight{1, "straight 10 m", {0, 0, 0, 45.0}, {10, s, s, 45.0}};
  Trial turn{2, "turn in place +90", {10, s, s, 45.0}, {20, s, s, 135.0}};
  return {straight, turn};
}

TEST(EvaluateTrials, MeasuresDistanceAndOrientationErrors) {
  const auto results = EvaluateTrials(Estimate(), Trials(), {});
  ASSERT_EQ(results.size(), 2u);
  EXPECT_NEAR(results[0].true_distance_m, 10, 1e-9);
  EXPECT_NEAR(results[0].estimated_distance_m, 11, 1e-9);
  EXPECT_NEAR(results[0].distance_error_pct, 10, 1e-9);
  EXPECT_NEAR(results[0].position_error_m, 1, 1e-9);
  EXPECT_NEAR(results[0].heading_error_deg, 0, 1e-9);
  // The turn in place moves nowhere: no distance percentage, a 5 deg heading error.
  EXPECT_TRUE(std::isnan(results[1].distance_error_pct));
  EXPECT_NEAR(results[1].position_error_m, 0, 1e-9);
  EXPECT_NEAR(results[1].true_turn_deg, 90, 1e-9);
  EXPECT_NEAR(results[1].estimated_turn_deg, 95, 1e-6);
  EXPECT_NEAR(results[1].heading_error_deg, 5, 1e-6);
  EXPECT_NEAR(results[1].orientation_error_pct, 100 * 5.0 / 360, 1e-6);

  const TrialSetSummary s = SummarizeTrials("A", results);
  EXPECT_EQ(s.trials, 2);
  EXPECT_EQ(s.distance_trials, 1);
  EXPECT_EQ(s.orientation_trials, 2);
  EXPECT_NEAR(s.distance_error_pct.mean, 10, 1e-9);
  EXPECT_NEAR(s.orientation_error_pct.mean, 100 * 2.5 / 360, 1e-6);
  EXPECT_NEAR(s.orientation_error_pct.std, 100 * 2.5 / 360, 1e-6);
}

TEST(EvaluateTrials, HeadingChangesWrapAcrossNorth) {
  // Turning from 350 to 10 deg is +20, estimated as +20: no error.
  std::vector<StampedPose> est = {Pose(0, 0, 0, 350), Pose(1, 0, 0, 10)};
  const Trial turn{1, "", {0, 0, 0, 350.0}, {1, 0, 0, 10.0}};
  const auto r = EvaluateTrials(est, {turn}, {});
  EXPECT_NEAR(r[0].true_turn_deg, 20, 1e-9);
  EXPECT_NEAR(r[0].estimated_turn_deg, 20, 1e-6);
  EXPECT_NEAR(r[0].heading_error_deg, 0, 1e-6);
}

TEST(EvaluateTrials, TrialsWithoutHeadingsHaveNoOrientationError) {
  auto trials = Trials();
  trials[0].end.heading_deg.reset();
  const auto r = EvaluateTrials(Estimate(), trials, {});
  EXPECT_TRUE(std::isnan(r[0].orientation_error_pct));
  EXPECT_EQ(SummarizeTrials("C", r).orientation_trials, 1);
  const Table table = TrialsTable({SummarizeTrials("C", r)});
  EXPECT_TRUE(table.rows[0][1].IsNumber());
}

TEST(EvaluateTrials, ATrialOutsideTheTrajectoryIsBadInput) {
  auto trials = Trials();
  trials[1].end.t_s = 25;
  EXPECT_THROW(EvaluateTrials(Estimate(), trials, {}), InputError);
}

TEST(ReadTrials, ReadsTheFormatAndRejectsBadFiles) {
  util::ScopedTempDir tmp;
  const auto path = tmp.path() / "trials.json";
  std::ofstream(path) << R"({"format": "lunarnav.trials/1", "trials": [
      {"id": 7, "description": "arc", "start": {"t_s": 1, "x_m": 0, "y_m": 0, "heading_deg": 10},
       "end": {"t_s": 9, "x_m": 3.5, "y_m": 4, "heading_deg": null}}]})";
  const auto trials = ReadTrials(path);
  ASSERT_EQ(trials.size(), 1u);
  EXPECT_EQ(trials[0].id, 7);
  EXPECT_EQ(trials[0].description, "arc");
  EXPECT_DOUBLE_EQ(trials[0].end.x_m, 3.5);
  EXPECT_EQ(trials[0].start.heading_deg, 10.0);
  EXPECT_FALSE(trials[0].end.heading_deg.has_value());

  for (const char* bad : {R"({"format": "other/1", "trials": []})",
                          R"({"format": "lunarnav.trials/1", "trials": []})",
                          R"({"format": "lunarnav.trials/1", "trials": [{"start": {"t_s": 0, "x_m": 0, "y_m": 0}}]})",
                          R"({"format": "lunarnav.trials/1", "trials": [{"start": {"t_s": 0, "x_m": 0, "y_m": 0},
                              "end": {"t_s": 1, "x_m": "3", "y_m": 0}}]})",
                          R"({"format": "lunarnav.trials/1", "trials": [{"start": {"t_s": 2, "x_m": 0, "y_m": 0},
                              "end": {"t_s": 1, "x_m": 3, "y_m": 0}}]})"}) {
    std::ofstream(path) << bad;
    EXPECT_THROW(ReadTrials(path), InputError) << bad;
  }
}

TEST(HeadingDeg, IsClockwiseFromNorth) {
  for (double h : {0.0, 45.0, 90.0, 181.0, 359.0}) {
    EXPECT_NEAR(HeadingDeg(Pose(0, 0, 0, h).world_from_body), h, 1e-9);
  }
}

}  // namespace
}  // namespace lunarnav::evaluation
