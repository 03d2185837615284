#include "positioning/baseline.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace lunarnav::positioning {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kDeg = M_PI / 180.0;

// Four 10-bit wrapping encoders of 1024 counts per revolution on 0.11 m wheels, the left ones
// counting down when driving forward; a gyro of +-1 rad/s over 10 bits.
telemetry::SensorModel SkidSteerModel() {
  return telemetry::SensorModelFromJson(nlohmann::json::parse(R"({
    "format": "lunarnav.sensors/1",
    "channels": {
      "enc_fl": {"counts_per_revolution": 1024, "wheel_radius_m": 0.11, "sign": -1},
      "enc_fr": {"counts_per_revolution": 1024, "wheel_radius_m": 0.11},
      "enc_rl": {"counts_per_revolution": 1024, "wheel_radius_m": 0.11, "sign": -1},
      "enc_rr": {"counts_per_revolution": 1024, "wheel_radius_m": 0.11},
      "gyro_z": {"scale": 0.001953125, "offset": -1.0, "units": "rad/s"}
    }
  })"),
                                        "model");
}

// The counts of a wheel that has travelled `metres` (forward positive), from `start`.
double Count(const telemetry::SensorModel& m, telemetry::Channel c, double metres, double start) {
  const double counts = std::floor(metres / std::abs(m[c].MetresPerCount()));
  return std::fmod(std::fmod(start + m[c].sign * counts, 1024.0) + 1024.0, 1024.0);
}

TEST(PlainDeadReckoner, AStraightDriveOnWrappingDownCountingEncodersIsTheLine) {
  const telemetry::SensorModel model = SkidSteerModel();
  PlainDeadReckoner reckoner(model, {true, true, true, true}, false, 0.0, 1.0);
  const telemetry::Channel wheels[4] = {telemetry::Channel::kEncoderFrontLeft, telemetry::Channel::kEncoderFrontRight,
                                        telemetry::Channel::kEncoderRearLeft, telemetry::Channel::kEncoderRearRight};
  for (int k = 0; k <= 400; ++k) {  // 40 s at 0.5 m/s, 10 Hz: the counters wrap 28 times
    std::array<double, 4> counts;
    for (int w = 0; w < 4; ++w) counts[w] = Count(model, wheels[w], 0.05 * k, 100.0 * w);
    reckoner.Step(0.1 * k, counts, kNaN);
  }
  EXPECT_NEAR(reckoner.pose().y_m, 20.0, 0.001);  // one count is 0.67 mm
  EXPECT_NEAR(reckoner.pose().x_m, 0.0, 1e-9);
  EXPECT_NEAR(reckoner.distance_m(), 20.0, 0.001);
}

TEST(PlainDeadReckoner, RemovesTheGyroBiasLearntAtRestAndIntegratesAtTheGyrosRate) {
  const telemetry::SensorModel model = SkidSteerModel();
  PlainDeadReckoner reckoner(model, {true, true, false, false}, true, 0.0, 1.0);
  const double bias = 0.02;  // rad/s (1.15 deg/s)
  auto gyro_count = [&](double rate) { return (rate + bias + 1.0) / 0.001953125; };  // unrounded: exact
  double travel = 0, heading = 0;
  for (int k = 0; k <= 50 * 30; ++k) {  // gyro at 50 Hz, encoders at 10 Hz
    const double t = 0.02 * k;
    // At rest for 5 s, then an arc turning right at 0.3 rad/s for 5 s, then straight.
    const double rate = t >= 5 && t < 10 ? 0.3 : 0.0;
    if (k > 0) heading += rate * 0.02;
    if (t >= 5) travel += 0.4 * 0.02;
    std::array<double, 4> counts = {kNaN, kNaN, kNaN, kNaN};
    if (k % 5 == 0) {
      counts[0] = Count(model, telemetry::Channel::kEncoderFrontLeft, travel, 7);
      counts[1] = Count(model, telemetry::Channel::kEncoderFrontRight, travel, 900);
    }
    reckoner.Step(t, counts, gyro_count(rate));
  }
  EXPECT_TRUE(reckoner.gyro_bias_known());
  EXPECT_NEAR(reckoner.gyro_bias_radps(), bias, 1e-9);
  // 1.5 rad turned; the rate steps at 5 and 10 s are taken as trapezoids (half a sample each).
  EXPECT_NEAR(reckoner.pose().heading_rad, heading, 0.3 * 0.02);
  EXPECT_NEAR(reckoner.distance_m(), 0.4 * 25, 0.01);
}

