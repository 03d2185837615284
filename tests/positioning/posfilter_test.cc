#include "positioning/posfilter.h"

#include <gtest/gtest.h>

#include <cmath>
#include <algorithm>
#include <array>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "positioning/trajectory_io.h"
#include "telemetry/lowpass.h"
#include "util/testing.h"

namespace lunarnav::positioning {
namespace {

// A straight drive at 0.5 m/s with a single inclinometer, `pitch_column`, reading a step
// from 0 to 114 counts (10.02 deg) halfway; 10 Hz.
telemetry::TelemetryLog OneInclinometerLog(const telemetry::SensorModel& model, telemetry::Channel pitch) {
  telemetry::TelemetryLog log;
  log.source = "log.csv";
  const int n = 400;
  const double counts_per_m = 1.0 / model[telemetry::Channel::kEncoderFrontLeft].MetresPerCount();
  for (int k = 0; k < n; ++k) {
    log.t_s.push_back(0.1 * k);
    log.line.push_back(k + 2);
    log.counts[static_cast<int>(telemetry::Channel::kEncoderFrontLeft)].push_back(
        static_cast<double>(std::llround(0.05 * k * counts_per_m) % 1024));  // a 10-bit counter
    log.counts[static_cast<int>(pitch)].push_back(k < n / 2 ? 512 : 512 + 114);  // 10.02 deg
  }
  return log;
}

telemetry::SensorModel Model(const std::string& pitch_column) {
  return telemetry::SensorModelFromJson(nlohmann::json::parse(R"({
    "format": "lunarnav.sensors/1",
    "channels": {
      "enc_fl": {"counts_per_revolution": 512, "wheel_radius_m": 0.2},
      ")" + pitch_column + R"(": {"scale": 0.087890625, "offset": -45.0, "units": "deg"}
    }
  })"),
                                        "model");
}

// With one inclinometer, either, the pitch is that inclinometer low-passed: the step shows
// the filter's smooth rise (no jump), and the two sides give the same trajectory.
TEST(RunPosfilter, OneInclinometerOnEitherSideGivesItsFilteredPitch) {
  const telemetry::SensorModel left_model = Model("pitch_left"), right_model = Model("pitch_right");
  PosfilterOptions filtered;
  filtered.smooth_attitude = false;
  const PosfilterResult left =
      RunPosfilter(OneInclinometerLog(left_model, telemetry::Channel::kPitchLeft), left_model, filtered);
  const PosfilterResult right =
      RunPosfilter(OneInclinometerLog(right_model, telemetry::Channel::kPitchRight), right_model, filtered);
  const auto& a = left.motion.trajectory;
  const auto& b = right.motion.trajectory;
  ASSERT_EQ(a.size(), 400u);
  ASSERT_EQ(b.size(), a.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].pitch_rad, b[k].pitch_rad) << k;
    EXPECT_EQ(a[k].z_m, b[k].z_m) << k;
  }
  // Filtered by the tilt's low-pass: the step's first sample moves the pitch by the filter's
  // first coefficient times the step (10 deg), far less than the step.
  const double deg = M_PI / 180.0;
  ASSERT_EQ(right.tilt_design.sections.size(), 1u);
  const double step = (b.back().pitch_rad - b[199].pitch_rad);
  EXPECT_NEAR(b[200].pitch_rad - b[199].pitch_rad, right.tilt_design.sections[0].b0 * step, 1e-9);
  EXPECT_LT(b[200].pitch_rad - b[199].pitch_rad, 0.2 * step);
  EXPECT_NEAR(b.back().pitch_rad, 114 * 0.087890625 * deg, 0.001 * deg);
}

