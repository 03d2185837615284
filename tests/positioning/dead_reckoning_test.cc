#include "positioning/dead_reckoning.h"

#include <gtest/gtest.h>

#include <cmath>

namespace lunarnav::positioning {
namespace {

constexpr double kDeg = M_PI / 180.0;

// n steps of dt with the given heading and pitch functions and all four wheels at `speed`.
DeadReckoningInputs Drive(int n, double dt, double speed, double (*heading)(double),
                          double pitch_rad = 0.0) {
  DeadReckoningInputs in;
  for (int k = 0; k < n; ++k) {
    const double t = k * dt;
    in.t_s.push_back(t);
    in.heading_rad.push_back(heading(t));
    in.pitch_rad.push_back(pitch_rad);
    for (auto& w : in.wheel_m) w.push_back(speed * t);
  }
  return in;
}

TEST(DeadReckon, ConstantSpeedStraightRunIsTheExactLine) {
  const auto in = Drive(101, 0.1, 0.5, [](double) { return 30.0 * kDeg; }, 5.0 * kDeg);
  const DeadReckoningResult r = DeadReckon(in, {});
  const double d = 0.5 * 10.0;  // 5 m
  const TrajectorySample& end = r.trajectory.back();
  EXPECT_NEAR(end.x_m, d * std::cos(5 * kDeg) * std::sin(30 * kDeg), 1e-9);  // east
  EXPECT_NEAR(end.y_m, d * std::cos(5 * kDeg) * std::cos(30 * kDeg), 1e-9);  // north
  EXPECT_NEAR(end.z_m, d * std::sin(5 * kDeg), 1e-9);
  EXPECT_NEAR(r.distance_m, d, 1e-9);
  EXPECT_NEAR(end.speed_mps, 0.5, 1e-9);
  EXPECT_EQ(r.slip_events, 0);
}

TEST(DeadReckon, ACircleOfKnownRadiusCloses) {
  // Radius 4 m at 0.5 m/s: one turn in 16 pi s, heading rate v / R; sampled at 10 Hz.
  const double radius = 4.0, speed = 0.5, period = 2 * M_PI * radius / speed;
  const int n = static_cast<int>(std::round(period / 0.1)) + 1;
  const auto in = Drive(n, period / (n - 1), speed, [](double t) { return 0.125 * t; });
  const DeadReckoningResult r = DeadReckon(in, {});
  const TrajectorySample& end = r.trajectory.back();
  EXPECT_NEAR(r.distance_m, 2 * M_PI * radius, 1e-9);
  // Midpoint headings make the closure error second order in the step: well under a mm here.
  EXPECT_LT(std::hypot(end.x_m, end.y_m), 1e-3);
  // Half way round, the rover is a diameter away (heading 0 at start: moving north, turning
  // clockwise, so the centre is east).
  const TrajectorySample& half = r.trajectory[(n - 1) / 2];
  EXPECT_NEAR(std::hypot(half.x_m, half.y_m), 2 * radius, 1e-3);
  EXPECT_GT(half.x_m, 7.9);
}

TEST(DeadReckon, HeadingWrapIsInvisible) {
  auto unwrapped = Drive(200, 0.1, 0.4, [](double t) { return (170.0 + 2.0 * t) * kDeg; });
  auto wrapped = unwrapped;
  for (double& h : wrapped.heading_rad) h = std::remainder(h, 2 * M_PI);  // jumps at 180 deg
  const auto a = DeadReckon(unwrapped, {}).trajectory.back();
  const auto b = DeadReckon(wrapped, {}).trajectory.back();
  EXPECT_NEAR(a.x_m, b.x_m, 1e-9);
  EXPECT_NEAR(a.y_m, b.y_m, 1e-9);
}

TEST(DeadReckon, ASlippingWheelIsDownWeighted) {
  auto in = Drive(101, 0.1, 0.5, [](double) { return 0.0; });
  for (std::size_t k = 0; k < in.t_s.size(); ++k) in.wheel_m[2][k] *= 1.8;  // spins 80 % fast
  const DeadReckoningResult r = DeadReckon(in, {});
  EXPECT_NEAR(r.trajectory.back().y_m, 5.0, 0.1);  // a plain mean would give 5.4
  EXPECT_EQ(r.slip_events, 100);
}

}  // namespace
}  // namespace lunarnav::positioning
