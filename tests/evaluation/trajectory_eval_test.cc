#include "evaluation/trajectory_eval.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>

#include "io/json_io.h"
#include "positioning/trajectory_io.h"
#include "util/errors.h"
#include "util/testing.h"

namespace lunarnav::evaluation {
namespace {

// A rover driving a 20 m straight line north, then a quarter circle of radius 10 m to the
// east, at 0.5 m/s, sampled at 10 Hz; z follows a gentle slope.
std::vector<positioning::TrajectorySample> Drive() {
  std::vector<positioning::TrajectorySample> out;
  const double v = 0.5, dt = 0.1;
  const double straight_s = 20 / v, arc_s = (M_PI / 2 * 10) / v;
  for (double t = 0; t <= straight_s + arc_s + 1e-9; t += dt) {
    positioning::TrajectorySample p;
    p.t_s = t;
    if (t <= straight_s) {
      p.x_m = 0;
      p.y_m = v * t;
      p.heading_rad = 0;
    } else {
      const double a = v * (t - straight_s) / 10;  // angle travelled on the arc
      p.x_m = 10 - 10 * std::cos(a);
      p.y_m = 20 + 10 * std::sin(a);
      p.heading_rad = a;
    }
    p.z_m = 0.01 * p.y_m;
    p.speed_mps = v;
    out.push_back(p);
  }
  return out;
}

std::vector<StampedPose> Poses(const std::vector<positioning::TrajectorySample>& samples,
                               const util::ScopedTempDir& tmp) {
  positioning::WriteTrajectoryTum(tmp.path() / "t.tum", samples);
  return ReadPoses(tmp.path() / "t.tum");
}

// The truth moved as a whole: turned 0.2 rad about the vertical through the origin, then 1 m
// east and 2 m north. Its absolute error without alignment is each pose's displacement,
// computed here by hand; aligning the first poses (origin) or all poses (rigid) removes it;
// the relative errors never see it.
TEST(EvaluateTrajectory, ARigidlyMovedCopyHasItsDisplacementAsErrorUntilAligned) {
  util::ScopedTempDir tmp;
  const auto truth = Poses(Drive(), tmp);
  const Eigen::Isometry3d move = Eigen::Translation3d(1, 2, 0) * Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ());
  auto moved = truth;
  double sum_sq = 0, largest = 0;
  for (std::size_t i = 0; i < moved.size(); ++i) {
    moved[i].world_from_body = move * truth[i].world_from_body;
    const double d = (moved[i].world_from_body.translation() - truth[i].world_from_body.translation()).norm();
    sum_sq += d * d;
    largest = std::max(largest, d);
  }
  TrajectoryEvalOptions options;
  options.alignment = Alignment::kNone;
  TrajectoryErrors e = EvaluateTrajectory(moved, truth, options);
  EXPECT_EQ(e.poses_matched, static_cast<long>(truth.size()));
  EXPECT_NEAR(e.ape_translation_m.rmse, std::sqrt(sum_sq / truth.size()), 1e-6);
  EXPECT_NEAR(e.ape_translation_m.max, largest, 1e-6);
  EXPECT_NEAR(e.ape_rotation_deg.max, 0.2 * 180 / M_PI, 1e-4);  // every heading off by 0.2 rad
  EXPECT_NEAR(e.rpe_translation_m.max, 0, 1e-6);
  EXPECT_NEAR(e.rpe_rotation_deg.max, 0, 1e-4);
  EXPECT_NEAR(e.drift_translation_pct, 0, 1e-6);
  EXPECT_NEAR(e.path_length_m, 20 + M_PI / 2 * 10, 0.01);  // the straight line and the quarter circle
  for (Alignment a : {Alignment::kOrigin, Alignment::kRigid}) {
    options.alignment = a;
    e = EvaluateTrajectory(moved, truth, options);
    EXPECT_NEAR(e.ape_translation_m.max, 0, 1e-6) << ToString(a);
    EXPECT_NEAR(e.ape_rotation_deg.max, 0, 1e-4) << ToString(a);
  }
  // Translating the first position onto the truth's leaves the turn: each pose is off by
  // |R p - p| for its position p relative to the start, R the 0.2 rad turn.
  options.alignment = Alignment::kStart;
  e = EvaluateTrajectory(moved, truth, options);
  const Eigen::Vector3d start = truth.front().world_from_body.translation();
  double start_largest = 0;
  for (const StampedPose& p : truth) {
    const Eigen::Vector3d rel = p.world_from_body.translation() - start;
    start_largest = std::max(start_largest, (move.linear() * rel - rel).norm());
  }
  EXPECT_NEAR(e.ape_translation_m.max, start_largest, 1e-6);
}

TEST(EvaluateTrajectory, AShiftedCopyHasTheShiftAsAbsoluteErrorAndNoRelativeError) {
  util::ScopedTempDir tmp;
  const auto truth = Poses(Drive(), tmp);
  auto shifted = truth;
  const Eigen::Vector3d shift(0.3, -0.4, 0.0);  // 0.5 m
  for (StampedPose& p : shifted) p.world_from_body.translation() += shift;
  TrajectoryEvalOptions options;
  options.alignment = Alignment::kNone;
  TrajectoryErrors e = EvaluateTrajectory(shifted, truth, options);
  EXPECT_NEAR(e.ape_translation_m.rmse, 0.5, 1e-6);
  EXPECT_NEAR(e.ape_translation_m.min, 0.5, 1e-6);
  EXPECT_NEAR(e.ape_translation_m.std, 0.0, 1e-6);
  EXPECT_NEAR(e.rpe_translation_m.max, 0.0, 1e-6);
  options.alignment = Alignment::kStart;
  e = EvaluateTrajectory(shifted, truth, options);
  EXPECT_NEAR(e.ape_translation_m.max, 0.0, 1e-6);
}

TEST(EvaluateTrajectory, AFivePercentLongOdometryDriftsFivePercent) {
  util::ScopedTempDir tmp;
  auto samples = Drive();
  samples.resize(401);  // the 20 m straight line only
  const auto truth = Poses(samples, tmp);
  auto scaled = truth;
  for (StampedPose& p : scaled) p.world_from_body.translation() *= 1.05;
  const TrajectoryErrors e = EvaluateTrajectory(scaled, truth, {});
  // KITTI divides by the nominal segment length; the true segments are at most one sample
  // spacing (5 cm) longer, so the drift is 5 % to within 5 % x 0.05 / 5.
  EXPECT_NEAR(e.drift_translation_pct, 5.0, 0.05);
  EXPECT_NEAR(e.drift_rotation_deg_per_m, 0.0, 1e-6);
  EXPECT_GT(e.drift_segments, 0);
  // 5 % of the end point's distance from the start (20 m north, 0.2 m up).
  EXPECT_NEAR(e.ape_translation_m.max, 0.05 * std::hypot(20.0, 0.2), 1e-6);
  // RPE pairs are 1 m apart on the true path: each is 5 cm too long.
  EXPECT_NEAR(e.rpe_translation_m.mean, 0.05, 1e-3);
}

TEST(EvaluateTrajectory, RigidAlignmentRemovesAConstantHeadingOffset) {
  util::ScopedTempDir tmp;
  const auto truth = Poses(Drive(), tmp);
  auto rotated = truth;
  const Eigen::Isometry3d yaw(Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitZ()));
  for (StampedPose& p : rotated) p.world_from_body = yaw * p.world_from_body;
  TrajectoryEvalOptions options;
  options.alignment = Alignment::kStart;
  EXPECT_GT(EvaluateTrajectory(rotated, truth, options).ape_translation_m.max, 1.0);
  options.alignment = Alignment::kRigid;
  const TrajectoryErrors e = EvaluateTrajectory(rotated, truth, options);
  EXPECT_NEAR(e.ape_translation_m.max, 0.0, 1e-6);
  EXPECT_NEAR(e.ape_rotation_deg.max, 0.0, 1e-4);
}