// The tilt's low-pass sets the attitude reported, not the path: the dead reckoning integrates
// the pitch through the paper's low-pass (--cutoff) whatever --tilt-cutoff is, so x, y and z
// are the same bit for bit, while the pitch reported follows the step sooner.
TEST(RunPosfilter, TheTiltCutoffChangesTheAttitudeNotThePath) {
  const telemetry::SensorModel model = Model("pitch_left");
  const telemetry::TelemetryLog log = OneInclinometerLog(model, telemetry::Channel::kPitchLeft);
  PosfilterOptions slow, fast;
  slow.smooth_attitude = fast.smooth_attitude = false;
  slow.tilt_cutoff_hz = slow.cutoff_hz;
  fast.tilt_cutoff_hz = 2.0;
  const PosfilterResult a = RunPosfilter(log, model, slow), b = RunPosfilter(log, model, fast);
  ASSERT_EQ(a.motion.trajectory.size(), b.motion.trajectory.size());
  for (std::size_t k = 0; k < a.motion.trajectory.size(); ++k) {
    EXPECT_EQ(a.motion.trajectory[k].x_m, b.motion.trajectory[k].x_m) << k;
    EXPECT_EQ(a.motion.trajectory[k].y_m, b.motion.trajectory[k].y_m) << k;
    EXPECT_EQ(a.motion.trajectory[k].z_m, b.motion.trajectory[k].z_m) << k;
  }
  // One second after the 10 deg step: the 0.25 Hz pitch has risen by a little over half of
  // it (its 0.9 s delay), the 2 Hz one has settled.
  const double deg = M_PI / 180.0, step = 114 * 0.087890625 * deg;
  EXPECT_LT(a.motion.trajectory[209].pitch_rad, 0.75 * step);
  EXPECT_NEAR(b.motion.trajectory[209].pitch_rad, step, 0.03 * step);
  // At most 0.4 of the sample rate: 2 Hz at 10 Hz stays 2 Hz; 20 Hz is taken as 4 Hz.
  EXPECT_DOUBLE_EQ(b.tilt_design.cutoff_hz, 2.0);
  fast.tilt_cutoff_hz = 20.0;
  EXPECT_NEAR(RunPosfilter(log, model, fast).tilt_design.cutoff_hz, 4.0, 1e-9);
}

// The attitude smoothed (the default): the tilts forward and backward over a fixed lag are the
// whole log's zero-phase filter away from its ends (no delay: the step's middle stays at the
// step), and the path is the filtered attitude's bit for bit (a constant speed: nothing to
// take out).
TEST(RunPosfilter, TheSmoothedAttitudeIsTheZeroPhaseFilterWithoutDelay) {
  const telemetry::SensorModel model = Model("pitch_left");
  telemetry::TelemetryLog log = OneInclinometerLog(model, telemetry::Channel::kPitchLeft);
  auto& wheel = log.counts[static_cast<int>(telemetry::Channel::kEncoderFrontLeft)];
  for (std::size_t k = 0; k < wheel.size(); ++k) wheel[k] = static_cast<double>(20 * k % 1024);  // no acceleration
  PosfilterOptions filtered;
  filtered.smooth_attitude = false;
  const PosfilterResult smooth = RunPosfilter(log, model, PosfilterOptions{});
  const PosfilterResult plain = RunPosfilter(log, model, filtered);
  EXPECT_DOUBLE_EQ(smooth.tilt_design.cutoff_hz, 1.0);  // the smoothed attitude's default
  EXPECT_DOUBLE_EQ(plain.tilt_design.cutoff_hz, 1.5);
  EXPECT_DOUBLE_EQ(smooth.attitude_lag_s, 4.0);
  const double deg = M_PI / 180.0, step = 114 * 0.087890625 * deg;
  std::vector<double> pitch;
  for (std::size_t k = 0; k < log.size(); ++k) {
    pitch.push_back(model[telemetry::Channel::kPitchLeft].ToRadians(
        static_cast<double>(log.counts[static_cast<int>(telemetry::Channel::kPitchLeft)][k])));
  }
  const std::vector<double> reference = telemetry::FilterZeroPhase(smooth.tilt_design, pitch);
  const auto& a = smooth.motion.trajectory;
  ASSERT_EQ(a.size(), log.size());
  for (std::size_t k = 100; k < 300; ++k) EXPECT_NEAR(a[k].pitch_rad, reference[k], 1e-6 * step) << k;
  // The step lies between rows 199 and 200: symmetric about it, half-way there.
  EXPECT_NEAR(a[199].pitch_rad + a[200].pitch_rad, step, 0.01 * step);
  EXPECT_LT(a[190].pitch_rad, 0.05 * step);
  EXPECT_GT(a[210].pitch_rad, 0.95 * step);
  for (std::size_t k = 0; k < a.size(); ++k) {
    ASSERT_EQ(a[k].x_m, plain.motion.trajectory[k].x_m) << k;
    ASSERT_EQ(a[k].y_m, plain.motion.trajectory[k].y_m) << k;
    ASSERT_EQ(a[k].z_m, plain.motion.trajectory[k].z_m) << k;
  }
}

