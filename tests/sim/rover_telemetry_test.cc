#include "sim/rover_telemetry.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>

#include "io/json_io.h"
#include "util/testing.h"

namespace lunarnav::sim {
namespace {

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
    EXPECT_EQ(run.raw.size(), 1001u) << name;
    EXPECT_GT(run.drive.samples.back().distance_m, 10.0) << name;
    EXPECT_FALSE(run.scenario.description.empty());
    EXPECT_EQ(run.CountsJson()["rows"], 1001);
  }
  // The trials end by themselves without --duration.
  RoverTelemetryOptions options;
  options.preset = TelemetryPreset::kTrialC;
  const RoverTelemetry run = SimulateRoverTelemetry(options);
  EXPECT_EQ(run.drive.trials.size(), 6u);
  EXPECT_EQ(run.drive.trials_truncated, 0);
  EXPECT_EQ(run.drive.commands_completed, static_cast<int>(run.scenario.commands.size()));
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