// A skid-steered rover turning in place from rest: the gyro (50 Hz) shows the turn up to an
// encoder interval (10 Hz) before the wheels' counts change. Those readings are the turn's,
// not the rest's: they stay out of the bias and in the heading.
TEST(PlainDeadReckoner, ATurnThatStartsBetweenEncoderSamplesIsNotTakenForRest) {
  const telemetry::SensorModel model = SkidSteerModel();
  const double bias = 0.001;  // rad/s
  const double turn_rate = 0.8;  // rad/s (46 deg/s), right
  for (double start : {5.02, 5.04, 5.06, 5.08}) {  // encoders at 5.0 and 5.1 s
    PlainDeadReckoner reckoner(model, {true, true, true, true}, true, 0.0, 1.0);
    double heading = 0, wheel = 0, last_t = 0;
    for (int k = 0; k <= 50 * 8; ++k) {  // 8 s
      const double t = 0.02 * k;
      // At rest, then turning in place for 2 s: the right wheels back, the left ones forward.
      const double rate = t >= start - 1e-9 && t < start + 2 ? turn_rate : 0.0;
      heading += rate * (t - last_t);
      wheel += rate * 0.25 * (t - last_t);  // a 0.5 m track
      last_t = t;
      std::array<double, 4> counts = {kNaN, kNaN, kNaN, kNaN};
      if (k % 5 == 0) {
        counts[0] = Count(model, telemetry::Channel::kEncoderFrontLeft, wheel, 10);
        counts[1] = Count(model, telemetry::Channel::kEncoderFrontRight, -wheel, 500);
        counts[2] = Count(model, telemetry::Channel::kEncoderRearLeft, wheel, 20);
        counts[3] = Count(model, telemetry::Channel::kEncoderRearRight, -wheel, 700);
      }
      reckoner.Step(t, counts, (rate + bias + 1.0) / 0.001953125);
    }
    SCOPED_TRACE(start);
    ASSERT_TRUE(reckoner.gyro_bias_known());
    // Taken as rest, the turn's readings before the counts change (1-4 of 250) would move the
    // bias by up to 0.8 x 4 / 250 = 0.013 rad/s and take up to 0.064 rad from the turn.
    EXPECT_NEAR(reckoner.gyro_bias_radps(), bias, 1e-9);
    EXPECT_NEAR(reckoner.pose().heading_rad, heading, turn_rate * 0.02);  // trapezoids at the steps
  }
}

TEST(PlainDeadReckoner, WithoutAStillStartTheFirstStationaryPeriodGivesTheBias) {
  const telemetry::SensorModel model = SkidSteerModel();
  PlainDeadReckoner reckoner(model, {true, false, false, false}, true, 10 * kDeg, 1.0);
  const double bias = -0.01;
  double travel = 0;
  for (int k = 0; k <= 10 * 20; ++k) {  // 10 Hz: driving 5 s, 4 s still, driving again
    const double t = 0.1 * k;
    if (t < 5 || t >= 9) travel += 0.05;
    reckoner.Step(t, {Count(model, telemetry::Channel::kEncoderFrontLeft, travel, 0), kNaN, kNaN, kNaN},
                  (bias + 1.0) / 0.001953125);
  }
  EXPECT_TRUE(reckoner.gyro_bias_known());
  EXPECT_NEAR(reckoner.gyro_bias_radps(), bias, 1e-9);
  // Until the bias was known (the end of the stop, at 9 s) the heading drifted with it; after,
  // not.
  EXPECT_NEAR(reckoner.pose().heading_rad, 10 * kDeg + bias * 9.0, std::abs(bias) * 0.5);
}

}  // namespace
}  // namespace lunarnav::positioning