// Over a log longer than the smoother's blocks (3000 rows of a pitch reading +-50 counts,
// +-4.4 deg, at random): every row within 1e-6 of that range of the whole log's forward-
// backward filter away from the log's ends, and the same values however the log is read.
TEST(RunPosfilter, TheSmoothedAttitudeAcrossBlocksIsTheWholeLogsZeroPhaseFilter) {
  const telemetry::SensorModel model = Model("pitch_left");
  telemetry::TelemetryLog log;
  log.source = "log.csv";
  std::vector<double> pitch;
  std::mt19937 random(7);
  std::uniform_int_distribution<int> reading(462, 562);
  for (int k = 0; k < 3000; ++k) {
    log.t_s.push_back(0.1 * k);
    log.line.push_back(k + 2);
    log.counts[static_cast<int>(telemetry::Channel::kEncoderFrontLeft)].push_back(static_cast<double>(20 * k % 1024));
    const double counts = reading(random);
    log.counts[static_cast<int>(telemetry::Channel::kPitchLeft)].push_back(counts);
    pitch.push_back(model[telemetry::Channel::kPitchLeft].ToRadians(counts));
  }
  PosfilterOptions options;
  options.block_rows = log.size();
  const PosfilterResult whole = RunPosfilter(log, model, options);
  const std::vector<double> reference = telemetry::FilterZeroPhase(whole.tilt_design, pitch);
  const double range = 100 * 0.087890625 * M_PI / 180.0;
  for (std::size_t k = 100; k + 100 < log.size(); ++k) {
    ASSERT_NEAR(whole.motion.trajectory[k].pitch_rad, reference[k], 1e-6 * range) << k;
  }
  for (const std::size_t block : {std::size_t{1}, std::size_t{7}, std::size_t{1024}}) {
    options.block_rows = block;
    const PosfilterResult r = RunPosfilter(log, model, options);
    for (std::size_t k = 0; k < log.size(); ++k) {
      ASSERT_EQ(r.motion.trajectory[k].pitch_rad, whole.motion.trajectory[k].pitch_rad) << block << ", row " << k;
    }
  }
}

// An inclinometer is a pendulum: on level ground a vehicle speeding up from rest at 0.2 m/s^2
// for 2 s and slowing down as much reads atan(a / g), 1.17 deg, nose up then down. The
// smoothed attitude takes the wheels' acceleration out: within 0.15 deg of level throughout;
// the filtered attitude keeps the reading.
TEST(RunPosfilter, TheSmoothedAttitudeTakesTheVehiclesAccelerationOut) {
  const telemetry::SensorModel model = Model("pitch_left");
  const telemetry::ChannelModel& tilt = model[telemetry::Channel::kPitchLeft];
  const double counts_per_m = 1.0 / model[telemetry::Channel::kEncoderFrontLeft].MetresPerCount();
  const double a = 0.2, g = 9.80665;
  telemetry::TelemetryLog log;
  log.source = "log.csv";
  for (int k = 0; k < 300; ++k) {  // 10 Hz: rest 5 s, +a 2 s, 0.4 m/s 10 s, -a 2 s, rest
    const double t = 0.1 * k;
    const double accel = t >= 5 && t < 7 ? a : t >= 17 && t < 19 ? -a : 0.0;
    double s = 0;
    if (t >= 5) s += 0.5 * a * std::pow(std::min(t, 7.0) - 5, 2);
    if (t >= 7) s += 0.4 * (std::min(t, 19.0) - 7);
    if (t >= 17) s -= 0.5 * a * std::pow(std::min(t, 19.0) - 17, 2);
    log.t_s.push_back(t);
    log.line.push_back(k + 2);
    log.counts[static_cast<int>(telemetry::Channel::kEncoderFrontLeft)].push_back(
        static_cast<double>(std::llround(s * counts_per_m) % 1024));  // a 10-bit counter
    log.counts[static_cast<int>(telemetry::Channel::kPitchLeft)].push_back(
        std::round((std::atan(accel / g) * 180 / M_PI - tilt.offset) / tilt.scale));
  }
  PosfilterOptions filtered;
  filtered.smooth_attitude = false;
  const PosfilterResult smooth = RunPosfilter(log, model, PosfilterOptions{});
  const PosfilterResult plain = RunPosfilter(log, model, filtered);
  const double deg = M_PI / 180.0, level = tilt.ToRadians(std::round(-tilt.offset / tilt.scale));
  double worst_smooth = 0, worst_plain = 0;
  for (std::size_t k = 0; k < log.size(); ++k) {
    worst_smooth = std::max(worst_smooth, std::abs(smooth.motion.trajectory[k].pitch_rad - level));
    worst_plain = std::max(worst_plain, std::abs(plain.motion.trajectory[k].pitch_rad - level));
  }
  EXPECT_LT(worst_smooth, 0.15 * deg);
  EXPECT_GT(worst_plain, 0.9 * deg);
  EXPECT_NEAR(smooth.pendulum_pitch_max_rad, std::atan(a / g), 0.2 * deg);
}

