#include "sim/rover_motion.h"

#include <gtest/gtest.h>

#include <cmath>

#include "sim/ground_surface.h"

namespace lunarnav::sim {
namespace {

constexpr double kDeg = M_PI / 180.0;

// A rover whose wheels roll without slip and whose path does not wander.
RoverOptions Ideal() { return RoverOptions().Scaled(0.0); }

RoverDrive Drive(const std::vector<MotionCommand>& commands, double heading_deg, const RoverOptions& rover = Ideal(),
                 const GroundSurfaceOptions& ground = {}) {
  return DriveRover(commands, rover, GroundSurface(ground, 1), heading_deg, 10.0, std::nullopt, 1);
}

TEST(DriveRover, StraightWithoutSlipEndsWhereCommandedAndItsWheelsTurnThatFar) {
  const RoverDrive d = Drive({MotionCommand::Pause(1), MotionCommand::Straight(5, 0.4), MotionCommand::Pause(2)}, 30);
  ASSERT_EQ(d.trials.size(), 1u);
  const RoverTrial& trial = d.trials[0];
  EXPECT_EQ(trial.description, "straight 5 m at 0.4 m/s");
  const RoverSample& start = d.samples[trial.start_sample];
  const RoverSample& end = d.samples[trial.end_sample];
  EXPECT_EQ(start.speed_mps, 0.0);
  EXPECT_EQ(end.speed_mps, 0.0);
  EXPECT_NEAR(start.t_s, 1.0, 0.1 + 1e-9);
  // The rover stops at the commanded distance (it creeps the last centimetres).
  EXPECT_NEAR(end.distance_m, 5.0, 0.005);
  EXPECT_NEAR(end.x_m, 5.0 * std::sin(30 * kDeg), 0.005);
  EXPECT_NEAR(end.y_m, 5.0 * std::cos(30 * kDeg), 0.005);
  EXPECT_DOUBLE_EQ(end.heading_rad, 30 * kDeg);
  for (double w : end.wheel_m) EXPECT_NEAR(w, end.distance_m, 1e-9);
  // At rest until the end of the log; speeds within the acceleration limit throughout.
  EXPECT_EQ(d.samples.back().x_m, end.x_m);
  for (std::size_t k = 1; k < d.samples.size(); ++k) {
    EXPECT_LE(std::abs(d.samples[k].speed_mps - d.samples[k - 1].speed_mps), Ideal().max_accel_mps2 * 0.1 + 1e-9);
  }
}

TEST(DriveRover, ArcWithoutSlipFollowsItsCircle) {
  // From the origin heading north, 90 deg right on a 5 m radius: the centre is (5, 0) and
  // the rover ends at (5, 5) heading east.
  const RoverDrive d = Drive({MotionCommand::Arc(5, 90, 0.3), MotionCommand::Pause(1)}, 0);
  ASSERT_EQ(d.trials.size(), 1u);
  const RoverSample& end = d.samples[d.trials[0].end_sample];
  EXPECT_NEAR(end.x_m, 5.0, 0.03);
  EXPECT_NEAR(end.y_m, 5.0, 0.03);
  EXPECT_NEAR(end.heading_rad / kDeg, 90.0, 0.3);
  for (const RoverSample& s : d.samples) EXPECT_NEAR(std::hypot(s.x_m - 5.0, s.y_m), 5.0, 0.03);
  // Skid steering without slip: the outer (left) wheels travel (R + track/2) / R as far.
  const double track = Ideal().track_m;
  EXPECT_NEAR(end.wheel_m[0] / end.wheel_m[1], (5 + track / 2) / (5 - track / 2), 0.01);
}

TEST(DriveRover, TurnInPlaceTurnsByItsAngleWithoutMoving) {
  const RoverDrive d = Drive({MotionCommand::TurnInPlace(-90, 10), MotionCommand::Pause(1)}, 10);
  ASSERT_EQ(d.trials.size(), 1u);
  const RoverSample& end = d.samples[d.trials[0].end_sample];
  EXPECT_NEAR(end.heading_rad / kDeg, -80.0, 0.1);
  EXPECT_NEAR(end.x_m, 0.0, 1e-9);
  EXPECT_NEAR(end.y_m, 0.0, 1e-9);
  // Left wheels back, right wheels forward, each a quarter circle of radius track / 2.
  const double arc = 0.5 * Ideal().track_m * M_PI / 2;
  EXPECT_NEAR(end.wheel_m[0], -arc, 0.005);
  EXPECT_NEAR(end.wheel_m[1], arc, 0.005);
  double max_rate = 0;
  for (const RoverSample& s : d.samples) max_rate = std::max(max_rate, std::abs(s.turn_rate_radps));
  EXPECT_NEAR(max_rate / kDeg, 10.0, 1e-6);
}

TEST(DriveRover, WheelsSlipByTheConfiguredFraction) {
  RoverOptions rover;  // slip_mean 0.03, per-wheel variation 0.02 RMS
  rover.turn_slip_rate_hz = 0;
  const RoverDrive d = Drive({MotionCommand::Straight(20, 0.4), MotionCommand::Pause(1)}, 0, rover);
  const RoverSample& end = d.samples.back();
  double mean = 0;
  for (double w : end.wheel_m) mean += 0.25 * w / end.distance_m;
  EXPECT_NEAR(mean, 1.0 + rover.slip_mean, 0.015);
  EXPECT_GT(mean, 1.0);
}

TEST(DriveRover, AttitudeFollowsTheSlopeWithThePaperSigns) {
  GroundSurfaceOptions slope;
  slope.slope_deg = 5;
  slope.slope_azimuth_deg = 0;  // rising to the north
  // Heading north: nose up 5 deg, no roll; 10 m along the ground climb 10 sin 5 deg.
  RoverDrive d = Drive({MotionCommand::Straight(10, 0.4)}, 0, Ideal(), slope);
  const RoverSample& up = d.samples.back();
  EXPECT_NEAR(up.pitch_rad / kDeg, 5.0, 0.01);
  EXPECT_NEAR(up.roll_rad / kDeg, 0.0, 0.01);
  EXPECT_NEAR(up.z_m, 10 * std::sin(5 * kDeg), 0.01);
  EXPECT_NEAR(up.y_m, 10 * std::cos(5 * kDeg), 0.01);
  // Heading east: the left side is uphill, so the right side is down: roll +5 deg.
  d = Drive({MotionCommand::Straight(10, 0.4)}, 90, Ideal(), slope);
  EXPECT_NEAR(d.samples.back().pitch_rad / kDeg, 0.0, 0.01);
  EXPECT_NEAR(d.samples.back().roll_rad / kDeg, 5.0, 0.01);
  EXPECT_NEAR(d.samples.back().z_m, 0.0, 1e-9);
}

TEST(DriveRover, ALogShorterThanTheCommandsTruncatesTheLastTrial) {
  const std::vector<MotionCommand> commands = {MotionCommand::Straight(4, 0.4), MotionCommand::Pause(2),
                                               MotionCommand::Straight(4, 0.4), MotionCommand::Pause(2)};
  const RoverDrive full = DriveRover(commands, Ideal(), GroundSurface({}, 1), 0, 10, std::nullopt, 1);
  EXPECT_EQ(full.trials.size(), 2u);
  EXPECT_EQ(full.trials_truncated, 0);
  const RoverDrive cut = DriveRover(commands, Ideal(), GroundSurface({}, 1), 0, 10, 20.0, 1);
  EXPECT_EQ(cut.samples.size(), 201u);
  EXPECT_EQ(cut.trials.size(), 1u);
  EXPECT_EQ(cut.trials_truncated, 1);
}

TEST(DriveRover, RejectsImpossibleCommands) {
  EXPECT_THROW(Drive({MotionCommand::Arc(0, 90, 0.3)}, 0), std::invalid_argument);
  EXPECT_THROW(Drive({MotionCommand::Straight(3, 0)}, 0), std::invalid_argument);
  EXPECT_THROW(Drive({MotionCommand::Pause(-1)}, 0), std::invalid_argument);
}

}  // namespace
}  // namespace lunarnav::sim
