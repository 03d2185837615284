#include "sim/rover_sensors.h"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <vector>

#include "sim/rover_telemetry.h"
#include "telemetry/sensor_model.h"
#include "telemetry/telemetry_csv.h"
#include "util/testing.h"

namespace lunarnav::sim {
namespace {

using telemetry::Channel;
constexpr double kDeg = M_PI / 180.0;
constexpr Channel kWheels[4] = {Channel::kEncoderFrontLeft, Channel::kEncoderFrontRight, Channel::kEncoderRearLeft,
                                Channel::kEncoderRearRight};

double WrapPi(double a) { return std::remainder(a, 2 * M_PI); }

// With ideal sensors, every count of the written log, read back through the project's own
// reader and sensor model (telemetry.csv + sensors.json), is the truth within one
// quantisation step: half a step for rounded analog channels, one count for encoders (whole
// counts turned), across counter and compass wrap-around.
void ExpectCountsDecodeToTruth(TelemetryPreset preset, int bits) {
  RoverTelemetryOptions options;
  options.preset = preset;
  options.bits = bits;
  options.noise_scale = 0;
  options.duration_s = 240;
  const RoverTelemetry run = SimulateRoverTelemetry(options);
  util::ScopedTempDir dir;
  WriteRoverTelemetry(dir.path(), run, options);
  const telemetry::SensorModel model = telemetry::ReadSensorModel(dir.path() / "sensors.json");
  const telemetry::TelemetryLog log = telemetry::ReadTelemetryCsv(dir.path() / "telemetry.csv", model);
  const std::vector<RoverSample>& truth = run.drive.samples;
  ASSERT_EQ(log.size(), truth.size());
  int wraps = 0;
  for (std::size_t k = 0; k < truth.size(); ++k) {
    ASSERT_NEAR(log.t_s[k], truth[k].t_s, 1e-9);
    const auto value = [&](Channel c) { return log.counts[static_cast<int>(c)][k]; };
    const auto step = [&](Channel c) { return std::abs(model[c].ToRadians(1) - model[c].ToRadians(0)); };
    for (Channel c : {Channel::kCompass, Channel::kPitchLeft, Channel::kPitchRight, Channel::kRoll, Channel::kGyroZ}) {
      ASSERT_GE(value(c), 0);
      ASSERT_LE(value(c), (1 << bits) - 1);
    }
    EXPECT_LE(std::abs(WrapPi(model[Channel::kCompass].ToRadians(value(Channel::kCompass)) - truth[k].heading_rad)),
              0.5 * step(Channel::kCompass) + 1e-9)
        << "row " << k;
    EXPECT_NEAR(model[Channel::kPitchLeft].ToRadians(value(Channel::kPitchLeft)), truth[k].pitch_left_rad,
                0.5 * step(Channel::kPitchLeft) + 1e-9);
    EXPECT_NEAR(model[Channel::kPitchRight].ToRadians(value(Channel::kPitchRight)), truth[k].pitch_right_rad,
                0.5 * step(Channel::kPitchRight) + 1e-9);
    EXPECT_NEAR(model[Channel::kRoll].ToRadians(value(Channel::kRoll)), truth[k].roll_rad,
                0.5 * step(Channel::kRoll) + 1e-9);
    EXPECT_NEAR(model[Channel::kGyroZ].ToRadians(value(Channel::kGyroZ)), truth[k].turn_rate_radps,
                0.5 * step(Channel::kGyroZ) + 1e-9);
    for (int i = 0; i < 4; ++i) {
      const telemetry::ChannelModel& m = model[kWheels[i]];
      const double period = std::ldexp(1.0, m.counter_bits);
      ASSERT_LT(value(kWheels[i]), period);
      // Counts since the start, unwrapped: the travel modulo one counter period.
      const double counts = value(kWheels[i]) - static_cast<double>(run.draws.encoder_initial_counts[i]);
      const double travel_counts = truth[k].wheel_m[i] / m.MetresPerCount();  // signed like the counter
      const double residue = std::remainder(counts - travel_counts, period);
      EXPECT_LT(std::abs(residue), 1.0 + 1e-9) << "row " << k << " wheel " << i;
      if (k > 0 && std::abs(value(kWheels[i]) - log.counts[static_cast<int>(kWheels[i])][k - 1]) > period / 2) ++wraps;
    }
  }
  EXPECT_GT(wraps, 0) << "the counters should wrap in this log";
}

TEST(SimulatedSensors, IdealCountsDecodeToTruthWithinOneQuantisationStep10Bits) {
  ExpectCountsDecodeToTruth(TelemetryPreset::kTrialB, 10);
  ExpectCountsDecodeToTruth(TelemetryPreset::kTraverse, 10);
}

TEST(SimulatedSensors, IdealCountsDecodeToTruthWithinOneQuantisationStep7Bits) {
  ExpectCountsDecodeToTruth(TelemetryPreset::kTrialC, 7);
}

TEST(SimulatedSensors, SensorModelIsThePapersRoverAndItsOldTelemetry) {
  const telemetry::SensorModel m10 = SimulatedSensorModel(10), m7 = SimulatedSensorModel(7);
  for (Channel c : telemetry::kAllChannels) {
    EXPECT_EQ(m10[c].bits, 10);
    EXPECT_EQ(m7[c].bits, 7);
  }
  EXPECT_EQ(m10[Channel::kEncoderFrontLeft].counter_bits, 10);
  EXPECT_EQ(m7[Channel::kEncoderFrontLeft].counter_bits, 7);
  // The same sensors: full scale unchanged, 8 times coarser.
  EXPECT_DOUBLE_EQ(m7[Channel::kCompass].scale * 128, 360.0);
  EXPECT_DOUBLE_EQ(m7[Channel::kEncoderRearRight].MetresPerCount(), 8 * m10[Channel::kEncoderRearRight].MetresPerCount());
  EXPECT_EQ(m10[Channel::kEncoderFrontRight].sign, -1);
  EXPECT_EQ(m10[Channel::kEncoderFrontLeft].sign, 1);
}

TEST(DigitiseAnalog, RoundsClampsAndWrapsTheCompass) {
  const telemetry::SensorModel model_compass = SimulatedSensorModel(10);  // kept: the reference below points into it
  const telemetry::ChannelModel& compass = model_compass[Channel::kCompass];
  EXPECT_EQ(DigitiseAnalog(compass, 0.0, true), 0);
  EXPECT_EQ(DigitiseAnalog(compass, -0.1 * kDeg, true), 0);
  EXPECT_EQ(DigitiseAnalog(compass, -1.0 * kDeg, true), 1021);  // -2.84 counts
  EXPECT_EQ(DigitiseAnalog(compass, 361.0 * kDeg, true), 3);
  const telemetry::SensorModel model_gyro = SimulatedSensorModel(10);  // kept: the reference below points into it
  const telemetry::ChannelModel& gyro = model_gyro[Channel::kGyroZ];
  EXPECT_EQ(DigitiseAnalog(gyro, 0.0, false), 512);
  EXPECT_EQ(DigitiseAnalog(gyro, 100.0 * kDeg, false), 1023);  // beyond +60 deg/s: the rail
  EXPECT_EQ(DigitiseAnalog(gyro, -100.0 * kDeg, false), 0);
}

TEST(DigitiseEncoder, CountsWholeCountsWithSignAndWraps) {
  const telemetry::SensorModel model = SimulatedSensorModel(10);
  const telemetry::ChannelModel& left = model[Channel::kEncoderFrontLeft];
  const telemetry::ChannelModel& right = model[Channel::kEncoderFrontRight];
  const double per = std::abs(left.MetresPerCount());
  EXPECT_EQ(DigitiseEncoder(left, 2.5 * per, 1000), 1002);
  EXPECT_EQ(DigitiseEncoder(left, 30.0 * per, 1000), 6);       // 1030 mod 1024
  EXPECT_EQ(DigitiseEncoder(right, 2.5 * per, 1), 1023);       // counts down: 1 - 2
  EXPECT_EQ(DigitiseEncoder(left, -0.5 * per, 0), 1023);       // reversing half a count: floor
}

// The sensors' error processes, each seen on its own.
TEST(SimulatedSensors, CompassNoiseHasMostOfItsPowerAboveAQuarterHertz) {
  std::vector<RoverSample> still(4096);
  for (std::size_t k = 0; k < still.size(); ++k) still[k].t_s = 0.1 * k;
  const telemetry::SensorModel model = SimulatedSensorModel(10);
  const RawTelemetry raw = SimulateSensors(still, SensorErrorOptions(), model, 10.0, 5, nullptr);
  std::vector<double> x(still.size());
  double mean = 0;
  for (std::size_t k = 0; k < x.size(); ++k) {
    x[k] = WrapPi(model[Channel::kCompass].ToRadians(raw.counts[k][static_cast<int>(Channel::kCompass)])) / kDeg;
    mean += x[k] / x.size();
  }
  // Periodogram by a direct DFT over the bins up to Nyquist.
  const std::size_t n = x.size();
  double below = 0, above = 0, total_var = 0;
  for (double v : x) total_var += (v - mean) * (v - mean) / n;
  for (std::size_t f = 1; f <= n / 2; ++f) {
    std::complex<double> sum = 0;
    for (std::size_t k = 0; k < n; ++k) sum += (x[k] - mean) * std::polar(1.0, -2 * M_PI * f * k / n);
    const double hz = 10.0 * f / n;
    (hz <= 0.25 ? below : above) += std::norm(sum);
  }
  EXPECT_GT(above / (above + below), 0.8);
  // About the configured 2 deg RMS, plus the slow wander (0.5 deg) and quantisation.
  EXPECT_NEAR(std::sqrt(total_var), std::hypot(2.0, 0.5), 0.5);
}

TEST(SimulatedSensors, CompassLagsWhileTurningAndGyroHasItsDrawnBiasAndScale) {
  RoverTelemetryOptions options;
  options.preset = TelemetryPreset::kTrialB;  // turns in place at 10 deg/s
  const RoverTelemetry run = SimulateRoverTelemetry(options);
  const telemetry::SensorModel& model = run.sensor_model;
  double turning_error = 0, still_error = 0;
  int turning = 0, still = 0;
  // Least-squares gyro = a + b * truth, in deg/s.
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (std::size_t k = 0; k < run.raw.size(); ++k) {
    const RoverSample& s = run.drive.samples[k];
    const double compass = model[Channel::kCompass].ToRadians(run.raw.counts[k][static_cast<int>(Channel::kCompass)]);
    const double error = WrapPi(compass - s.heading_rad) / kDeg - run.draws.compass_bias_deg;
    if (std::abs(s.turn_rate_radps / kDeg) > 9.9) {
      turning_error += error * (s.turn_rate_radps > 0 ? 1 : -1);
      ++turning;
    } else if (s.speed_mps == 0 && s.turn_rate_radps == 0) {
      still_error += error;
      ++still;
    }
    const double x = s.turn_rate_radps / kDeg;
    const double y = model[Channel::kGyroZ].ToRadians(run.raw.counts[k][static_cast<int>(Channel::kGyroZ)]) / kDeg;
    sx += x;
    sy += y;
    sxx += x * x;
    sxy += x * y;
  }
  ASSERT_GT(turning, 100);
  ASSERT_GT(still, 100);
  // At 10 deg/s the compass reads about 1.5 deg per deg/s behind (docs/simulate.md).
  EXPECT_LT(turning_error / turning, -8.0);
  EXPECT_NEAR(still_error / still, 0.0, 1.5);
  const double n = static_cast<double>(run.raw.size());
  const double slope = (n * sxy - sx * sy) / (n * sxx - sx * sx);
  const double intercept = (sy - slope * sx) / n;
  EXPECT_NEAR(slope, 1.0 + run.draws.gyro_scale_error, 0.005);
  EXPECT_NEAR(intercept, run.draws.gyro_bias_dps, 0.1);
  EXPECT_GT(std::abs(run.draws.gyro_bias_dps) + std::abs(run.draws.gyro_scale_error), 0.0);
}

TEST(SimulatedSensors, InclinometersReadAccelerationAsTilt) {
  // Ideal sensors but for the pendulum physics: accelerating at a, pitch reads atan(a/g) high.
  SensorErrorOptions e = SensorErrorOptions().Scaled(0);
  e.tilt_accel_gain = 1;
  e.tilt_tau_s = 0;
  std::vector<RoverSample> samples(20);
  for (std::size_t k = 0; k < samples.size(); ++k) {
    samples[k].t_s = 0.1 * k;
    samples[k].accel_mps2 = k < 10 ? 0.0 : 0.5;
  }
  const telemetry::SensorModel model = SimulatedSensorModel(10);
  const RawTelemetry raw = SimulateSensors(samples, e, model, 10.0, 1, nullptr);
  const telemetry::ChannelModel& m = model[Channel::kPitchLeft];
  EXPECT_NEAR(m.ToRadians(raw.counts[5][static_cast<int>(Channel::kPitchLeft)]), 0.0, 0.5 * m.scale * kDeg);
  EXPECT_NEAR(m.ToRadians(raw.counts[15][static_cast<int>(Channel::kPitchLeft)]), std::atan(0.5 / 9.80665),
              0.5 * m.scale * kDeg + 1e-12);
}

}  // namespace
}  // namespace lunarnav::sim