// A small skid-steered rover (0.45 m track) without a compass, 50 Hz rows: 3 s at rest, then
// cycles of 5 s straight at 0.5 m/s, 3 s of arc turning 30 deg/s right, and a turn in place
// of 45 deg/s left for 2 s, each started and stopped abruptly (1.5 m/s^2, 500 deg/s^2). Its
// four 10-bit encoders (the left ones counting down) are read every `encoder_every`-th row
// (5: at 10 Hz); the gyro (+-1 rad/s over 10 bits, 0.35 deg/s of noise) reads
// (1 + gyro_scale) times the true rate, and `spike_row`'s gyro sample 250 counts low (28 deg/s).
struct SkidSteerDrive {
  telemetry::SensorModel model = telemetry::SensorModelFromJson(nlohmann::json::parse(R"({
    "format": "lunarnav.sensors/1",
    "vehicle": {"max_speed_mps": 1.0, "max_turn_accel_dps2": 600},
    "channels": {
      "enc_fl": {"counts_per_revolution": 1024, "wheel_radius_m": 0.11, "sign": -1},
      "enc_fr": {"counts_per_revolution": 1024, "wheel_radius_m": 0.11},
      "enc_rl": {"counts_per_revolution": 1024, "wheel_radius_m": 0.11, "sign": -1},
      "enc_rr": {"counts_per_revolution": 1024, "wheel_radius_m": 0.11},
      "gyro_z": {"scale": 0.001953125, "offset": -1.0, "units": "rad/s", "noise_rms": 0.006}
    }
  })"),
                                                                "model");
  telemetry::TelemetryLog log;
  double heading_rad = 0, x_m = 0, y_m = 0;  // the truth at the end

  explicit SkidSteerDrive(int encoder_every, double gyro_scale = 0.0, int spike_row = -1) {
    const double dt = 0.02, track = 0.45;
    const double nan = std::numeric_limits<double>::quiet_NaN();
    std::mt19937 rng(3);
    std::normal_distribution<double> noise(0.0, 0.35 * M_PI / 180);
    double v = 0, w = 0;  // speed, turn rate (rad/s, positive right)
    std::array<double, 4> travel{};
    for (int k = 0; k < 50 * 43; ++k) {
      const double t = k * dt;
      const double phase = std::fmod(t - 3.0, 10.0);
      double target_v = 0, target_w = 0;
      if (t >= 3.0 && phase < 5.0) {
        target_v = 0.5;
      } else if (t >= 3.0 && phase < 8.0) {
        target_v = 0.5;
        target_w = 30 * M_PI / 180;
      } else if (t >= 3.0) {
        target_w = -45 * M_PI / 180;
      }
      if (k > 0) {
        v += std::clamp(target_v - v, -1.5 * dt, 1.5 * dt);
        w += std::clamp(target_w - w, -500 * M_PI / 180 * dt, 500 * M_PI / 180 * dt);
        x_m += v * dt * std::sin(heading_rad + 0.5 * w * dt);
        y_m += v * dt * std::cos(heading_rad + 0.5 * w * dt);
        heading_rad += w * dt;
        for (int i = 0; i < 4; ++i) travel[i] += (v + (i % 2 == 0 ? 1 : -1) * w * track / 2) * dt;  // left: outer
      }
      log.t_s.push_back(t);
      log.line.push_back(k + 2);
      using telemetry::Channel;
      const Channel wheels[4] = {Channel::kEncoderFrontLeft, Channel::kEncoderFrontRight, Channel::kEncoderRearLeft,
                                 Channel::kEncoderRearRight};
      for (int i = 0; i < 4; ++i) {
        const telemetry::ChannelModel& m = model[wheels[i]];
        const double counts = m.sign * std::floor(travel[i] / std::abs(m.MetresPerCount()));
        log.counts[static_cast<int>(wheels[i])].push_back(
            k % encoder_every == 0 ? std::fmod(std::fmod(100 * i + counts, 1024.0) + 1024.0, 1024.0) : nan);
      }
      double gyro = std::round(((1.0 + gyro_scale) * w + noise(rng) + 1.0) / 0.001953125);
      if (k == spike_row) gyro -= 250;
      log.counts[static_cast<int>(telemetry::Channel::kGyroZ)].push_back(gyro);
    }
  }
};

TEST(RunPosfilter, WithoutACompassTheGyroScaleIsHeldAtItsPrior) {
  const SkidSteerDrive drive(5, 0.05);  // the gyro reads 5 % high
  const PosfilterResult r = RunPosfilter(drive.log, drive.model, PosfilterOptions{});
  ASSERT_TRUE(r.kalman_used);
  EXPECT_EQ(r.heading.gyro_scale_error, 0.0);
  EXPECT_EQ(r.heading.gyro_scale_sigma, 0.0);
  EXPECT_NE(r.states["gyro_scale"].get<std::string>().find("held at prior"), std::string::npos);
  EXPECT_NE(r.states["gyro_bias"].get<std::string>().find("estimated from"), std::string::npos);
}

