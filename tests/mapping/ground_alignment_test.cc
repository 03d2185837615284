// Attitude from the ground: a pair placed with a wrong height, pitch and roll is brought back
// onto the ground the pairs before it mapped; too little ground in common leaves it alone.
#include "mapping/ground_alignment.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "sim/portable_random.h"

namespace lunarnav::mapping {
namespace {

constexpr double kDeg = M_PI / 180.0;

// Rolling ground with bumps, world frame.
double Ground(double x, double y) {
  return 0.05 * x - 0.03 * y + 0.2 * std::sin(0.4 * x) * std::cos(0.3 * y) + 0.05 * std::sin(3.1 * x + 1.7 * y);
}

FramePose TruePose(const std::string& stem, double y) {
  FramePose p;
  p.stem = stem;
  p.t_s = y;
  p.x_m = 0.3;
  p.y_m = y;
  p.z_m = Ground(0.3, y);
  p.heading_rad = 10 * kDeg;
  p.pitch_rad = -2 * kDeg;
  p.roll_rad = 1 * kDeg;
  return p;
}

// What a pair at `pose` sees: ground points 1.5-11 m ahead over +-4 m, in its vehicle frame,
// with 1 cm of noise.
std::vector<Eigen::Vector3f> View(const FramePose& pose, std::uint64_t seed, double near_m = 1.5, double far_m = 11) {
  sim::PortableRandom rng(seed, "view");
  const Eigen::Isometry3d vehicle_from_world = pose.WorldFromVehicle().inverse();
  const double h = pose.heading_rad;
  std::vector<Eigen::Vector3f> points;
  for (double ahead = near_m; ahead < far_m; ahead += 0.06) {
    for (double side = -4; side <= 4; side += 0.06) {
      const double x = pose.x_m + ahead * std::sin(h) + side * std::cos(h);
      const double y = pose.y_m + ahead * std::cos(h) - side * std::sin(h);
      const Eigen::Vector3d v = vehicle_from_world * Eigen::Vector3d(x, y, Ground(x, y) + 0.01 * rng.Normal());
      points.push_back(v.cast<float>());
    }
  }
  return points;
}

TEST(PoseFromTransform, InvertsWorldFromVehicle) {
  FramePose p = TruePose("a", 3);
  p.heading_rad = 725 * kDeg;  // two turns and 5 deg, unwrapped
  const FramePose q = PoseFromTransform(p.WorldFromVehicle(), p);
  EXPECT_NEAR(q.x_m, p.x_m, 1e-12);
  EXPECT_NEAR(q.z_m, p.z_m, 1e-12);
  EXPECT_NEAR(q.heading_rad, p.heading_rad, 1e-12);
  EXPECT_NEAR(q.pitch_rad, p.pitch_rad, 1e-12);
  EXPECT_NEAR(q.roll_rad, p.roll_rad, 1e-12);
  EXPECT_EQ(q.stem, "a");
}

TEST(GroundAligner, BringsAPairWithAWrongAttitudeBackOntoTheMap) {
  GroundAligner aligner(0.25, GroundAlignmentOptions{});
  GroundAlignment first;
  const FramePose a = TruePose("a", 0);
  const FramePose kept = aligner.Align(a, View(a, 1), &first);
  EXPECT_FALSE(first.applied);  // nothing to align to yet
  EXPECT_EQ(kept.pitch_rad, a.pitch_rad);

  const FramePose b = TruePose("b", 0.8);
  FramePose wrong = b;
  wrong.z_m += 0.08;
  wrong.pitch_rad += 1.0 * kDeg;  // inclinometers that read an acceleration
  wrong.roll_rad -= 0.7 * kDeg;
  GroundAlignment record;
  const FramePose fixed = aligner.Align(wrong, View(b, 2), &record);
  ASSERT_TRUE(record.applied) << record.reason;
  EXPECT_GT(record.cells, 300);
  EXPECT_GT(record.rms_before_m, 0.05);
  EXPECT_LT(record.rms_after_m, 0.02);
  EXPECT_NEAR(fixed.pitch_rad / kDeg, b.pitch_rad / kDeg, 0.05);
  EXPECT_NEAR(fixed.roll_rad / kDeg, b.roll_rad / kDeg, 0.05);
  EXPECT_NEAR(fixed.z_m, b.z_m, 0.01);
  EXPECT_NEAR(fixed.heading_rad / kDeg, b.heading_rad / kDeg, 0.02);  // untouched, to first order
  EXPECT_NEAR(fixed.x_m, b.x_m, 1e-9);
  EXPECT_NEAR(fixed.y_m, b.y_m, 1e-9);

  // Half the correction with a gain of one half.
  GroundAlignmentOptions half;
  half.gain = 0.5;
  GroundAligner damped(0.25, half);
  damped.Align(a, View(a, 1), nullptr);
  const FramePose partly = damped.Align(wrong, View(b, 2), nullptr);
  EXPECT_NEAR((partly.pitch_rad - b.pitch_rad) / kDeg, 0.5, 0.05);
}

TEST(GroundAligner, ABandOfOneDistanceFixesTheHeightThereWithTheLeastTilt) {
  // map-loop's requests: each pair matches a band of ground a metre or two deep, overlapping
  // the last one's. The band fixes the height there and the roll, not the pitch: the prior
  // takes the least tilt, so the pair lands on the map where they overlap.
  GroundAligner aligner(0.25, GroundAlignmentOptions{});
  const FramePose a = TruePose("a", 0);
  aligner.Align(a, View(a, 1, 4.0, 6.5), nullptr);
  const FramePose b = TruePose("b", 0.8);
  FramePose wrong = b;
  wrong.z_m += 0.06;
  wrong.roll_rad += 0.8 * kDeg;
  GroundAlignment record;
  const FramePose fixed = aligner.Align(wrong, View(b, 2, 5.0, 6.5), &record);
  ASSERT_TRUE(record.applied) << record.reason;
  EXPECT_GT(record.rms_before_m, 0.04);
  EXPECT_LT(record.rms_after_m, 0.015);
  EXPECT_NEAR(fixed.roll_rad / kDeg, b.roll_rad / kDeg, 0.1);
  // The pitch moves little (at most what the shift at 5.7 m ahead would ask alone).
  EXPECT_LT(std::abs(fixed.pitch_rad - b.pitch_rad) / kDeg, 0.6);
}

TEST(GroundAligner, LeavesAPairAloneWithoutGroundInCommonOrForAnImplausibleFit) {
  GroundAligner aligner(0.25, GroundAlignmentOptions{});
  const FramePose a = TruePose("a", 0);
  aligner.Align(a, View(a, 1), nullptr);
  const FramePose far = TruePose("c", 30);  // beyond what pair a saw
  GroundAlignment record;
  FramePose wrong = far;
  wrong.pitch_rad += 1 * kDeg;
  const FramePose kept = aligner.Align(wrong, View(far, 3), &record);
  EXPECT_FALSE(record.applied);
  EXPECT_NE(record.reason.find("in common"), std::string::npos);
  EXPECT_EQ(kept.pitch_rad, wrong.pitch_rad);

  GroundAligner again(0.25, GroundAlignmentOptions{});
  again.Align(a, View(a, 1), nullptr);
  FramePose tipped = TruePose("b", 0.8);
  tipped.pitch_rad += 20 * kDeg;  // no inclinometer is this wrong
  again.Align(tipped, View(TruePose("b", 0.8), 2), &record);
  EXPECT_FALSE(record.applied);
  EXPECT_TRUE(record.contradicts);
  EXPECT_NE(record.reason.find("largest"), std::string::npos);
}

TEST(GroundAlignmentOptions, RefusesNonsense) {
  GroundAlignmentOptions o;
  o.gain = 0;
  EXPECT_THROW(o.Validate(), std::invalid_argument);
  o = GroundAlignmentOptions{};
  o.min_range_m = 12;
  EXPECT_THROW(o.Validate(), std::invalid_argument);
  o = GroundAlignmentOptions{};
  o.max_tilt_deg = std::nan("");
  EXPECT_THROW(o.Validate(), std::invalid_argument);
}

}  // namespace
}  // namespace lunarnav::mapping
