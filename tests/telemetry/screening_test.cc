#include "telemetry/screening.h"
#include <fstream>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "util/testing.h"

namespace lunarnav::telemetry {
namespace {

// A rover driving at 0.5 m/s and turning at 6 deg/s for 60 s, logged at 10 Hz by the sensors
// of testdata/telemetry/ratler_sensors.json (10-bit counts, 10-bit wrapping encoders).
struct Scenario {
  SensorModel model = ReadSensorModel(util::TestDataPath("telemetry/ratler_sensors.json"));
  TelemetryLog log;

  // noise: Gaussian sensor noise in counts on the analog channels (clean data is noisy).
  explicit Scenario(double noise = 1.5) {
    std::mt19937 rng(11);
    std::normal_distribution<double> gauss(0.0, noise);
    const int n = 600;
    for (int i = 0; i < n; ++i) {
      const double t = 0.1 * i;
      log.t_s.push_back(t);
      log.line.push_back(i + 2);
      const double heading_deg = std::fmod(30.0 + 6.0 * t, 360.0);
      const double distance_m = 0.5 * t;
      Set(Channel::kCompass, std::fmod(std::round(heading_deg / 0.3515625 + gauss(rng)) + 1024, 1024));
      Set(Channel::kGyroZ, std::round((6.0 + 60.0) / 0.1171875 + gauss(rng)));
      for (Channel e : {Channel::kEncoderFrontLeft, Channel::kEncoderFrontRight,
                        Channel::kEncoderRearLeft, Channel::kEncoderRearRight}) {
        Set(e, std::fmod(std::round(distance_m / model[e].MetresPerCount()), 1024.0));
      }
      Set(Channel::kPitchLeft, std::round(535 + gauss(rng)));
      Set(Channel::kPitchRight, std::round(535 + (i / 20) % 2 + gauss(rng)));  // a little rocking
      Set(Channel::kRoll, std::round(512 + gauss(rng)));
    }
  }
  void Set(Channel c, double count) { log.counts[static_cast<int>(c)].push_back(count); }
  double& At(Channel c, int i) { return log.counts[static_cast<int>(c)][i]; }
  ScreenedLog Screen() const { return ScreenTelemetry(log, model, ScreeningOptions{}); }
};

long Rejections(const ScreenedLog& s) {
  return static_cast<long>(s.events.size()) - s.Count(ScreeningRule::kEncoderWrap);
}

TEST(ScreenTelemetry, LeavesCleanDataUntouchedAndUnwrapsEncoders) {
  Scenario sc;
  const ScreenedLog s = sc.Screen();
  EXPECT_EQ(Rejections(s), 0) << s.ReportJson().dump();
  EXPECT_EQ(s.t_s.size(), 600u);
  // 30 m at 0.00614 m/count = 4890 counts: four wraps of the 10-bit counter per wheel.
  EXPECT_EQ(s.Count(ScreeningRule::kEncoderWrap), 4 * 4);
  const auto& fl = s.value[static_cast<int>(Channel::kEncoderFrontLeft)];
  const double metres = (fl.back() - fl.front()) * sc.model[Channel::kEncoderFrontLeft].MetresPerCount();
  EXPECT_NEAR(metres, 0.5 * 59.9, 0.01);
  // The compass is continuous across 360 -> 0: 6 deg/s for 59.9 s.
  const auto& compass = s.value[static_cast<int>(Channel::kCompass)];
  EXPECT_NEAR((compass.back() - compass.front()) * 180 / M_PI, 6.0 * 59.9, 1.5);
}

TEST(ScreenTelemetry, EachRuleCatchesItsFault) {
  {
    Scenario sc;  // a moderate spike: within the rate limit, caught by the Hampel test
    sc.At(Channel::kCompass, 300) += 23;
    const ScreenedLog s = sc.Screen();
    EXPECT_EQ(s.Count(ScreeningRule::kSpike), 1);
    EXPECT_EQ(Rejections(s), 1);
    EXPECT_TRUE(std::isnan(s.value[static_cast<int>(Channel::kCompass)][300]));
  }
  {
    Scenario sc;  // a wild value: faster than any turn
    sc.At(Channel::kCompass, 300) += 300;
    const ScreenedLog s = sc.Screen();
    EXPECT_EQ(s.Count(ScreeningRule::kRateLimit), 1);
    EXPECT_EQ(Rejections(s), 1);
  }
  {
    Scenario sc;  // the compass freezes for 5 s while the gyro says the rover turns
    for (int i = 200; i < 250; ++i) sc.At(Channel::kCompass, i) = sc.At(Channel::kCompass, 199);
    const ScreenedLog s = sc.Screen();
    EXPECT_GE(s.Count(ScreeningRule::kStuck), 45);
    EXPECT_EQ(s.counts[static_cast<int>(ScreeningRule::kStuck)][static_cast<int>(Channel::kCompass)],
              s.Count(ScreeningRule::kStuck));
  }
  {
    Scenario sc;  // one encoder stops counting while the others go on (a broken encoder)
    for (int i = 300; i < 360; ++i) sc.At(Channel::kEncoderRearLeft, i) = sc.At(Channel::kEncoderRearLeft, 299);
    const ScreenedLog s = sc.Screen();
    EXPECT_GE(s.counts[static_cast<int>(ScreeningRule::kStuck)][static_cast<int>(Channel::kEncoderRearLeft)], 55);
  }
  {
    Scenario sc;  // the gyro is silent for 3 s
    for (int i = 100; i < 130; ++i) sc.At(Channel::kGyroZ, i) = std::nan("");
    const ScreenedLog s = sc.Screen();
    EXPECT_EQ(s.Count(ScreeningRule::kDropout), 1);
    EXPECT_EQ(Rejections(s), 1);
  }
  {
    Scenario sc;  // rails and the valid range
    sc.At(Channel::kRoll, 50) = 1023;
    sc.At(Channel::kPitchLeft, 60) = 0;
    sc.At(Channel::kEncoderFrontRight, 70) = 2000;  // beyond the 10-bit counter
    const ScreenedLog s = sc.Screen();
    EXPECT_EQ(s.Count(ScreeningRule::kAtRail), 2);
    EXPECT_EQ(s.Count(ScreeningRule::kOutOfRange), 1);
    EXPECT_EQ(Rejections(s), 3);
  }
  {
    Scenario sc;  // time stamps: a repeat, one out of order, and a 2 s hole
    sc.log.t_s[101] = sc.log.t_s[100];
    std::swap(sc.log.t_s[201], sc.log.t_s[202]);
    for (int i = 400; i < 420; ++i) sc.log.t_s[i] = sc.log.t_s[399] + 2.0 + 0.1 * (i - 400) + 0.001;
    for (int i = 420; i < 600; ++i) sc.log.t_s[i] += 2.0;
    const ScreenedLog s = sc.Screen();
    EXPECT_EQ(s.Count(ScreeningRule::kRepeatedTimestamp), 1);
    EXPECT_EQ(s.Count(ScreeningRule::kOutOfOrderTimestamp), 1);
    EXPECT_EQ(s.Count(ScreeningRule::kGap), 1);
    for (std::size_t k = 1; k < s.t_s.size(); ++k) ASSERT_GT(s.t_s[k], s.t_s[k - 1]);
  }
}

// The rows [from, to) of a log, as a reader hands over a block.
TelemetryLog Slice(const TelemetryLog& log, std::size_t from, std::size_t to) {
  TelemetryLog block;
  block.t_s.assign(log.t_s.begin() + from, log.t_s.begin() + to);
  block.line.assign(log.line.begin() + from, log.line.begin() + to);
  for (int c = 0; c < kNumChannels; ++c) {
    if (!log.counts[c].empty()) block.counts[c].assign(log.counts[c].begin() + from, log.counts[c].begin() + to);
  }
  return block;
}

// Screening a log block by block, each row taken when final and released, gives the whole
// log's screening row for row (every value, event and count), whatever the block size; and
// the rows waiting for their look-ahead stay few: the spike test's next samples, the
// longest stuck run, the statistics window at the start.
// A small skid-steered rover at 50 Hz: pitch from an accelerometer that vibrates (1.5 deg RMS)
// and a gyro through turns started and stopped at 500 deg/s^2 (0 to 45 deg/s in 0.09 s).
struct VibratingLog {
  SensorModel model = SensorModelFromJson(nlohmann::json::parse(R"({
    "format": "lunarnav.sensors/1",
    "channels": {
      "enc_fl": {"counts_per_revolution": 1024, "wheel_radius_m": 0.11},
      "pitch_left": {"scale": 0.05859375, "offset": -30.0, "units": "deg"},
      "gyro_z": {"scale": 0.001953125, "offset": -1.0, "units": "rad/s"}
    }
  })"),
                                          "model");
  TelemetryLog log;
  VibratingLog() {
    std::mt19937 rng(5);
    std::normal_distribution<double> gauss(0.0, 1.0);
    double rate_dps = 0, travel_m = 0;
    for (int i = 0; i < 3000; ++i) {  // 60 s
      const double t = 0.02 * i;
      const double phase = std::fmod(t, 6.0);  // turning for 2 s of every 6
      const double target = phase < 2.0 ? 45.0 : 0.0;
      rate_dps += std::clamp(target - rate_dps, -500.0 * 0.02, 500.0 * 0.02);
      travel_m += 0.5 * 0.02;
      log.t_s.push_back(t);
      log.line.push_back(i + 2);
      log.counts[static_cast<int>(Channel::kEncoderFrontLeft)].push_back(
          std::fmod(std::floor(travel_m / model[Channel::kEncoderFrontLeft].MetresPerCount()), 1024.0));
      log.counts[static_cast<int>(Channel::kPitchLeft)].push_back(
          std::round((2.0 + 1.5 * gauss(rng) + 30.0) / 0.05859375));
      log.counts[static_cast<int>(Channel::kGyroZ)].push_back(
          std::round((rate_dps * M_PI / 180 + 0.006 * gauss(rng) + 1.0) / 0.001953125));
    }
  }
};

TEST(ScreenTelemetry, RateLimitsDeriveFromTheVehiclesLimitsAndTheSensorsNoise) {
  VibratingLog v;
  const int pitch = static_cast<int>(Channel::kPitchLeft), gyro = static_cast<int>(Channel::kGyroZ);
  const int rate_limit = static_cast<int>(ScreeningRule::kRateLimit);
  {  // Limits that ignore the vibration and the abrupt turns (no noise stated, none estimated):
     // the rules reject real motion and noise by the thousand, and say so.
    SensorModel m = v.model;
    m.vehicle.max_turn_accel_dps2 = 180.0;
    ScreeningOptions options;
    options.estimate_missing_noise = false;
    const ScreenedLog s = ScreenTelemetry(v.log, m, options);
    EXPECT_EQ(s.samples[pitch], 3000);
    EXPECT_GT(s.counts[rate_limit][pitch], 300);
    EXPECT_GT(s.counts[rate_limit][gyro], 10);
    bool pitch_warned = false;
    for (const ScreenedLog::Share& w : s.Warnings()) {
      pitch_warned = pitch_warned || (w.channel == pitch && w.rule == ScreeningRule::kRateLimit);
      EXPECT_GT(w.share, s.warning_share);
    }
    EXPECT_TRUE(pitch_warned);
    EXPECT_FALSE(s.ReportJson()["warnings"].empty());
  }
  {  // The sensor file states the noise and the vehicle's angular acceleration: nothing
     // real is rejected, and no warning.
    SensorModel m = v.model;
    m[Channel::kPitchLeft].noise_rms = 1.5;
    m[Channel::kGyroZ].noise_rms = 0.006;
    m.vehicle.max_turn_accel_dps2 = 600.0;
    const ScreenedLog s = ScreenTelemetry(v.log, m, ScreeningOptions{});
    EXPECT_EQ(s.counts[rate_limit][pitch], 0);
    EXPECT_EQ(s.counts[rate_limit][gyro], 0);
    EXPECT_NEAR(s.rate_limit[gyro] * 180 / M_PI, 600.0, 1e-9);
    EXPECT_TRUE(s.Warnings().empty()) << s.ReportJson()["warnings"].dump();
    for (const ScreenedLog::Share& share : s.RejectionShares()) EXPECT_LT(share.share, s.warning_share);
    EXPECT_FALSE(s.rate_noise_from_log[pitch]);
    EXPECT_DOUBLE_EQ(s.rate_noise[pitch] * 180 / M_PI, 1.5);
  }
  {  // No noise stated: it is estimated from the log (1.5 deg and 0.006 rad/s, quantised),
     // and again nothing real is rejected.
    SensorModel m = v.model;
    m.vehicle.max_turn_accel_dps2 = 600.0;
    const ScreenedLog s = ScreenTelemetry(v.log, m, ScreeningOptions{});
    EXPECT_TRUE(s.rate_noise_from_log[pitch]);
    EXPECT_TRUE(s.rate_noise_from_log[gyro]);
    EXPECT_NEAR(s.rate_noise[pitch] * 180 / M_PI, 1.5, 0.15);
    EXPECT_NEAR(s.rate_noise[gyro], 0.006, 0.0006);
    EXPECT_EQ(s.counts[rate_limit][pitch], 0);
    EXPECT_EQ(s.counts[rate_limit][gyro], 0);
    EXPECT_TRUE(s.Warnings().empty()) << s.ReportJson()["warnings"].dump();
    EXPECT_EQ(s.ReportJson()["rate_limits"]["pitch_left"]["noise_from"], "log");
  }
}

// An accelerometer's tilt on a rover driving over rough and smooth ground in turn, as a real
// log shows it: 0.3 deg of noise on smooth ground, 2.5 deg in bursts on rough ground (a third
// of the time), the noise not stated in the sensor file. The rate limit's noise from the log
// takes the bursts' scale, not the smooth ground's median, so under 1 % of the real samples
// are rejected; a fault far beyond the vibration is still caught.
TEST(ScreenTelemetry, RateLimitNoiseFromALogOfVibrationBurstsTakesTheBurstsScale) {
  VibratingLog v;
  const int pitch = static_cast<int>(Channel::kPitchLeft);
  std::vector<double>& counts = v.log.counts[pitch];
  std::mt19937 rng(17);
  std::normal_distribution<double> gauss(0.0, 1.0);
  for (std::size_t i = 0; i < counts.size(); ++i) {
    const bool rough = (i / 250) % 3 == 0;  // 5 s of rough ground in every 15
    counts[i] = std::round((2.0 + (rough ? 2.5 : 0.3) * gauss(rng) + 30.0) / 0.05859375);
  }
  SensorModel m = v.model;
  m.vehicle.max_turn_accel_dps2 = 600.0;
  const int rate_limit = static_cast<int>(ScreeningRule::kRateLimit);
  const ScreenedLog clean = ScreenTelemetry(v.log, m, ScreeningOptions{});
  EXPECT_TRUE(clean.rate_noise_from_log[pitch]);
  EXPECT_GT(clean.rate_noise[pitch] * 180 / M_PI, 1.0);  // the median alone reads the smooth ground's
  EXPECT_LT(clean.counts[rate_limit][pitch], 0.01 * 3000);
  for (const ScreenedLog::Share& share : clean.RejectionShares()) EXPECT_LT(share.share, 0.01);
  // A tilt sensor's fault, 40 deg off for one sample, in the rough and in the smooth part.
  for (const std::size_t i : {100, 1100}) counts[i] += 40.0 / 0.05859375;
  const ScreenedLog faulty = ScreenTelemetry(v.log, m, ScreeningOptions{});
  for (const std::size_t i : {100, 1100}) {
    EXPECT_TRUE(std::isnan(faulty.value[pitch][i])) << "sample " << i << " accepted";
  }
}

// A turn started and stopped faster than the sensor file's limit (1500 deg/s^2: 0 to 45 deg/s
// in 0.03 s, where max_turn_accel_dps2 says 500): the first samples of each change are too
// fast for the limit from the last accepted sample, but the samples after them go on from
// them within it, so they are the turn, not a fault, and every one is kept: the gyro's
// integral is the whole turn. A fault as large, one sample off and back, is still rejected.
TEST(ScreenTelemetry, RateLimitKeepsAJoltThatTheNextSamplesConfirm) {
  VibratingLog v;
  const int gyro = static_cast<int>(Channel::kGyroZ);
  std::vector<double>& counts = v.log.counts[gyro];
  double rate_dps = 0, true_turn_deg = 0;
  for (std::size_t i = 0; i < counts.size(); ++i) {
    const double phase = std::fmod(0.02 * static_cast<double>(i), 6.0);
    rate_dps += std::clamp((phase >= 1.0 && phase < 3.0 ? 45.0 : 0.0) - rate_dps, -1500.0 * 0.02, 1500.0 * 0.02);
    true_turn_deg += rate_dps * 0.02;
    counts[i] = std::round((rate_dps * M_PI / 180 + 1.0) / 0.001953125);
  }
  SensorModel m = v.model;
  m[Channel::kGyroZ].noise_rms = 0.006;
  m.vehicle.max_turn_accel_dps2 = 500.0;
  const int rate_limit = static_cast<int>(ScreeningRule::kRateLimit);
  const ScreenedLog s = ScreenTelemetry(v.log, m, ScreeningOptions{});
  EXPECT_EQ(s.counts[rate_limit][gyro], 0);
  double turn_deg = 0;
  for (std::size_t k = 0; k < s.value[gyro].size(); ++k) {
    ASSERT_FALSE(std::isnan(s.value[gyro][k])) << "row " << k;
    turn_deg += s.value[gyro][k] * 180 / M_PI * 0.02;
  }
  EXPECT_NEAR(turn_deg, true_turn_deg, 0.5);  // quantisation: 0.11 deg/s a count
  // A fault of the same size: one sample 30 deg/s off, at rest (4 s into a 6 s cycle).
  counts[1100] += std::round(30.0 * M_PI / 180 / 0.001953125);
  const ScreenedLog faulty = ScreenTelemetry(v.log, m, ScreeningOptions{});
  EXPECT_EQ(faulty.counts[rate_limit][gyro], 1);
  EXPECT_TRUE(std::isnan(faulty.value[gyro][1100]));
}

TEST(ScreeningStream, BlocksAndReleasesGiveTheWholeLogsResult) {
  Scenario sc;
  sc.At(Channel::kCompass, 300) += 23;                                            // spike
  for (int i = 200; i < 250; ++i) sc.At(Channel::kCompass, i) = sc.At(Channel::kCompass, 199);  // stuck
  for (int i = 400; i < 460; ++i) sc.At(Channel::kEncoderRearLeft, i) = sc.At(Channel::kEncoderRearLeft, 399);
  for (int i = 100; i < 130; ++i) sc.At(Channel::kGyroZ, i) = std::nan("");      // dropout
  for (int i = 0; i < 600; i += 2) sc.At(Channel::kRoll, i) = std::nan("");      // half rate
  sc.At(Channel::kPitchLeft, 60) = 0;                                             // rail
  for (int i = 350; i < 360; ++i) sc.At(Channel::kPitchRight, i) += 200;          // jolt: kept
  sc.log.t_s[151] = sc.log.t_s[150];                                              // repeat
  std::swap(sc.log.t_s[501], sc.log.t_s[502]);                                    // out of order
  ScreeningOptions options;
  options.statistics_intervals = 100;  // a window shorter than the log
  const ScreenedLog whole = ScreenTelemetry(sc.log, sc.model, options);
  ASSERT_GT(whole.events.size(), 100u);
  for (std::size_t k = 348; k < 362; ++k) {  // (one row dropped before: the repeated time stamp)
    EXPECT_FALSE(std::isnan(whole.value[static_cast<int>(Channel::kPitchRight)][k])) << "jolt row " << k;
  }
  std::array<bool, kNumChannels> present{};
  for (Channel c : kAllChannels) present[static_cast<int>(c)] = sc.log.Has(c);
  for (const std::size_t block : {std::size_t{1}, std::size_t{7}, std::size_t{64}}) {
    ScreeningStream stream(sc.model, options, present);
    std::array<std::vector<double>, kNumChannels> value;
    std::vector<double> t;
    std::size_t taken = 0, most_waiting = 0;
    auto take = [&] {
      for (; taken < stream.final_end(); ++taken) {
        t.push_back(stream.t(taken));
        for (Channel c : kAllChannels) value[static_cast<int>(c)].push_back(stream.value(c, taken));
      }
      stream.Release(taken);
    };
    for (std::size_t from = 0; from < sc.log.size(); from += block) {
      stream.Push(Slice(sc.log, from, std::min(from + block, sc.log.size())));
      if (stream.end() > 101) most_waiting = std::max(most_waiting, stream.end() - stream.final_end());
      take();
    }
    stream.Finish();
    take();
    const std::string what = "blocks of " + std::to_string(block);
    ASSERT_EQ(t, whole.t_s) << what;
    for (Channel c : kAllChannels) {
      const std::vector<double>& a = value[static_cast<int>(c)];
      const std::vector<double>& b = whole.value[static_cast<int>(c)];
      for (std::size_t k = 0; k < b.size(); ++k) {
        ASSERT_TRUE(a[k] == b[k] || (std::isnan(a[k]) && std::isnan(b[k]))) << what << ", " << ToString(c) << " row " << k;
      }
    }
    const ScreenedLog& report = stream.report();
    EXPECT_EQ(report.counts, whole.counts) << what;
    ASSERT_EQ(report.events.size(), whole.events.size()) << what;
    for (std::size_t i = 0; i < whole.events.size(); ++i) {
      EXPECT_TRUE(report.events[i].line == whole.events[i].line && report.events[i].rule == whole.events[i].rule &&
                  report.events[i].channel == whole.events[i].channel)
          << what << ", event " << i;
    }
    // The longest wait: the encoder stuck for 6 s (61 rows to see it end), then the
    // half-rate roll's next three samples (6 rows) for its spike test; plus a block.
    EXPECT_LE(most_waiting, 61 + 6 + block) << what;
  }
}

// A channel with fewer than three samples in the statistics window takes its typical
// interval from its first three: the compass starts at row 100 of a log whose window is
// the first 16 intervals; its 3 s silence later is its only dropout.
TEST(ScreeningStream, AChannelStartingLateTakesItsIntervalFromItsFirstSamples) {
  Scenario sc;
  for (int i = 0; i < 100; ++i) sc.At(Channel::kCompass, i) = std::nan("");
  for (int i = 300; i < 330; ++i) sc.At(Channel::kCompass, i) = std::nan("");
  ScreeningOptions options;
  options.statistics_intervals = 16;
  const ScreenedLog s = ScreenTelemetry(sc.log, sc.model, options);
  EXPECT_EQ(s.counts[static_cast<int>(ScreeningRule::kDropout)][static_cast<int>(Channel::kCompass)], 1);
  EXPECT_EQ(s.Count(ScreeningRule::kDropout), 1);
  EXPECT_NEAR(s.typical_interval_s, 0.1, 1e-12);
}

TEST(WriteScreeningLog, ListsEveryEventWithItsLine) {
  Scenario sc;
  sc.At(Channel::kRoll, 50) = 1023;
  const ScreenedLog s = sc.Screen();
  util::ScopedTempDir tmp;
  WriteScreeningLog(tmp.path() / "screening.csv", s);
  std::ifstream in(tmp.path() / "screening.csv");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("52,5,roll,at_rail,1023"), std::string::npos) << text;
}

}  // namespace
}  // namespace lunarnav::telemetry