// The baseline integrates the same counts: on a clean log it ends near the filtered
// trajectory and near the truth; a budget too small for the two's difference is a warning.
TEST(RunPosfilter, TheBaselineEndsNearTheFilteredTrajectoryAndPartingIsAWarning) {
  const SkidSteerDrive drive(5);
  PosfilterOptions options;
  const PosfilterResult r = RunPosfilter(drive.log, drive.model, options);
  ASSERT_FALSE(r.baseline_trajectory.empty());
  EXPECT_EQ(r.baseline_trajectory.back().t_s, r.motion.last_pose.t_s);
  EXPECT_NEAR(r.baseline_trajectory[1].t_s - r.baseline_trajectory[0].t_s, options.baseline_interval_s, 1e-9);
  EXPECT_TRUE(r.baseline_bias_known);
  EXPECT_LT(std::hypot(r.baseline_last_pose.x_m - drive.x_m, r.baseline_last_pose.y_m - drive.y_m),
            0.03 * r.baseline_distance_m);
  EXPECT_LT(r.baseline_end_difference_m, r.baseline_expected_drift_m);
  EXPECT_TRUE(r.warnings.empty());
  EXPECT_FALSE(r.SummaryJson()["baseline"]["parted"].get<bool>());
  options.baseline_drift_fraction = 1e-6;
  options.baseline_heading_drift_dps = 0;
  const PosfilterResult tight = RunPosfilter(drive.log, drive.model, options);
  ASSERT_EQ(tight.warnings.size(), 1u);
  EXPECT_NE(tight.warnings[0].find("from the plain baseline's end"), std::string::npos);
  EXPECT_TRUE(tight.SummaryJson()["baseline"]["parted"].get<bool>());
}

// The baseline moves at its encoders' samples, so its poses are written at them: once a
// second, at the first encoder sample due (between samples its position would be the last
// sample's, stamped up to an interval later: a real log's GPS then scores it as lagging).
TEST(RunPosfilter, TheBaselineIsWrittenAtItsEncoderSamples) {
  const SkidSteerDrive drive(7);  // encoders every 0.14 s: the whole seconds fall between samples
  const PosfilterResult r = RunPosfilter(drive.log, drive.model, PosfilterOptions{});
  const std::vector<double>& enc = drive.log.counts[static_cast<int>(telemetry::Channel::kEncoderFrontLeft)];
  ASSERT_GT(r.baseline_trajectory.size(), 40u);
  for (std::size_t j = 0; j + 1 < r.baseline_trajectory.size(); ++j) {  // the last: the log's last row
    const double t = r.baseline_trajectory[j].t_s;
    const auto row = std::lower_bound(drive.log.t_s.begin(), drive.log.t_s.end(), t) - drive.log.t_s.begin();
    ASSERT_LT(row, static_cast<long>(enc.size()));
    EXPECT_FALSE(std::isnan(enc[static_cast<std::size_t>(row)])) << "baseline pose " << j << " at " << t << " s";
    if (j > 0) {
      const double gap = t - r.baseline_trajectory[j - 1].t_s;
      EXPECT_GE(gap, 1.0 - 0.14 - 1e-9) << j;
      EXPECT_LE(gap, 1.0 + 0.14 + 1e-9) << j;
    }
  }
}

TEST(RunPosfilter, AGyroSampleRejectedMidTurnLeavesTheTurn) {
  // Row 50 * 10 is 2 s into the first arc (turning at 30 deg/s); row 50 * 14 + 10 is 0.2 s into
  // the first turn in place (45 deg/s).
  for (const int spike_row : {50 * 10, 50 * 14 + 10}) {
    const SkidSteerDrive clean(5), spiked(5, 0.0, spike_row);
    const PosfilterResult a = RunPosfilter(clean.log, clean.model, PosfilterOptions{});
    const PosfilterResult b = RunPosfilter(spiked.log, spiked.model, PosfilterOptions{});
    const int gyro = static_cast<int>(telemetry::Channel::kGyroZ);
    EXPECT_EQ(b.screened.counts[static_cast<int>(telemetry::ScreeningRule::kRateLimit)][gyro] +
                  b.screened.counts[static_cast<int>(telemetry::ScreeningRule::kSpike)][gyro],
              1 + a.screened.counts[static_cast<int>(telemetry::ScreeningRule::kRateLimit)][gyro] +
                  a.screened.counts[static_cast<int>(telemetry::ScreeningRule::kSpike)][gyro]);
    // Dropping the sample's share of the turn would lose 0.6-0.9 deg; the gyro's noise over a
    // sample is 0.007 deg.
    EXPECT_NEAR(b.motion.last_pose.heading_rad, a.motion.last_pose.heading_rad, 0.05 * M_PI / 180) << spike_row;
    // And against the truth (the spike is in the reading only): the heading to within what
    // the gyro's bias, measured over 2 s at rest with 0.35 deg/s of noise, drifts in 40 s
    // (1 deg RMS; 3 sigma), the position to within that heading error over the distance.
    EXPECT_NEAR(b.motion.last_pose.heading_rad, spiked.heading_rad, 3.0 * M_PI / 180) << spike_row;
    EXPECT_LT(std::hypot(b.motion.last_pose.x_m - spiked.x_m, b.motion.last_pose.y_m - spiked.y_m),
              0.03 * b.motion.distance_m)
        << spike_row;
  }
}

