#include "sim/rover_telemetry.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>

#include "io/json_io.h"
#include "util/testing.h"

namespace lunarnav::sim {
namespace {

constexpr double kDeg = M_PI / 180.0;

namespace fs = std::filesystem;
constexpr const char* kOutputs[] = {"telemetry.csv", "sensors.json", "truth.csv", "trials.json", "faults.csv"};

std::string Slurp(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void Write(const RoverTelemetryOptions& options, const fs::path& dir) {
  WriteRoverTelemetry(dir, SimulateRoverTelemetry(options), options);
}

TEST(SimulateRoverTelemetry, SameSeedSameBytesOtherSeedOtherBytes) {
  RoverTelemetryOptions options;
  options.preset = TelemetryPreset::kTraverse;
  options.duration_s = 120;
  options.faults = ParseFaultSpecs("timestamps");
  options.faults.push_back(ParseFaultSpec("spikes*2"));
  util::ScopedTempDir a, b, c;
  Write(options, a.path());
  Write(options, b.path());
  options.seed = 2;
  Write(options, c.path());
  for (const char* name : kOutputs) {
    const std::string first = Slurp(a.path() / name);
    ASSERT_FALSE(first.empty()) << name;
    EXPECT_EQ(first, Slurp(b.path() / name)) << name;
  }
  for (const char* name : {"telemetry.csv", "truth.csv", "trials.json", "faults.csv"}) {
    EXPECT_NE(Slurp(a.path() / name), Slurp(c.path() / name)) << name;
  }
}

TEST(SimulateRoverTelemetry, AddingFaultsLeavesTheRestOfTheRunAlone) {
  RoverTelemetryOptions options;
  options.preset = TelemetryPreset::kTrialB;
  const RoverTelemetry clean = SimulateRoverTelemetry(options);
  options.faults = {ParseFaultSpec("spike:compass@20")};
  const RoverTelemetry faulty = SimulateRoverTelemetry(options);
  ASSERT_EQ(faulty.faults.size(), 1u);
  int differing_cells = 0;
  for (std::size_t r = 0; r < clean.raw.size(); ++r) {
    for (int c = 0; c < telemetry::kNumChannels; ++c) differing_cells += clean.raw.counts[r][c] != faulty.raw.counts[r][c];
  }
  EXPECT_EQ(differing_cells, 1);
}

TEST(SimulateRoverTelemetry, TrialsAreFromRestToRestWithTheTruePoses) {
  RoverTelemetryOptions options;
  options.preset = TelemetryPreset::kTrialA;
  const RoverTelemetry run = SimulateRoverTelemetry(options);
  const nlohmann::json trials = TrialsJson(run);
  EXPECT_EQ(trials["format"], "lunarnav.trials/1");
  ASSERT_EQ(trials["trials"].size(), 6u);  // six straight lines
  EXPECT_EQ(trials["trials_truncated"], 0);
  const double commanded[6] = {4, 6, 8, 4, 6, 8};
  for (int i = 0; i < 6; ++i) {
    const nlohmann::json& t = trials["trials"][i];
    SCOPED_TRACE(t.dump());
    const std::size_t start = run.drive.trials[i].start_sample, end = run.drive.trials[i].end_sample;
    EXPECT_EQ(t["start"]["line"], TelemetryCsvLine(start));
    EXPECT_EQ(t["end"]["line"], TelemetryCsvLine(end));
    const auto moving = [&](std::size_t k) {
      return run.drive.samples[k].speed_mps != 0 || run.drive.samples[k].turn_rate_radps != 0;
    };
    EXPECT_FALSE(moving(start));
    EXPECT_TRUE(moving(start + 1));
    EXPECT_TRUE(moving(end - 1));
    EXPECT_FALSE(moving(end));
    for (std::size_t k = end; k <= run.drive.trials[i].rest_until_sample; ++k) EXPECT_FALSE(moving(k));
    EXPECT_NEAR(t["end"]["x_m"].get<double>(), run.drive.samples[end].x_m, 5e-4);
    EXPECT_NEAR(t["end"]["y_m"].get<double>(), run.drive.samples[end].y_m, 5e-4);
    EXPECT_EQ(t["commanded"]["path_length_m"], commanded[i]);
    // The rover drives the commanded length along the ground; the tape measure reads the
    // straight line between the poses, shorter by the wander and the slope.
    EXPECT_NEAR(t["measured"]["path_length_m"].get<double>(), commanded[i], 0.01);
    EXPECT_LE(t["measured"]["distance_m"].get<double>(), commanded[i] + 0.01);
    EXPECT_GT(t["measured"]["distance_m"].get<double>(), 0.95 * commanded[i]);
    const double dx = t["end"]["x_m"].get<double>() - t["start"]["x_m"].get<double>();
    const double dy = t["end"]["y_m"].get<double>() - t["start"]["y_m"].get<double>();
    EXPECT_NEAR(std::hypot(dx, dy), t["measured"]["distance_m"].get<double>(), 2e-3);
  }
}

TEST(SimulateRoverTelemetry, EveryPresetRunsAndDescribesItself) {
  for (const auto& [name, preset] : TelemetryPresetNames()) {
    RoverTelemetryOptions options;
    options.preset = preset;
    options.duration_s = 100;
    const RoverTelemetry run = SimulateRoverTelemetry(options);
    EXPECT_EQ(run.scenario.name, name);
    // The skid-steer presets' rows are at the IMU's 50 Hz, the others' at --rate.
    const std::size_t rows = run.scenario.mems ? 5001u : 1001u;
    EXPECT_EQ(run.raw.size(), rows) << name;
    EXPECT_GT(run.drive.samples.back().distance_m, 10.0) << name;
    EXPECT_FALSE(run.scenario.description.empty());
    EXPECT_EQ(run.CountsJson()["rows"], rows);
  }
  // The trials end by themselves without --duration.
  RoverTelemetryOptions options;
  options.preset = TelemetryPreset::kTrialC;
  const RoverTelemetry run = SimulateRoverTelemetry(options);
  EXPECT_EQ(run.drive.trials.size(), 6u);
  EXPECT_EQ(run.drive.trials_truncated, 0);
  EXPECT_EQ(run.drive.commands_completed, static_cast<int>(run.scenario.commands.size()));
}

// The real-like preset: encoders at 10 Hz, the gyro and tilt at 50 Hz, the sensor model of a
// small skid-steered rover (left wheels counting down), abrupt turns; a compass only in the
// -compass variant.
TEST(SimulateRoverTelemetry, SkidSteerPresetsHaveTheirSensorsRatesAndModel) {
  for (const bool compass : {false, true}) {
    RoverTelemetryOptions options;
    options.preset = compass ? TelemetryPreset::kSkidSteerCompass : TelemetryPreset::kSkidSteer;
    const RoverTelemetry run = SimulateRoverTelemetry(options);
    const int fl = static_cast<int>(telemetry::Channel::kEncoderFrontLeft);
    const int gyro = static_cast<int>(telemetry::Channel::kGyroZ);
    const int heading = static_cast<int>(telemetry::Channel::kCompass);
    long encoder_samples = 0, gyro_samples = 0, compass_samples = 0;
    for (const auto& row : run.raw.counts) {
      encoder_samples += row[fl] != kEmptyCell;
      gyro_samples += row[gyro] != kEmptyCell;
      compass_samples += row[heading] != kEmptyCell;
    }
    const double duration = run.drive.samples.back().t_s;
    EXPECT_NEAR(duration, 177.0, 0.1);
    EXPECT_NEAR(encoder_samples / duration, 10.0, 0.1);
    EXPECT_NEAR(gyro_samples / duration, 50.0, 0.1);
    EXPECT_NEAR(compass_samples / duration, compass ? 10.0 : 0.0, 0.1);
    EXPECT_EQ(run.sensor_model[telemetry::Channel::kCompass].present, compass);
    EXPECT_EQ(run.sensor_model[telemetry::Channel::kEncoderFrontLeft].sign, -1);
    EXPECT_EQ(run.sensor_model[telemetry::Channel::kEncoderFrontLeft].counts_per_revolution, 1024);
    EXPECT_NEAR(run.sensor_model[telemetry::Channel::kGyroZ].ToRadians(1023), 1.0, 0.01);
    // Abrupt turns: the turn rate changes at up to 500 deg/s^2, and reaches 45 deg/s.
    double max_accel = 0, max_rate = 0;
    for (const RoverSample& s : run.drive.samples) {
      max_accel = std::max(max_accel, std::abs(s.turn_accel_radps2) / kDeg);
      max_rate = std::max(max_rate, std::abs(s.turn_rate_radps) / kDeg);
    }
    EXPECT_GT(max_accel, 400.0);
    EXPECT_LE(max_accel, 501.0);
    EXPECT_NEAR(max_rate, 45.0, 1.0);
    EXPECT_GT(run.drive.samples.back().distance_m, 60.0);
  }
  RoverTelemetryOptions options;
  options.preset = TelemetryPreset::kSkidSteer;
  options.rate_hz = 20;
  EXPECT_THROW(SimulateRoverTelemetry(options), std::invalid_argument);
}

// Faults on the skid-steer preset land on channels it has and on rows where they have a
// sample (the encoders are sampled in one row of five, and there is no compass).
TEST(SimulateRoverTelemetry, FaultsOnTheSkidSteerPresetLandOnSamples) {
  RoverTelemetryOptions options;
  options.preset = TelemetryPreset::kSkidSteer;
  for (const char* text : {"spikes*8", "stuck:enc_fl*1", "out-of-range*3", "spike:enc_rr@30.01"}) {
    for (FaultSpec& spec : ParseFaultSpecs(text)) options.faults.push_back(spec);
  }
  const RoverTelemetry run = SimulateRoverTelemetry(options);
  ASSERT_EQ(run.faults.size(), 13u);
  for (const InjectedFault& f : run.faults) {
    ASSERT_GE(f.channel, 0);
    EXPECT_TRUE(run.sensor_model.channels[f.channel].present) << f.spec;
    EXPECT_NE(f.original, kEmptyCell) << f.spec << " at row " << f.row;
    EXPECT_NE(run.raw.counts[f.row][f.channel], kEmptyCell) << f.spec;
  }
  // The one at 30.01 s went to the encoder's next sample, at 30.1 s.
  bool at_time = false;
  for (const InjectedFault& f : run.faults) {
    if (f.spec == "spike:enc_rr@30.01") {
      at_time = true;
      EXPECT_EQ(f.t_us, 30100000);
    }
  }
  EXPECT_TRUE(at_time);
}

TEST(SimulateRoverTelemetry, RejectsBadOptions) {
  RoverTelemetryOptions options;
  options.bits = 5;
  EXPECT_THROW(SimulateRoverTelemetry(options), std::invalid_argument);
  options = {};
  options.rate_hz = 0;
  EXPECT_THROW(SimulateRoverTelemetry(options), std::invalid_argument);
  options = {};
  options.duration_s = -1;
  EXPECT_THROW(SimulateRoverTelemetry(options), std::invalid_argument);
  options = {};
  options.noise_scale = -1;
  EXPECT_THROW(SimulateRoverTelemetry(options), std::invalid_argument);
}

TEST(WriteRoverTelemetry, WritesTheDocumentedHeadersAndAReadableSensorModel) {
  RoverTelemetryOptions options;
  options.preset = TelemetryPreset::kTrialB;
  options.bits = 7;
  options.duration_s = 30;
  util::ScopedTempDir dir;
  Write(options, dir.path());
  std::ifstream telemetry(dir.path() / "telemetry.csv");
  std::string line;
  std::getline(telemetry, line);
  EXPECT_EQ(line[0], '#');
  std::getline(telemetry, line);
  EXPECT_EQ(line[0], '#');
  std::getline(telemetry, line);
  EXPECT_EQ(line, "t,enc_fl,enc_fr,enc_rl,enc_rr,compass,pitch_left,pitch_right,roll,gyro_z");
  std::getline(telemetry, line);
  EXPECT_EQ(line.rfind("0,", 0), 0u);
  const nlohmann::json sensors = io::ReadJson(dir.path() / "sensors.json");
  const telemetry::SensorModel model = telemetry::SensorModelFromJson(sensors, "sensors.json");
  EXPECT_EQ(model[telemetry::Channel::kCompass].bits, 7);
  EXPECT_EQ(model.ToJson()["channels"], sensors["channels"]);
  std::ifstream truth(dir.path() / "truth.csv");
  while (std::getline(truth, line) && line[0] == '#') {
  }
  EXPECT_EQ(line.rfind("t_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg", 0), 0u);
}

}  // namespace
}  // namespace lunarnav::sim
