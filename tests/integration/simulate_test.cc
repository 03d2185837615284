// Integration tests of `simulate telemetry`, and of posfilter on its logs.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "integration/run_tool.h"
#include "io/json_io.h"
#include "positioning/trajectory_io.h"
#include "util/testing.h"

namespace lunarnav {
namespace {
namespace fs = std::filesystem;
using testing::RunTool;

constexpr double kDeg = M_PI / 180.0;
constexpr const char* kDataOutputs[] = {"telemetry.csv", "sensors.json", "truth.csv", "trials.json", "faults.csv"};

// Runs `simulate telemetry ARGS -o DIR` and expects success.
void Simulate(std::vector<std::string> args, const fs::path& dir, const fs::path& scratch) {
  args.insert(args.begin(), "telemetry");
  args.insert(args.end(), {"-o", dir.string(), "-q"});
  const testing::ToolRun run = RunTool("simulate", args, scratch);
  ASSERT_EQ(run.exit_code, 0) << run.stderr_text;
}

void Posfilter(const fs::path& log_dir, const fs::path& out, const fs::path& scratch,
               std::vector<std::string> extra = {}) {
  std::vector<std::string> args = {(log_dir / "telemetry.csv").string(), "--sensors",
                                   (log_dir / "sensors.json").string(), "-o", out.string(), "-q"};
  args.insert(args.end(), extra.begin(), extra.end());
  const testing::ToolRun run = RunTool("posfilter", args, scratch);
  ASSERT_EQ(run.exit_code, 0) << run.stderr_text;
}

double WrapDeg(double d) { return std::remainder(d, 360.0); }

TEST(Simulate, PosfilterOnATrialALogEndsNearTheTrueEndPose) {
  util::ScopedTempDir tmp;
  Simulate({"--preset", "trial-a"}, tmp.path() / "sim", tmp.path());
  Posfilter(tmp.path() / "sim", tmp.path() / "pf", tmp.path());
  const nlohmann::json trials = io::ReadJson(tmp.path() / "sim" / "trials.json");
  const auto trajectory = positioning::ReadTrajectoryCsv(tmp.path() / "pf" / "trajectory.csv");
  ASSERT_EQ(trials["trials"].size(), 6u);
  double path_m = 0;
  for (const auto& t : trials["trials"]) path_m += t["measured"]["path_length_m"].get<double>();
  const nlohmann::json& end = trials["trials"].back()["end"];
  const positioning::TrajectorySample& last = trajectory.back();
  const double error_m = std::hypot(last.x_m - end["x_m"].get<double>(), last.y_m - end["y_m"].get<double>());
  // 36 m of straight lines with 4 % wheel slip (trial A's untuned motion control): a few %.
  EXPECT_GT(path_m, 35.0);
  EXPECT_LT(error_m / path_m, 0.07) << error_m << " m off after " << path_m << " m";
  EXPECT_LT(std::abs(WrapDeg(last.heading_rad / kDeg - end["heading_deg"].get<double>())), 5.0);
  EXPECT_NEAR(last.z_m, end["z_m"].get<double>(), 0.03 * path_m);
}

// Heading error against truth.csv, RMS over every row, degrees.
double RmsHeadingErrorDeg(const fs::path& trajectory_csv, const fs::path& truth_csv) {
  const auto estimate = positioning::ReadTrajectoryCsv(trajectory_csv);
  const auto truth = positioning::ReadTrajectoryCsv(truth_csv);
  EXPECT_EQ(estimate.size(), truth.size());
  double sum = 0;
  for (std::size_t k = 0; k < std::min(estimate.size(), truth.size()); ++k) {
    EXPECT_NEAR(estimate[k].t_s, truth[k].t_s, 1e-6);
    sum += std::pow(WrapDeg((estimate[k].heading_rad - truth[k].heading_rad) / kDeg), 2);
  }
  return std::sqrt(sum / static_cast<double>(truth.size()));
}

TEST(Simulate, GyroGatedKalmanHeadingBeatsPlainLowPassOnArcs) {
  // Trial C: arcs, during which the compass lags the turn (its transients) and the low-pass
  // filter adds its own delay; the Kalman filter follows the gyro while turning.
  util::ScopedTempDir tmp;
  Simulate({"--preset", "trial-c"}, tmp.path() / "sim", tmp.path());
  Posfilter(tmp.path() / "sim", tmp.path() / "kalman", tmp.path(), {"--heading", "kalman"});
  Posfilter(tmp.path() / "sim", tmp.path() / "lowpass", tmp.path(), {"--heading", "lowpass"});
  const double kalman = RmsHeadingErrorDeg(tmp.path() / "kalman" / "trajectory.csv", tmp.path() / "sim" / "truth.csv");
  const double lowpass =
      RmsHeadingErrorDeg(tmp.path() / "lowpass" / "trajectory.csv", tmp.path() / "sim" / "truth.csv");
  // Measured when written: 1.57 against 7.24 deg (2.15 deg before the filter estimated the
  // gyro's scale and smoothed its compass gate).
  EXPECT_LT(kalman, 0.5 * lowpass) << "kalman " << kalman << " deg, low-pass " << lowpass << " deg";
  EXPECT_LT(kalman, 2.0);
}

// A row of a CSV file with '#' comments and a header, by column name.
std::vector<std::map<std::string, std::string>> ReadCsv(const fs::path& path) {
  std::ifstream in(path);
  std::vector<std::string> header;
  std::vector<std::map<std::string, std::string>> rows;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> cells;
    std::istringstream s(line);
    for (std::string cell; std::getline(s, cell, ',');) cells.push_back(cell);
    if (line.back() == ',') cells.emplace_back();
    if (header.empty()) {
      header = cells;
      continue;
    }
    std::map<std::string, std::string> row;
    for (std::size_t i = 0; i < header.size() && i < cells.size(); ++i) row[header[i]] = cells[i];
    rows.push_back(row);
  }
  return rows;
}

TEST(Simulate, SevenAndTenBitLogsOfTheSameDriveGiveTheSameDistance) {
  // Trial B: straight lines with slip and bursts of spinning wheels, turns in place. At 7 bits
  // a wheel count is 4.9 cm, more than a wheel turns in one sample; the slip test must not take
  // that quantisation for slip, nor the path length count its back and forth.
  util::ScopedTempDir tmp;
  double distance[2] = {0, 0};
  long slip_events[2] = {0, 0};
  double wheel_travel_m = 0;
  const char* bits[2] = {"10", "7"};
  for (int b = 0; b < 2; ++b) {
    const fs::path sim = tmp.path() / (std::string("sim") + bits[b]);
    Simulate({"--preset", "trial-b", "--bits", bits[b]}, sim, tmp.path());
    Posfilter(sim, tmp.path() / (std::string("pf") + bits[b]), tmp.path());
    const nlohmann::json summary = io::ReadJson(tmp.path() / (std::string("pf") + bits[b]) / "summary.json");
    distance[b] = summary["motion"]["distance_m"].get<double>();
    slip_events[b] = summary["motion"]["slip_events"].get<long>();
    if (b == 0) {
      const auto truth = ReadCsv(sim / "truth.csv");
      ASSERT_FALSE(truth.empty());
      for (const char* w : {"wheel_fl_m", "wheel_fr_m", "wheel_rl_m", "wheel_rr_m"}) {
        wheel_travel_m += 0.25 * std::stod(truth.back().at(w));
      }
    }
  }
  // Measured when written: 23.92 and 23.88 m, the wheels' mean travel 23.91 m (before: 24.49
  // and 27.68 m).
  EXPECT_NEAR(distance[1], distance[0], 0.02 * distance[0]);
  EXPECT_NEAR(distance[0], wheel_travel_m, 0.02 * wheel_travel_m);
  EXPECT_NEAR(distance[1], wheel_travel_m, 0.02 * wheel_travel_m);
  // The wheels' bursts of spinning while turning (+40 % for 1 s) are still slip at 10 bits
  // (measured: 22 wheel-steps; at 7 bits, where such a burst is less than a count, 2).
  EXPECT_GT(slip_events[0], 0);
  EXPECT_LT(slip_events[1], 100);  // before: 1055, quantisation taken for slip
}


TEST(Simulate, PosfilterScreeningReportsEveryInjectedFaultWhereFaultsCsvSaysItIs) {
  // Trial B moves at 5-19 s, 23-33 s (turning), 36-48 s, 52-62 s (turning), 66-82 s, ...: the
  // stuck runs are placed while their channels move (a stuck value at rest is no fault).
  util::ScopedTempDir tmp;
  Simulate({"--preset", "trial-b", "--faults",
            "spike:compass@20,spike:pitch_left@30,spike:enc_fl@40,stuck:gyro_z@50+5,stuck:enc_rr@68+4,"
            "dropout:roll@70,out-of-range:compass@80,out-of-range:enc_fr@90,repeated_timestamp@100,"
            "out_of_order_timestamp@110"},
           tmp.path() / "sim", tmp.path());
  Posfilter(tmp.path() / "sim", tmp.path() / "pf", tmp.path(),
            {"--screening-log", (tmp.path() / "screening.csv").string()});
  const auto faults = ReadCsv(tmp.path() / "sim" / "faults.csv");
  ASSERT_EQ(faults.size(), 10u);
  std::set<std::pair<long, std::string>> events;  // (line, channel)
  for (const auto& e : ReadCsv(tmp.path() / "screening.csv")) {
    if (e.at("rule") != "encoder_wrap") events.insert({std::stol(e.at("line")), e.at("channel")});
  }
  for (const auto& f : faults) {
    SCOPED_TRACE(f.at("kind") + " " + f.at("channel") + " at line " + f.at("line"));
    const long line = std::stol(f.at("line")), rows = std::stol(f.at("rows"));
    EXPECT_EQ(line, std::stol(f.at("row")) + 4);
    // Spikes, out-of-range and time stamps on their line; a stuck run or a dropout somewhere
    // within it or on the line where the channel comes back.
    bool found = false;
    for (long l = line; l <= line + (rows > 1 ? rows : 0) && !found; ++l) found = events.count({l, f.at("channel")}) > 0;
    EXPECT_TRUE(found);
  }
}

// The real-like presets (a small skid-steered rover with MEMS sensors, encoders at 10 Hz, the
// IMU at 50 Hz, abrupt turns), with and without a compass, over six seeds. What it checks: on
// average posfilter's trajectory is closer to the truth than the plain baseline it writes
// beside it (by `evaluate trajectory`, after a 2-D alignment; without a compass by 10 % or
// more, with one not worse); it is not "no worse on every seed": the worst seed is bounded only
// loosely, by a seed's spread (1.1 without a compass; 1.5 with one, whose magnetic wander made
// seed 3 1.40 when measured), and those two bounds were set above the values measured; no
// screening rule rejects more than its warning share; without a compass the gyro's scale is
// not adapted. One seed alone is no test of this: the baseline and the filter share the errors
// nothing in such a log shows (wheel slip, the gyro's scale), so a seed's ratio lies anywhere
// from 0.2 to 1.2 (docs/posfilter.md), and a log that differs in one random draw (another
// compiler's rounding, in the simulator) moves it by 0.1.
TEST(Simulate, OnTheSkidSteerPresetsPosfilterBeatsThePlainBaselineOnAverage) {
  util::ScopedTempDir tmp;
  for (const std::string preset : {"skid-steer", "skid-steer-compass"}) {
    double sum = 0, worst = 0;
    const int seeds = 6;
    for (int seed = 1; seed <= seeds; ++seed) {
      SCOPED_TRACE(preset + " seed " + std::to_string(seed));
      const std::string name = preset + "-" + std::to_string(seed);
      const fs::path sim = tmp.path() / name, pf = tmp.path() / (name + "-pf"), ev = tmp.path() / (name + "-ev");
      Simulate({"--preset", preset, "--seed", std::to_string(seed)}, sim, tmp.path());
      Posfilter(sim, pf, tmp.path());
      const testing::ToolRun run =
          RunTool("evaluate",
                  {"trajectory", "filtered=" + (pf / "trajectory.csv").string(),
                   "baseline=" + (pf / "baseline.csv").string(), "--truth", (sim / "truth.csv").string(), "-o",
                   ev.string(), "-q"},
                  tmp.path());
      ASSERT_EQ(run.exit_code, 0) << run.stderr_text;
      const nlohmann::json evaluation = io::ReadJson(ev / "summary.json");
      const double ratio = evaluation["estimates"]["filtered"]["ape_mean_ratio"].get<double>();
      sum += ratio;
      worst = std::max(worst, ratio);
      EXPECT_LT(evaluation["estimates"]["baseline"]["ape_mean_m"].get<double>(), 5.0);
      const nlohmann::json summary = io::ReadJson(pf / "summary.json");
      const double warning_share = summary["screening"]["warning_share"].get<double>();
      for (const auto& share : summary["screening"]["rejection_shares"]) {
        EXPECT_LT(share["share"].get<double>(), warning_share) << share.dump();
      }
      if (preset == "skid-steer") {
        EXPECT_EQ(summary["heading_kalman"]["gyro_scale_error"].get<double>(), 0.0);
        EXPECT_NE(summary["states"]["gyro_scale"].get<std::string>().find("held at prior"), std::string::npos);
      }
    }
    // Measured (GCC's logs, seeds 1-6), against the baseline whose rest ends at its last still
    // encoder sample: without a compass a mean ratio of 0.83, the worst 0.95; with one 0.91
    // and 1.40 (seed 3; seed 6 1.14: the compass's magnetic wander pulls the heading more
    // than the gyro drifts, docs/posfilter.md). Against the baseline that took the first
    // turn's start for rest the means read 0.64 and 0.63: the filter's gain was half the
    // baseline's error.
    EXPECT_LE(sum / seeds, preset == "skid-steer" ? 0.9 : 1.0) << preset;
    EXPECT_LE(worst, preset == "skid-steer" ? 1.1 : 1.5) << preset;
  }
}

TEST(Simulate, SameSeedSameBytesOtherSeedOtherBytes) {
  util::ScopedTempDir tmp;
  const std::vector<std::string> args = {"--preset", "traverse", "--duration", "60", "--bits", "7",
                                         "--faults", "spikes*2,timestamps"};
  Simulate(args, tmp.path() / "a", tmp.path());
  Simulate(args, tmp.path() / "b", tmp.path());
  std::vector<std::string> other = args;
  other.insert(other.end(), {"--seed", "2"});
  Simulate(other, tmp.path() / "c", tmp.path());
  for (const char* name : kDataOutputs) {
    EXPECT_EQ(testing::ReadFileBytes(tmp.path() / "a" / name), testing::ReadFileBytes(tmp.path() / "b" / name)) << name;
  }
  EXPECT_NE(testing::ReadFileBytes(tmp.path() / "a" / "telemetry.csv"), testing::ReadFileBytes(tmp.path() / "c" / "telemetry.csv"));
  const nlohmann::json summary = io::ReadJson(tmp.path() / "a" / "summary.json");
  EXPECT_EQ(summary["tool"], "simulate");
  EXPECT_EQ(summary["subcommand"], "telemetry");
  EXPECT_EQ(summary["options"]["bits"], 7);
  EXPECT_EQ(summary["counts"]["rows"], 601);
  EXPECT_EQ(summary["counts"]["faults"], 4);
}

TEST(Simulate, TheTestdataFixtureIsWhatItsCommandWrites) {
  // testdata/README.md: simulate telemetry --preset trial-a --seed 1 -o testdata/telemetry/trial-a
  util::ScopedTempDir tmp;
  Simulate({"--preset", "trial-a", "--seed", "1"}, tmp.path() / "sim", tmp.path());
  for (const char* name : kDataOutputs) {
    EXPECT_EQ(testing::ReadFileBytes(tmp.path() / "sim" / name), testing::ReadFileBytes(util::TestDataPath(std::string("telemetry/trial-a/") + name)))
        << name << " differs: regenerate the fixture (testdata/README.md)";
  }
}

TEST(Simulate, NoNoiseGivesIdealSensors) {
  util::ScopedTempDir tmp;
  Simulate({"--preset", "trial-b", "--duration", "30", "--no-noise"}, tmp.path() / "sim", tmp.path());
  const nlohmann::json summary = io::ReadJson(tmp.path() / "sim" / "summary.json");
  EXPECT_EQ(summary["options"]["noise_scale"], 0.0);
  EXPECT_EQ(summary["sensor_error_draws"]["compass_bias_deg"], 0.0);
  EXPECT_EQ(summary["sensor_error_draws"]["gyro_scale_error"], 0.0);
}

TEST(Simulate, BadArgumentsAreUsageErrorsWithOneErrorLine) {
  util::ScopedTempDir tmp;
  const std::string out = (tmp.path() / "out").string();
  EXPECT_EQ(RunTool("simulate", {"telemetry", "--preset", "trial-x", "-o", out}, tmp.path()).exit_code, 2);
  EXPECT_EQ(RunTool("simulate", {"telemetry", "--preset", "trial-a", "--bits", "8", "-o", out}, tmp.path()).exit_code,
            2);
  EXPECT_EQ(RunTool("simulate", {"--preset", "trial-a", "-o", out}, tmp.path()).exit_code, 2);  // no subcommand
  for (const char* fault : {"bogus", "spike@1000", "timestamps@5", "stuck:nochannel"}) {
    const testing::ToolRun run =
        RunTool("simulate", {"telemetry", "--preset", "trial-a", "--faults", fault, "-o", out}, tmp.path());
    EXPECT_EQ(run.exit_code, 2) << fault;
    EXPECT_EQ(run.ErrorLines(), 1) << run.stderr_text;
  }
  EXPECT_FALSE(fs::exists(tmp.path() / "out" / "telemetry.csv"));
  std::ofstream(tmp.path() / "file") << "x";
  EXPECT_EQ(RunTool("simulate", {"telemetry", "--preset", "trial-a", "-o", (tmp.path() / "file").string()}, tmp.path())
                .exit_code,
            2);
}

}  // namespace
}  // namespace lunarnav