TEST(RunPosfilter, EncodersAtTenHertzAndTheGyroAtFiftyIntegrateThePathOfOneCommonRate) {
  const SkidSteerDrive common(1), mixed(5);
  const PosfilterResult a = RunPosfilter(common.log, common.model, PosfilterOptions{});
  const PosfilterResult b = RunPosfilter(mixed.log, mixed.model, PosfilterOptions{});
  ASSERT_EQ(a.motion.trajectory.size(), b.motion.trajectory.size());
  double worst = 0;
  for (std::size_t k = 0; k < a.motion.trajectory.size(); ++k) {
    worst = std::max(worst, std::hypot(a.motion.trajectory[k].x_m - b.motion.trajectory[k].x_m,
                                       a.motion.trajectory[k].y_m - b.motion.trajectory[k].y_m));
  }
  EXPECT_LT(worst, 0.03) << "m apart at worst over " << a.motion.distance_m << " m";
  // And both follow the truth through the abrupt turns: the heading to within what the
  // gyro's bias, measured over 2 s at rest with 0.35 deg/s of noise, drifts in 40 s (1 deg
  // RMS); the position to within that heading error over the distance.
  for (const PosfilterResult* r : {&a, &b}) {
    EXPECT_NEAR(r->motion.last_pose.heading_rad, common.heading_rad, 3.0 * M_PI / 180);
    EXPECT_LT(std::hypot(r->motion.last_pose.x_m - common.x_m, r->motion.last_pose.y_m - common.y_m),
              0.03 * r->motion.distance_m);
  }
}

// A wheel's silence is bridged by interpolation in time: an encoder counting 8 per sample
// with 20 samples missing gives the trajectory of the complete log (and before its first
// reading, the wheel holds it).
TEST(RunPosfilter, BridgesAnEncodersGapByInterpolationInTime) {
  const telemetry::SensorModel model = Model("pitch_left");
  auto log_with_gap = [&](bool gap) {
    telemetry::TelemetryLog log = OneInclinometerLog(model, telemetry::Channel::kPitchLeft);
    std::vector<double>& enc = log.counts[static_cast<int>(telemetry::Channel::kEncoderFrontLeft)];
    for (std::size_t k = 0; k < enc.size(); ++k) {
      enc[k] = std::fmod(8.0 * static_cast<double>(k), 1024.0);  // a 10-bit counter
      if (gap && (k < 5 || (k >= 100 && k < 120))) enc[k] = std::numeric_limits<double>::quiet_NaN();
    }
    return log;
  };
  const PosfilterResult full = RunPosfilter(log_with_gap(false), model, PosfilterOptions{});
  const PosfilterResult gappy = RunPosfilter(log_with_gap(true), model, PosfilterOptions{});
  ASSERT_EQ(gappy.motion.trajectory.size(), full.motion.trajectory.size());
  const double step_m = 8.0 * model[telemetry::Channel::kEncoderFrontLeft].MetresPerCount();
  for (std::size_t k = 6; k < full.motion.trajectory.size(); ++k) {
    EXPECT_NEAR(gappy.motion.trajectory[k].speed_mps, step_m / 0.1, 1e-9) << k;
    EXPECT_NEAR(gappy.motion.trajectory[k].y_m - gappy.motion.trajectory[5].y_m,
                full.motion.trajectory[k].y_m - full.motion.trajectory[5].y_m, 1e-9) << k;
  }
  // Before the first reading the wheel holds it: no motion up to it.
  EXPECT_EQ(gappy.motion.trajectory[5].y_m, 0.0);
}

