#include "positioning/trajectory_io.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>

#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "util/testing.h"

namespace lunarnav::positioning {
namespace {

// The cells of one column of a trajectory CSV's data rows (comments and the header skipped).
std::vector<std::string> CsvColumn(const std::filesystem::path& path, int column) {
  std::ifstream in(path);
  std::vector<std::string> cells;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || line[0] == 't') continue;
    std::size_t a = 0;
    for (int c = 0; c < column; ++c) a = line.find(',', a) + 1;
    cells.push_back(line.substr(a, line.find(',', a) - a));
  }
  return cells;
}

TEST(TrajectoryCsv, RoundTrips) {
  util::ScopedTempDir tmp;
  std::vector<TrajectorySample> in(3);
  for (int i = 0; i < 3; ++i) {
    in[i] = {0.1 * i + 1e9, 1.5 * i, -2.25 * i, 0.125 * i, -0.5 + i, 0.05 * i, -0.02 * i, 0.7};
  }
  WriteTrajectoryCsv(tmp.path() / "t.csv", in);
  const std::vector<TrajectorySample> back = ReadTrajectoryCsv(tmp.path() / "t.csv");
  ASSERT_EQ(back.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_DOUBLE_EQ(back[i].t_s, in[i].t_s);
    // Written to 0.1 mm and 0.0001 deg (docs/formats.md).
    EXPECT_NEAR(back[i].y_m, in[i].y_m, 0.5e-4);
    // Headings are written in [0, 360).
    EXPECT_NEAR(std::remainder(back[i].heading_rad - in[i].heading_rad, 2 * M_PI), 0.0, 0.5e-4 * M_PI / 180);
    EXPECT_NEAR(back[i].pitch_rad, in[i].pitch_rad, 0.5e-4 * M_PI / 180);
  }
}

TEST(TrajectoryTum, QuaternionPointsTheBodyXAxisAlongTheHeading) {
  util::ScopedTempDir tmp;
  TrajectorySample p;
  p.heading_rad = M_PI / 2;  // east
  p.pitch_rad = 0.1;         // nose up
  WriteTrajectoryTum(tmp.path() / "t.tum", {p});
  std::ifstream in(tmp.path() / "t.tum");
  std::string line;
  std::getline(in, line);  // comment
  std::getline(in, line);
  std::istringstream row(line);
  double t, x, y, z, qx, qy, qz, qw;
  row >> t >> x >> y >> z >> qx >> qy >> qz >> qw;
  const Eigen::Vector3d forward = Eigen::Quaterniond(qw, qx, qy, qz) * Eigen::Vector3d::UnitX();
  // Quaternions are written with 8 decimals.
  EXPECT_NEAR(forward.x(), std::cos(0.1), 1e-7);  // east
  EXPECT_NEAR(forward.y(), 0.0, 1e-7);
  EXPECT_NEAR(forward.z(), std::sin(0.1), 1e-7);  // up
}

