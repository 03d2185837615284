#include "sim/telemetry_faults.h"

#include <gtest/gtest.h>

#include <fstream>
#include <set>
#include <sstream>
#include <string>

#include "sim/rover_telemetry.h"
#include "util/testing.h"

namespace lunarnav::sim {
namespace {

using telemetry::Channel;

TEST(ParseFaultSpec, ReadsEveryFormAndTheCommandLineSpellings) {
  FaultSpec s = ParseFaultSpec("spikes:compass@30");
  EXPECT_EQ(s.kind, FaultKind::kSpike);
  EXPECT_EQ(s.channel, Channel::kCompass);
  EXPECT_EQ(s.at_s, 30.0);
  s = ParseFaultSpec("stuck:enc_fl@40+6");
  EXPECT_EQ(s.kind, FaultKind::kStuck);
  EXPECT_EQ(s.Duration(), 6.0);
  s = ParseFaultSpec("dropouts*3");
  EXPECT_EQ(s.kind, FaultKind::kDropout);
  EXPECT_FALSE(s.channel.has_value());
  EXPECT_EQ(s.count, 3);
  EXPECT_EQ(s.Duration(), 2.0);
  s = ParseFaultSpec("out-of-range:gyro_z~2");
  EXPECT_EQ(s.kind, FaultKind::kOutOfRange);
  EXPECT_EQ(s.per_minute, 2.0);
  EXPECT_EQ(ParseFaultSpec("out_of_order_timestamp@3").kind, FaultKind::kOutOfOrderTimestamp);
  const std::vector<FaultSpec> group = ParseFaultSpecs("timestamps*2");
  ASSERT_EQ(group.size(), 2u);
  EXPECT_EQ(group[0].kind, FaultKind::kRepeatedTimestamp);
  EXPECT_EQ(group[1].kind, FaultKind::kOutOfOrderTimestamp);
  EXPECT_EQ(group[1].count, 2);
  EXPECT_EQ(ParseFaultSpecs("spike").size(), 1u);
}

TEST(ParseFaultSpec, RejectsMalformedRequests) {
  for (const char* bad : {"bogus", "spike:nochannel", "spike@x", "spike@-1", "spike+3", "stuck+0", "spike@1*2",
                          "repeated_timestamp:compass", "dropout*1.5", ""}) {
    EXPECT_THROW(ParseFaultSpec(bad), std::invalid_argument) << bad;
  }
  EXPECT_THROW(ParseFaultSpecs("timestamps@5"), std::invalid_argument);
}

// The same run with and without faults: the cells and time stamps that differ are exactly
// those the fault list names, each as it says, and faults.csv lists them.
TEST(InjectFaults, FaultsAppearExactlyWhereRequested) {
  RoverTelemetryOptions options;
  options.preset = TelemetryPreset::kTrialA;
  const RoverTelemetry clean = SimulateRoverTelemetry(options);
  for (const char* f : {"spike:compass@30", "spike:pitch_left@31.05", "stuck:enc_fl@40+6", "dropout:gyro_z@50+2",
                        "out-of-range:roll@60", "out-of-range:enc_rr@61", "repeated_timestamp@70",
                        "out_of_order_timestamp@80", "spikes*3", "dropouts:compass*2", "stuck~1"}) {
    for (FaultSpec& s : ParseFaultSpecs(f)) options.faults.push_back(s);
  }
  const RoverTelemetry run = SimulateRoverTelemetry(options);
  const std::vector<InjectedFault>& faults = run.faults;
  ASSERT_EQ(faults.size(), 8u + 3u + 2u + 2u);  // stuck~1: 128 s of log at 1 per minute
  ASSERT_EQ(run.raw.size(), clean.raw.size());

  std::set<std::pair<std::size_t, int>> expected_cells;  // (row, channel); channel -1: time stamp
  for (const InjectedFault& f : faults) {
    SCOPED_TRACE(f.spec);
    if (f.kind == FaultKind::kRepeatedTimestamp) {
      EXPECT_EQ(run.raw.t_us[f.row], run.raw.t_us[f.row - 1]);
      EXPECT_EQ(f.original, clean.raw.t_us[f.row]);
      expected_cells.insert({f.row, -1});
      continue;
    }
    if (f.kind == FaultKind::kOutOfOrderTimestamp) {
      EXPECT_LT(run.raw.t_us[f.row], run.raw.t_us[f.row - 1]);
      EXPECT_EQ(run.raw.counts[f.row], clean.raw.counts[f.row - 1]);  // the rows swapped
      EXPECT_EQ(run.raw.counts[f.row - 1], clean.raw.counts[f.row]);
      for (int c = -1; c < telemetry::kNumChannels; ++c) {
        expected_cells.insert({f.row, c});
        expected_cells.insert({f.row - 1, c});
      }
      continue;
    }
    const telemetry::ChannelModel& m = run.sensor_model[static_cast<Channel>(f.channel)];
    for (std::size_t r = f.row; r < f.row + f.rows; ++r) {
      const std::int64_t cell = run.raw.counts[r][f.channel];
      switch (f.kind) {
        case FaultKind::kSpike:
          EXPECT_EQ(cell, f.value);
          EXPECT_NE(cell, clean.raw.counts[r][f.channel]);
          break;
        case FaultKind::kOutOfRange:
          EXPECT_TRUE(cell < m.valid_min || cell > m.valid_max) << cell;
          break;
        case FaultKind::kStuck: EXPECT_EQ(cell, clean.raw.counts[f.row - 1][f.channel]); break;
        case FaultKind::kDropout: EXPECT_EQ(cell, kEmptyCell); break;
        default: break;
      }
      expected_cells.insert({r, f.channel});
    }
    if (f.kind == FaultKind::kStuck) {
      EXPECT_EQ(f.rows, f.spec.find("+6") != std::string::npos ? 60u : 50u);
    }
    if (f.kind == FaultKind::kDropout) {
      EXPECT_EQ(f.rows, 20u);
    }
  }
  // Requests at a time land on the first row at or after it.
  const auto row_at = [&](double t_s) {
    for (const InjectedFault& f : faults) {
      if (f.spec.find("@") != std::string::npos && std::abs(clean.drive.samples[f.row].t_s - t_s) < 0.1 - 1e-9 &&
          clean.drive.samples[f.row].t_s >= t_s - 1e-9) {
        return true;
      }
    }
    return false;
  };
  for (double t : {30.0, 31.05, 40.0, 50.0, 60.0, 61.0, 70.0, 80.0}) EXPECT_TRUE(row_at(t)) << t;
  // Nothing else changed.
  for (std::size_t r = 0; r < run.raw.size(); ++r) {
    if (run.raw.t_us[r] != clean.raw.t_us[r]) {
      EXPECT_TRUE(expected_cells.count({r, -1})) << "time of row " << r;
    }
    for (int c = 0; c < telemetry::kNumChannels; ++c) {
      if (run.raw.counts[r][c] != clean.raw.counts[r][c]) {
        EXPECT_TRUE(expected_cells.count({r, c})) << "row " << r << " channel " << c;
      }
    }
  }

  // faults.csv lists the same faults: row, line, time, channel, kind.
  util::ScopedTempDir dir;
  WriteFaultsCsv(dir.path() / "faults.csv", faults);
  std::ifstream in(dir.path() / "faults.csv");
  std::string line;
  std::size_t listed = 0;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || line.rfind("row,", 0) == 0) continue;
    ASSERT_LT(listed, faults.size());
    const InjectedFault& f = faults[listed++];
    std::istringstream cells(line);
    std::string row, file_line, t, channel, kind;
    std::getline(cells, row, ',');
    std::getline(cells, file_line, ',');
    std::getline(cells, t, ',');
    std::getline(cells, channel, ',');
    std::getline(cells, kind, ',');
    EXPECT_EQ(std::stoul(row), f.row);
    EXPECT_EQ(std::stol(file_line), TelemetryCsvLine(f.row));
    EXPECT_EQ(channel, f.channel < 0 ? "row" : telemetry::ToString(static_cast<Channel>(f.channel)));
    EXPECT_EQ(kind, ToString(f.kind));
  }
  EXPECT_EQ(listed, faults.size());
}

