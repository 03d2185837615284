#include "positioning/posfilter.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

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
        std::round(0.05 * k * counts_per_m));
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
  const PosfilterResult left = RunPosfilter(OneInclinometerLog(left_model, telemetry::Channel::kPitchLeft),
                                            left_model, PosfilterOptions{});
  const PosfilterResult right = RunPosfilter(OneInclinometerLog(right_model, telemetry::Channel::kPitchRight),
                                             right_model, PosfilterOptions{});
  const auto& a = left.motion.trajectory;
  const auto& b = right.motion.trajectory;
  ASSERT_EQ(a.size(), 400u);
  ASSERT_EQ(b.size(), a.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].pitch_rad, b[k].pitch_rad) << k;
    EXPECT_EQ(a[k].z_m, b[k].z_m) << k;
  }
  // Filtered: the step's first sample moves the pitch by far less than the step (10 deg).
  const double deg = M_PI / 180.0;
  EXPECT_LT(b[200].pitch_rad - b[199].pitch_rad, 1.0 * deg);
  EXPECT_NEAR(b.back().pitch_rad, 114 * 0.087890625 * deg, 0.001 * deg);
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

// The log is read a block at a time, each row run as soon as its look-ahead is known: the
// results do not depend on the block size, in either filter mode.
TEST(RunPosfilter, ResultsDoNotDependOnTheBlockSize) {
  const telemetry::SensorModel model = TrialASensors();
  const telemetry::TelemetryLog log = GappyLog(model);
  for (const FilterMode mode : {FilterMode::kCausal, FilterMode::kZeroPhase}) {
    PosfilterOptions options;
    options.mode = mode;
    options.screening.statistics_intervals = 200;  // shorter than the log
    options.block_rows = log.size();
    const PosfilterResult whole = RunPosfilter(log, model, options);
    for (const std::size_t block : {std::size_t{1}, std::size_t{5}, std::size_t{1024}}) {
      options.block_rows = block;
      const PosfilterResult r = RunPosfilter(log, model, options);
      const std::string what = ToString(mode) + ", blocks of " + std::to_string(block);
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
