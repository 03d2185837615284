#include "positioning/dead_reckoning.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "positioning/attitude.h"

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

// A drive of a skid-steered rover (track 0.84 m, the wheels' differential 1.5 x the track's):
// straight 10 m, a 90 deg turn in place, an arc of radius 5 m through 90 deg, straight 10 m,
// at 10 Hz, each wheel's rim turning a few % further than the ground (a slowly varying slip
// per wheel, never beyond the slip tolerance). Returns the inputs with the wheels read by
// encoders of `counts_per_metre` (each from its own random starting phase) and the wheels'
// true mean travel.
DeadReckoningInputs SkidSteeredDrive(double metres_per_count, double* true_travel_m) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> phase(0.0, 1.0);
  const double half_track = 0.5 * 1.5 * 0.84;
  struct Segment { double seconds, speed_mps, turn_radps; };
  const Segment segments[] = {{2, 0, 0}, {25, 0.4, 0}, {9, 0, 10 * kDeg}, {19.6, 0.4, 0.08}, {25, 0.4, 0}, {2, 0, 0}};
  DeadReckoningInputs in;
  std::array<double, 4> rim{}, offset{};
  for (double& o : offset) o = phase(rng);
  const double side[4] = {1, -1, 1, -1};
  double t = 0, heading = 0;
  *true_travel_m = 0;
  auto sample = [&]() {
    in.t_s.push_back(t);
    in.heading_rad.push_back(heading);
    for (int i = 0; i < 4; ++i) {
      in.wheel_m[i].push_back(std::floor(rim[i] / metres_per_count + offset[i]) * metres_per_count);
    }
  };
  sample();
  for (const Segment& s : segments) {
    for (int k = 0; k < static_cast<int>(std::lround(s.seconds / 0.1)); ++k) {
      t += 0.1;
      heading += s.turn_radps * 0.1;
      for (int i = 0; i < 4; ++i) {
        const double slip = 1.03 + 0.04 * std::sin(0.3 * t + i);  // 3 % +- 4 %
        rim[i] += slip * (s.speed_mps + side[i] * s.turn_radps * half_track) * 0.1;
      }
      sample();
    }
  }
  for (const double r : rim) *true_travel_m += 0.25 * r;
  return in;
}

TEST(DeadReckon, SevenAndTenBitEncodersGiveTheSameDistance) {
  const double wheel_circumference = 2 * M_PI * 0.25;
  double travel7 = 0, travel10 = 0;
  DeadReckoningInputs in7 = SkidSteeredDrive(wheel_circumference / 32, &travel7);    // 4.9 cm
  DeadReckoningInputs in10 = SkidSteeredDrive(wheel_circumference / 256, &travel10);  // 6 mm
  in7.wheel_resolution_m.fill(wheel_circumference / 32);
  in10.wheel_resolution_m.fill(wheel_circumference / 256);
  const DeadReckoningResult r7 = DeadReckon(in7, {});
  const DeadReckoningResult r10 = DeadReckon(in10, {});
  ASSERT_NEAR(travel7, travel10, 1e-9);
  EXPECT_NEAR(r10.distance_m, travel10, 0.01 * travel10);
  EXPECT_NEAR(r7.distance_m, travel7, 0.02 * travel7);
  EXPECT_NEAR(r7.distance_m, r10.distance_m, 0.02 * r10.distance_m);
  // Neither quantisation nor the turn in place (the sides' wheels turning opposite ways) is slip.
  EXPECT_EQ(r10.slip_events, 0);
  EXPECT_LE(r7.slip_events, 5);
  const TrajectorySample& e7 = r7.trajectory.back();
  const TrajectorySample& e10 = r10.trajectory.back();
  EXPECT_LT(std::hypot(e7.x_m - e10.x_m, e7.y_m - e10.y_m), 0.02 * r10.distance_m);
}

TEST(DeadReckon, ASlippingWheelInATurnInPlaceIsDownWeighted) {
  // Turning in place: left wheels forward, right wheels back, 5 cm per step; the front left
  // wheel spins 60 % fast. The rover does not move; a plain mean would move it 1.5 cm a step.
  DeadReckoningInputs in;
  for (int k = 0; k < 50; ++k) {
    in.t_s.push_back(0.1 * k);
    in.heading_rad.push_back(0.1 * k);
    in.wheel_m[0].push_back(0.05 * 1.6 * k);
    in.wheel_m[1].push_back(-0.05 * k);
    in.wheel_m[2].push_back(0.05 * k);
    in.wheel_m[3].push_back(-0.05 * k);
  }
  const DeadReckoningResult r = DeadReckon(in, {});
  EXPECT_EQ(r.slip_events, 49);
  EXPECT_LT(std::hypot(r.trajectory.back().x_m, r.trajectory.back().y_m), 0.05);
  EXPECT_LT(r.distance_m, 0.1);  // a plain mean: 0.74 m
}

// The half angles' sines and cosines followed by the angle-sum formulas agree with sin and
// cos of every angle along a million-sample random walk of a heading that keeps turning
// (to 10 000 rad: large arguments too), with small steps, steps beyond the series' range,
// and jumps.
TEST(HalfAngleTracker, AgreesWithSinAndCos) {
  std::mt19937_64 rng(21);
  std::normal_distribution<double> step(0.02, 0.05);
  std::uniform_real_distribution<double> unit(0, 1);
  HalfAngleTracker tracker;
  double angle = -3.0, worst = 0;
  int series = 0;
  for (int i = 0; i < 1000000; ++i) {
    angle += step(rng);
    if (unit(rng) < 0.001) angle += 5.0 * (unit(rng) - 0.5);  // a jump
    const double before = angle;
    const HalfAngle a = tracker(before), b = HalfAngle::Of(before);
    worst = std::max({worst, std::abs(a.sin - b.sin), std::abs(a.cos - b.cos)});
    series += a.sin != b.sin;
  }
  EXPECT_GT(angle, 10000.0);
  EXPECT_LT(worst, 1e-13) << worst;
  EXPECT_GT(series, 100000);  // the series path ran (its values differ in the last bits)
}

}  // namespace
}  // namespace lunarnav::positioning