TEST(EvaluateTrajectory, TwoDimensionalAlignmentComparesAFlatTrajectoryHorizontally) {
  util::ScopedTempDir tmp;
  const auto truth = Poses(Drive(), tmp);  // climbs 0.01 m per m north
  // A flat (z = 0) copy turned by 30 deg about the vertical and moved 5 m east.
  auto flat = truth;
  const Eigen::Isometry3d move = Eigen::Translation3d(5, 0, 0) * Eigen::AngleAxisd(0.5236, Eigen::Vector3d::UnitZ());
  for (StampedPose& p : flat) {
    p.world_from_body.translation().z() = 0;
    p.world_from_body = move * p.world_from_body;
  }
  TrajectoryEvalOptions options;
  options.alignment = Alignment::kRigid2d;
  EXPECT_NEAR(EvaluateTrajectory(flat, truth, options).ape_translation_m.max, 0.0, 1e-6);
  // A 3-D rigid alignment has to tilt the flat copy onto the climbing plane, which cannot
  // stretch it by the climb's sqrt(1 + 0.01^2): it leaves errors the 2-D one does not.
  options.alignment = Alignment::kRigid;
  EXPECT_GT(EvaluateTrajectory(flat, truth, options).ape_translation_m.max, 1e-4);
  // Horizontal errors are kept: 0.3 m east of the truth everywhere after the first half.
  auto off = truth;
  for (std::size_t i = off.size() / 2; i < off.size(); ++i) off[i].world_from_body.translation().x() += 0.3;
  options.alignment = Alignment::kRigid2d;
  EXPECT_GT(EvaluateTrajectory(off, truth, options).ape_translation_m.mean, 0.05);
  EXPECT_EQ(AlignmentFromString("rigid-2d"), Alignment::kRigid2d);
}