TEST(InjectFaults, RandomPlacementsKeepClearOfEachOtherAndOfTheEnds) {
  RoverTelemetryOptions options;
  options.preset = TelemetryPreset::kTrialC;
  options.faults = {ParseFaultSpec("spikes*20"), ParseFaultSpec("stuck*3"), ParseFaultSpec("dropouts*3")};
  const RoverTelemetry run = SimulateRoverTelemetry(options);
  ASSERT_EQ(run.faults.size(), 26u);
  const std::size_t margin = 20;  // 2 s at 10 Hz
  for (std::size_t i = 0; i < run.faults.size(); ++i) {
    const InjectedFault& a = run.faults[i];
    EXPECT_GE(a.row, margin);
    EXPECT_LE(a.row + a.rows, run.raw.size() - margin);
    for (std::size_t j = i + 1; j < run.faults.size(); ++j) {
      const InjectedFault& b = run.faults[j];  // b.row >= a.row
      EXPECT_GE(b.row, a.row + a.rows - 1 + (a.channel == b.channel ? 20 : 10)) << a.spec << " " << b.spec;
    }
  }
  // Too many to place: a usage error, not a hang.
  options.faults = {ParseFaultSpec("stuck:compass*100+5")};
  EXPECT_THROW(SimulateRoverTelemetry(options), std::invalid_argument);
  options.faults = {ParseFaultSpec("spike@1000")};
  EXPECT_THROW(SimulateRoverTelemetry(options), std::invalid_argument);
}

}  // namespace
}  // namespace lunarnav::sim