// The simulated trial A log (testdata) with channels at lower rates and gaps: every other
// compass sample missing, the gyro silent for 2 s, the left pitch missing for the first and
// last 3 s, the roll for 5 s in the middle, a wheel for 1 s, and a compass spike.
telemetry::TelemetryLog GappyLog(const telemetry::SensorModel& model) {
  telemetry::TelemetryLog log = telemetry::ReadTelemetryCsv(util::TestDataPath("telemetry/trial-a/telemetry.csv"), model);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  auto column = [&](telemetry::Channel c) -> std::vector<double>& { return log.counts[static_cast<int>(c)]; };
  const std::size_t n = log.size();
  for (std::size_t k = 0; k < n; ++k) {
    const double t = log.t_s[k] - log.t_s.front(), left = log.t_s.back() - log.t_s[k];
    if (k % 2 == 1) column(telemetry::Channel::kCompass)[k] = nan;
    if (t >= 20 && t < 22) column(telemetry::Channel::kGyroZ)[k] = nan;
    if (t < 3 || left < 3) column(telemetry::Channel::kPitchLeft)[k] = nan;
    if (t >= 40 && t < 45) column(telemetry::Channel::kRoll)[k] = nan;
    if (t >= 50 && t < 51) column(telemetry::Channel::kEncoderRearRight)[k] = nan;
  }
  column(telemetry::Channel::kCompass)[n / 2] += 60;
  return log;
}

// The sensor model of the simulated trial A log in testdata.
telemetry::SensorModel TrialASensors() {
  return telemetry::ReadSensorModel(util::TestDataPath("telemetry/trial-a/sensors.json"));
}

// Every field of two poses equal, bit for bit.
bool SamePose(const TrajectorySample& a, const TrajectorySample& b) {
  return a.t_s == b.t_s && a.x_m == b.x_m && a.y_m == b.y_m && a.z_m == b.z_m && a.heading_rad == b.heading_rad &&
         a.pitch_rad == b.pitch_rad && a.roll_rad == b.roll_rad && a.speed_mps == b.speed_mps;
}

// With a sink the poses are computed row by row and handed over without the trajectory being
// kept: they are the very poses of the kept trajectory, in every filter mode and heading
// method, on a log with gaps of every kind.
TEST(RunPosfilter, PosesToASinkAreTheKeptTrajectory) {
  const telemetry::SensorModel model = TrialASensors();
  const telemetry::TelemetryLog log = GappyLog(model);
  for (const FilterMode mode : {FilterMode::kCausal, FilterMode::kZeroPhase}) {
    for (const HeadingMethod heading : {HeadingMethod::kKalman, HeadingMethod::kLowPass}) {
      PosfilterOptions options;
      options.mode = mode;
      options.heading = heading;
      const PosfilterResult kept = RunPosfilter(log, model, options);
      std::vector<TrajectorySample> streamed;
      std::vector<Eigen::Quaterniond> attitudes;
      const PosfilterResult sunk =
          RunPosfilter(log, model, options, [&](const PoseOutput& row) {
            streamed.push_back(row.pose);
            attitudes.push_back(row.enu_from_body);
          });
      const std::string what = ToString(mode) + ", " + ToString(heading);
      ASSERT_EQ(kept.motion.trajectory.size(), log.size()) << what;
      EXPECT_TRUE(sunk.motion.trajectory.empty()) << what;
      ASSERT_EQ(streamed.size(), kept.motion.trajectory.size()) << what;
      for (std::size_t k = 0; k < streamed.size(); ++k) {
        const TrajectorySample& a = kept.motion.trajectory[k];
        ASSERT_TRUE(SamePose(a, streamed[k])) << what << ", row " << k;
        // The attitude handed over with the pose is the pose's (made from the dead
        // reckoning's half angles instead of the angles: equal to rounding).
        const Eigen::Quaterniond q = EnuFromBody(a.heading_rad, a.pitch_rad, a.roll_rad);
        ASSERT_LT(attitudes[k].angularDistance(q), 1e-12) << what << ", row " << k;
      }
      EXPECT_EQ(sunk.motion.last_pose.x_m, kept.motion.trajectory.back().x_m) << what;
      EXPECT_EQ(sunk.motion.distance_m, kept.motion.distance_m) << what;
      EXPECT_GT(kept.motion.distance_m, 10.0) << what;
      EXPECT_EQ(sunk.SummaryJson().dump(), kept.SummaryJson().dump()) << what;
      // The gaps were filled, not dropped: every row has a finite pose.
      for (const TrajectorySample& p : streamed) ASSERT_TRUE(std::isfinite(p.x_m + p.pitch_rad + p.roll_rad));
    }
  }
}