// A GPS log as truth: positions only (t,east,north). The estimate, the drive turned 0.5 rad
// and 5 % long, is aligned in 2-D; its relative errors compare displacements (each 1 m pair 5 cm
// too long), its drift is 5 %, and no rotation error is claimed.
TEST(EvaluateTrajectory, APositionTrackAsTruthScoresPositionsAndDisplacementsOnly) {
  util::ScopedTempDir tmp;
  auto samples = Drive();
  samples.resize(401);  // the 20 m straight line
  {
    std::ofstream track(tmp.path() / "gps.csv");
    track << "# a GPS track, local ENU\r\nt,east,north,sats\r\n";
    for (const auto& p : samples) track << p.t_s << "," << p.x_m << "," << p.y_m << ",9\r\n";
  }
  const std::vector<StampedPose> truth = ReadPoses(tmp.path() / "gps.csv");
  ASSERT_EQ(truth.size(), samples.size());
  EXPECT_FALSE(truth[0].has_attitude);
  EXPECT_DOUBLE_EQ(truth[200].world_from_body.translation().y(), samples[200].y_m);
  auto estimate = Poses(samples, tmp);
  const Eigen::Isometry3d turn(Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()));
  for (StampedPose& p : estimate) {
    p.world_from_body.translation() *= 1.05;
    p.world_from_body = turn * p.world_from_body;
  }
  TrajectoryEvalOptions options;
  options.alignment = Alignment::kRigid2d;
  const TrajectoryErrors e = EvaluateTrajectory(estimate, truth, options);
  EXPECT_FALSE(e.truth_has_attitude);
  EXPECT_NEAR(e.rpe_translation_m.mean, 0.05, 1e-3);
  EXPECT_NEAR(e.drift_translation_pct, 5.0, 0.05);
  // The best 2-D fit of a 5 % long line to the line: centred, the ends 0.5 m off.
  EXPECT_NEAR(e.ape_translation_m.max, 0.5, 0.01);
  EXPECT_EQ(e.ape_rotation_deg.count, 0);
  EXPECT_TRUE(std::isnan(e.rpe_rotation_deg.rmse));
  EXPECT_TRUE(std::isnan(e.drift_rotation_deg_per_m));
  // The similarity alignment takes the 5 % out too: the path's shape is exact, the scale
  // 1 / 1.05, and the mean error at given instants (the ratio's) is as exact.
  options.alignment = Alignment::kSimilarity2d;
  const TrajectoryErrors similar = EvaluateTrajectory(estimate, truth, options);
  EXPECT_NEAR(similar.scale, 1 / 1.05, 1e-9);
  EXPECT_NEAR(similar.ape_translation_m.max, 0.0, 1e-6);
  EXPECT_NEAR(similar.rpe_translation_m.mean, 0.0, 1e-6);
  long count = 0;
  EXPECT_NEAR(MeanPositionErrorAt(estimate, similar, truth, options, {3.0, 7.5}, &count), 0.0, 1e-6);
  EXPECT_EQ(count, 2);
  EXPECT_DOUBLE_EQ(e.scale, 1.0);
  EXPECT_EQ(AlignmentFromString("similarity-2d"), Alignment::kSimilarity2d);
  // A header that is neither a trajectory nor a track, and a bad cell, are bad input.
  std::ofstream(tmp.path() / "bad.csv") << "time,lat,lon\n1,2,3\n";
  EXPECT_THROW(ReadPoses(tmp.path() / "bad.csv"), InputError);
  std::ofstream(tmp.path() / "cell.csv") << "t,east,north\n0,0,0\n1,x,2\n";
  EXPECT_THROW(ReadPoses(tmp.path() / "cell.csv"), InputError);
}