std::string ReadAll(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// The exact text, rounding and special values included (as written before the writer was
// made faster): time as the shortest text that reads back, 4 decimals (8 for quaternions)
// rounded half away from zero, no "-0.0000", magnitudes of 9e9 and beyond and NaN as the
// shortest text, headings in [0, 360).
TEST(TrajectoryWriter, WritesBothFilesInOnePassWithTheDocumentedText) {
  util::ScopedTempDir tmp;
  std::vector<TrajectorySample> poses(3);
  poses[0] = {0.1, 0.00005, -0.00004, -1.23456, -0.1, 0.25, -0.125, 0.7};
  poses[1] = {1234567.891, 123456.78915, -2e9, 9e9, 2 * M_PI, -M_PI / 2, 1e-9, 1e10};
  poses[2] = {1e-7, 0, 0, 0, 7.5, 0, 0, std::numeric_limits<double>::quiet_NaN()};
  TrajectoryWriter writer(tmp.path() / "t.csv", tmp.path() / "t.tum");
  for (const TrajectorySample& p : poses) writer.Add(p);
  EXPECT_FALSE(std::filesystem::exists(tmp.path() / "t.csv"));  // not before Commit
  writer.Commit();
  EXPECT_EQ(ReadAll(tmp.path() / "t.csv"),
            "# lunarnav trajectory: frame x east, y north, z up (m), origin at the start;\n"
            "# heading clockwise from north (deg, [0, 360)), pitch nose up (deg), roll right side down (deg)\n"
            "t_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg,speed_mps\n"
            "0.1,0.0001,0.0000,-1.2346,354.2704,14.3239,-7.1620,0.7000\n"
            "1234567.891,123456.7892,-2000000000.0000,9e+09,0.0000,-90.0000,0.0000,1e+10\n"
            "1e-07,0.0000,0.0000,0.0000,69.7183,0.0000,0.0000,nan\n");
  EXPECT_EQ(ReadAll(tmp.path() / "t.tum"),
            "# timestamp tx ty tz qx qy qz qw (lunarnav; ENU frame, body x forward, y left, z up)\n"
            "0.1 0.0001 0.0000 -1.2346 0.13384966 -0.03752261 0.73956539 0.65857372\n"
            "1234567.891 123456.7892 -2000000000.0000 9e+09 0.50000000 -0.50000000 -0.50000000 -0.50000000\n"
            "1e-07 0.0000 0.0000 0.0000 0.00000000 0.00000000 -0.17606820 -0.98437797\n");
}

// Brute force against printf: numbers of every magnitude up to 1e8, either sign, in every
// column (position, heading, pitch, roll, speed), come out as "%.4f" prints them (values within
// a hair of a rounding tie, where the writer rounds half away from zero and printf rounds the
// binary value, are left out).
TEST(TrajectoryWriter, WritesFourDecimalsAsPrintfDoes) {
  util::ScopedTempDir tmp;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> exponent(-6, 8), unit(0, 1);
  constexpr double kDeg = 180.0 / M_PI;
  auto near_tie = [](double v) {
    const double scaled = std::abs(v) * 1e4;
    return std::abs(scaled - std::floor(scaled) - 0.5) < 1e-6 * std::max(1.0, scaled * 1e-9);
  };
  // Per row the seven numbers as written (degrees for the angles) and the sample.
  std::vector<std::array<double, 7>> rows;
  std::vector<TrajectorySample> samples;
  while (rows.size() < 20000) {
    std::array<double, 7> v;
    for (double& x : v) x = (unit(rng) < 0.5 ? -1 : 1) * std::pow(10.0, exponent(rng));
    TrajectorySample p{1.0, v[0], v[1], v[2], std::abs(v[3]) / 1e8 * 359.0 / kDeg, v[4] / kDeg, v[5] / kDeg, v[6]};
    v[3] = p.heading_rad * kDeg;  // in [0, 360): written as it is
    v[4] = p.pitch_rad * kDeg;
    v[5] = p.roll_rad * kDeg;
    if (std::any_of(v.begin(), v.end(), near_tie)) continue;
    rows.push_back(v);
    samples.push_back(p);
  }
  {
    TrajectoryWriter writer(tmp.path() / "t.csv", {});
    for (const TrajectorySample& p : samples) writer.Add(p);
    writer.Commit();
  }
  char expected[64];
  for (int column = 0; column < 7; ++column) {
    const std::vector<std::string> written = CsvColumn(tmp.path() / "t.csv", column + 1);
    ASSERT_EQ(written.size(), rows.size());
    for (std::size_t i = 0; i < rows.size(); ++i) {
      std::snprintf(expected, sizeof(expected), "%.4f", rows[i][column]);
      std::string want = expected;
      if (want == "-0.0000") want = "0.0000";  // the writer never writes a negative zero
      ASSERT_EQ(written[i], want) << "column " << column << ", value " << rows[i][column];
    }
  }
}

// The same for the quaternion's 8 decimals in the TUM file: 20 000 components in [-1, 1].
TEST(TrajectoryWriter, WritesEightDecimalsAsPrintfDoes) {
  util::ScopedTempDir tmp;
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> component(-1, 1);
  std::vector<double> values;
  while (values.size() < 20000) {
    const double v = component(rng) * (values.size() % 7 == 0 ? 1e-5 : 1.0);  // small ones too
    const double scaled = std::abs(v) * 1e8;
    if (std::abs(scaled - std::floor(scaled) - 0.5) < 1e-6) continue;  // a hair from a tie
    values.push_back(v);
  }
  {
    TrajectoryWriter writer({}, tmp.path() / "t.tum");
    for (std::size_t i = 0; i + 4 <= values.size(); i += 4) {
      writer.Add(TrajectorySample{1.0, 0, 0, 0, 0, 0, 0, 0},
                 Eigen::Quaterniond(values[i + 3], values[i], values[i + 1], values[i + 2]));
    }
    writer.Commit();
  }
  std::ifstream in(tmp.path() / "t.tum");
  std::string line;
  std::size_t i = 0;
  char expected[64];
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream cells(line);
    std::string cell;
    for (int c = 0; c < 4; ++c) cells >> cell;  // time and position
    for (int c = 0; c < 4; ++c, ++i) {
      ASSERT_LT(i, values.size());
      cells >> cell;
      std::snprintf(expected, sizeof(expected), "%.8f", values[i]);
      std::string want = expected;
      if (want == "-0.00000000") want = "0.00000000";
      ASSERT_EQ(cell, want) << "component " << values[i];
    }
  }
  EXPECT_EQ(i, values.size());
}

// Time stamps are written as std::to_chars writes them (the shortest text that reads back):
// every whole second up to 3e5 s (fixed or scientific, as to_chars chooses), tenths up to
// 3e4 s, and others; the writer's fast paths must not differ.
TEST(TrajectoryWriter, WritesTimeStampsAsToCharsDoes) {
  util::ScopedTempDir tmp;
  std::vector<double> stamps;
  for (int i = 1; i <= 300000; ++i) stamps.push_back(i);
  for (int i = 1; i <= 300000; ++i) stamps.push_back(i / 10.0);
  for (double v : {1e8, 123456789.0, 999999999.0, 1e9, 0.05, 1234.5678, 1e-7, 3e10}) stamps.push_back(v);
  {
    TrajectoryWriter writer(tmp.path() / "t.csv", {});
    for (double t : stamps) writer.Add(TrajectorySample{t, 0, 0, 0, 0, 0, 0, 0});
    writer.Commit();
  }
  const std::vector<std::string> written = CsvColumn(tmp.path() / "t.csv", 0);
  ASSERT_EQ(written.size(), stamps.size());
  char expected[64];
  for (std::size_t i = 0; i < stamps.size(); ++i) {
    *std::to_chars(expected, expected + sizeof(expected), stamps[i]).ptr = '\0';
    ASSERT_EQ(written[i], expected) << "stamp " << stamps[i];
  }
}

TEST(TrajectoryWriter, LeavesNothingBehindWithoutCommit) {
  util::ScopedTempDir tmp;
  {
    TrajectoryWriter writer(tmp.path() / "t.csv", {});
    writer.Add(TrajectorySample{});
  }
  EXPECT_TRUE(std::filesystem::is_empty(tmp.path()));
}

}  // namespace
}  // namespace lunarnav::positioning