// The simulated trial A (testdata: a compass, a gyro with a scale error, turns): the heading
// smoothed over the default lag follows the truth closer than the filter alone, which learns
// the gyro's scale from the compass only after each turn; summary.json says by how much the
// smoother moved it.
TEST(RunPosfilter, TheSmoothedHeadingFollowsTheTruthCloserThanTheFilter) {
  const telemetry::SensorModel model = TrialASensors();
  const telemetry::TelemetryLog log =
      telemetry::ReadTelemetryCsv(util::TestDataPath("telemetry/trial-a/telemetry.csv"), model);
  // The truth: its CSV has posfilter's trajectory columns first.
  const std::vector<TrajectorySample> truth = ReadTrajectoryCsv(util::TestDataPath("telemetry/trial-a/truth.csv"));
  ASSERT_GT(truth.size(), 1000u);
  auto heading_errors = [&](const PosfilterResult& r, double* rms, double* largest) {
    double sum = 0;
    *largest = 0;
    std::size_t j = 0, n = 0;
    for (const TrajectorySample& p : r.motion.trajectory) {
      while (j + 1 < truth.size() && truth[j + 1].t_s <= p.t_s + 1e-9) ++j;
      if (std::abs(truth[j].t_s - p.t_s) > 1e-6) continue;
      const double e = std::remainder((p.heading_rad - truth[j].heading_rad) * 180.0 / M_PI, 360.0);
      sum += e * e;
      *largest = std::max(*largest, std::abs(e));
      ++n;
    }
    ASSERT_GT(n, 1000u);
    *rms = std::sqrt(sum / static_cast<double>(n));
  };
  PosfilterOptions options;
  const PosfilterResult smoothed = RunPosfilter(log, model, options);
  options.heading_lag_s = 0;
  const PosfilterResult filtered = RunPosfilter(log, model, options);
  double rms_smoothed = 0, largest_smoothed = 0, rms_filtered = 0, largest_filtered = 0;
  heading_errors(smoothed, &rms_smoothed, &largest_smoothed);
  heading_errors(filtered, &rms_filtered, &largest_filtered);
  // Measured when written: RMS 0.69 deg (largest 2.1) against 1.00 (5.3).
  EXPECT_LT(rms_smoothed, 0.8 * rms_filtered) << rms_smoothed << " vs " << rms_filtered;
  EXPECT_LT(largest_smoothed, 0.6 * largest_filtered) << largest_smoothed << " vs " << largest_filtered;
  const nlohmann::json summary = smoothed.SummaryJson();
  EXPECT_TRUE(summary["heading_kalman"]["smoothed"].get<bool>());
  EXPECT_GT(summary["heading_kalman"]["smoother_correction_max_deg"].get<double>(), 1.0);
  EXPECT_FALSE(filtered.SummaryJson()["heading_kalman"]["smoothed"].get<bool>());
}

// The log is read a block at a time, each row run as soon as its look-ahead is known: the
// results do not depend on the block size, in either filter mode, with the heading smoothed
// over the default lag (longer than this log), over one shorter than it (5 s, 50 rows: the
// smoother's fixed blocks of rows, two over the 1280), or not smoothed.
TEST(RunPosfilter, ResultsDoNotDependOnTheBlockSize) {
  const telemetry::SensorModel model = TrialASensors();
  const telemetry::TelemetryLog log = GappyLog(model);
  for (const auto& [mode, heading_lag_s] : {std::pair{FilterMode::kCausal, 60.0}, std::pair{FilterMode::kCausal, 5.0},
                                            std::pair{FilterMode::kCausal, 0.0}, std::pair{FilterMode::kZeroPhase, 60.0}}) {
    PosfilterOptions options;
    options.mode = mode;
    options.heading_lag_s = heading_lag_s;
    options.screening.statistics_intervals = 200;  // shorter than the log
    options.block_rows = log.size();
    const PosfilterResult whole = RunPosfilter(log, model, options);
    for (const std::size_t block : {std::size_t{1}, std::size_t{5}, std::size_t{1024}}) {
      options.block_rows = block;
      const PosfilterResult r = RunPosfilter(log, model, options);
      const std::string what =
          ToString(mode) + ", heading lag " + std::to_string(heading_lag_s) + " s, blocks of " + std::to_string(block);
      ASSERT_EQ(r.motion.trajectory.size(), whole.motion.trajectory.size()) << what;
      for (std::size_t k = 0; k < r.motion.trajectory.size(); ++k) {
        ASSERT_TRUE(SamePose(r.motion.trajectory[k], whole.motion.trajectory[k])) << what << ", row " << k;
      }
      EXPECT_EQ(r.SummaryJson().dump(), whole.SummaryJson().dump()) << what;
      EXPECT_EQ(r.screened.events.size(), whole.screened.events.size()) << what;
    }
  }
}

}  // namespace
}  // namespace lunarnav::positioning