// A relative-error step too small to move along the path (1e-17 m) still advances pose by
// pose: the evaluation ends, with one pair per consecutive poses.
TEST(EvaluateTrajectory, ATinyRpeStepEndsWithOnePairPerConsecutivePoses) {
  util::ScopedTempDir tmp;
  auto samples = Drive();
  samples.resize(101);
  const auto truth = Poses(samples, tmp);
  TrajectoryEvalOptions options;
  options.rpe_delta_m = 1e-17;
  options.drift_segments_m = {1e-17};
  const TrajectoryErrors e = EvaluateTrajectory(truth, truth, options);
  EXPECT_EQ(e.rpe_translation_m.count, 100);
  EXPECT_NEAR(e.rpe_translation_m.max, 0.0, 1e-9);
}

// Two estimates written at different rates are compared at the same instants: a 10 Hz
// estimate whose error is 0.1 m at every whole second and up to 0.2 m between, against a
// 1 Hz reference of the same poses at the whole seconds. Averaged over their own instants the
// 10 Hz estimate looked 1.6 x worse; at the reference's instants it is the same trajectory
// (ratio 1). A 10 Hz estimate 0.2 m off everywhere is 2 x the reference.
TEST(EvaluateTrajectoryCommand, TheRatioComparesEstimatesOfDifferentRatesAtTheReferencesInstants) {
  util::ScopedTempDir tmp;
  auto truth = Drive();
  truth.resize(401);  // the 20 m straight line, 0-40 s
  auto wobbly = truth, coarse = truth, offset = truth;
  coarse.clear();
  for (std::size_t i = 0; i < wobbly.size(); ++i) {
    wobbly[i].x_m += 0.1 + 0.1 * std::abs(std::sin(M_PI * wobbly[i].t_s));
    offset[i].x_m += 0.2;
    if (i % 10 == 0) coarse.push_back(wobbly[i]);
  }
  positioning::WriteTrajectoryTum(tmp.path() / "truth.tum", truth);
  positioning::WriteTrajectoryTum(tmp.path() / "wobbly.tum", wobbly);
  positioning::WriteTrajectoryTum(tmp.path() / "coarse.tum", coarse);
  positioning::WriteTrajectoryTum(tmp.path() / "offset.tum", offset);
  TrajectoryCommand command;
  command.estimates = {"wobbly=" + (tmp.path() / "wobbly.tum").string(),
                       "coarse=" + (tmp.path() / "coarse.tum").string(),
                       "offset=" + (tmp.path() / "offset.tum").string()};
  command.truth = tmp.path() / "truth.tum";
  command.output_dir = tmp.path() / "ev";
  command.alignment = "none";
  command.reference = "coarse";
  RunTrajectoryCommand(command, nlohmann::json::object());
  const nlohmann::json e = io::ReadJson(tmp.path() / "ev" / "summary.json")["estimates"];
  EXPECT_NEAR(e["coarse"]["ape_mean_m"].get<double>(), 0.1, 1e-9);
  EXPECT_NEAR(e["wobbly"]["ape_mean_m"].get<double>(), 0.1 + 0.2 / M_PI, 2e-3);  // its own instants
  EXPECT_NEAR(e["wobbly"]["ape_mean_ratio"].get<double>(), 1.0, 1e-9);
  EXPECT_EQ(e["wobbly"]["ratio_instants"].get<long>(), 41);
  EXPECT_NEAR(e["offset"]["ape_mean_ratio"].get<double>(), 2.0, 1e-9);
  EXPECT_NEAR(e["coarse"]["ape_mean_ratio"].get<double>(), 1.0, 1e-12);
}

TEST(ReadPoses, CsvAndTumGiveTheSamePoses) {
  util::ScopedTempDir tmp;
  auto samples = Drive();
  for (auto& s : samples) {
    s.pitch_rad = 0.05;
    s.roll_rad = -0.02;
  }
  positioning::WriteTrajectoryCsv(tmp.path() / "t.csv", samples);
  positioning::WriteTrajectoryTum(tmp.path() / "t.tum", samples);
  const auto a = ReadPoses(tmp.path() / "t.csv"), b = ReadPoses(tmp.path() / "t.tum");
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); i += 37) {
    EXPECT_TRUE(a[i].world_from_body.isApprox(b[i].world_from_body, 1e-6)) << i;
  }
  std::ofstream(tmp.path() / "bad.tum") << "0 1 2 3 0 0 0 1\n1 1 2 3 0 0 0.5 0.5\n";
  EXPECT_THROW(ReadPoses(tmp.path() / "bad.tum"), InputError);
  const auto far = std::vector<StampedPose>{{100, {}}, {101, {}}};
  EXPECT_THROW(EvaluateTrajectory(far, a, {}), InputError);  // no overlap in time
}

}  // namespace
}  // namespace lunarnav::evaluation
