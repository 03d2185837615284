#include "telemetry/telemetry_csv.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <string>
#include <thread>

#include "util/errors.h"
#include "util/testing.h"

namespace lunarnav::telemetry {
namespace {

SensorModel Model() {
  return SensorModelFromJson(nlohmann::json::parse(R"({
    "format": "lunarnav.sensors/1",
    "channels": {
      "enc_fl": {"counts_per_revolution": 512, "wheel_radius_m": 0.2},
      "compass": {"scale": 0.35, "units": "deg"},
      "roll": {"column": "ROLL", "scale": 0.1, "offset": -51.2}
    }
  })"),
                             "model");
}

// Plain rows take a fast path, rows with spaces, signs or CR the general one: both must read
// the same values (and the fast path must not accept what the general one rejects).
TEST(ParseTelemetryCsv, PlainAndDecoratedRowsReadAlike) {
  const std::string header = "t,compass,enc_fl,extra\n";
  const std::string plain =
      header + "0.1,100,5,x\n1e-1,,0007,\n12345.678,1023,999999999999,9\n-2.5,-3,0,\n";
  const std::string decorated =
      header + " 0.1 , 100 , +5 , x\r\n1e-1 ,, 0007,\n12345.678, 1023 ,+999999999999 ,9\n-2.5,-3, 0 ,\r\n";
  const TelemetryLog a = ParseTelemetryCsv(plain, "plain.csv", Model());
  const TelemetryLog b = ParseTelemetryCsv(decorated, "decorated.csv", Model());
  ASSERT_EQ(a.size(), 4u);
  ASSERT_EQ(b.size(), 4u);
  const std::vector<double> compass = {100, std::nan(""), 1023, -3};
  const std::vector<double> encoder = {5, 7, 999999999999, 0};
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(a.t_s[i], b.t_s[i]);
    for (const TelemetryLog* log : {&a, &b}) {
      const double c = log->counts[static_cast<int>(Channel::kCompass)][i];
      EXPECT_TRUE(std::isnan(compass[i]) ? std::isnan(c) : c == compass[i]) << "row " << i;
      EXPECT_EQ(log->counts[static_cast<int>(Channel::kEncoderFrontLeft)][i], encoder[i]) << "row " << i;
    }
  }
  EXPECT_EQ(a.t_s[1], 0.1);
  EXPECT_EQ(a.t_s[2], 12345.678);
  for (const char* bad : {"0.1,1.5,5,x\n", "0.1,5,5\n", "0.1,5,5,x,y\n", "0.1,5a,5,x\n", "inf,5,5,x\n",
                          "0.1,++5,5,x\n", "0.1,5,99999999999999999999,x\n"}) {
    EXPECT_THROW(ParseTelemetryCsv(header + bad, "bad.csv", Model()), InputError) << bad;
  }
}

// Time stamps of every shape the logs have (tenths, milliseconds, microseconds, long decimal
// expansions, integers, a leading or trailing point) read to the very double std::from_chars
// reads, whichever path reads them.
TEST(ParseTelemetryCsv, ReadsTimeStampsAsFromCharsDoes) {
  std::mt19937_64 rng(11);
  std::uniform_int_distribution<int> decimals(0, 17), integer_digits(0, 9);
  std::string text = "t,compass\n";
  std::vector<std::string> stamps;
  for (int i = 0; i < 20000; ++i) {
    std::string stamp;
    const int whole = integer_digits(rng), fraction = decimals(rng);
    for (int d = 0; d < whole; ++d) stamp += static_cast<char>('0' + rng() % 10);
    if (fraction > 0 || whole == 0) stamp += '.';
    for (int d = 0; d < fraction || (whole == 0 && d == 0); ++d) stamp += static_cast<char>('0' + rng() % 10);
    stamps.push_back(stamp);
    text += stamp + ",1\n";
  }
  const TelemetryLog log = ParseTelemetryCsv(text, "stamps.csv", Model());
  ASSERT_EQ(log.size(), stamps.size());
  for (std::size_t i = 0; i < stamps.size(); ++i) {
    double expected = 0;
    std::from_chars(stamps[i].data(), stamps[i].data() + stamps[i].size(), expected);
    ASSERT_EQ(log.t_s[i], expected) << stamps[i];
  }
}

// Counts of every length (leading zeros too), empty cells, in the middle and at the end of
// rows, and the last row without a newline (fewer than eight bytes left to read): as
// std::from_chars reads them. 20 000 rows.
TEST(ParseTelemetryCsv, ReadsCountsAsFromCharsDoes) {
  std::mt19937_64 rng(12);
  std::uniform_int_distribution<int> length(0, 18);
  std::string text = "t,enc_fl,ROLL\n";
  std::vector<std::array<std::string, 2>> cells;
  for (int i = 0; i < 20000; ++i) {
    std::array<std::string, 2> row;
    for (std::string& cell : row) {
      const int n = length(rng);
      for (int d = 0; d < n; ++d) cell += static_cast<char>('0' + rng() % 10);
    }
    cells.push_back(row);
    text += std::to_string(i + 1) + "," + row[0] + "," + row[1] + (i + 1 < 20000 ? "\n" : "");
  }
  const TelemetryLog log = ParseTelemetryCsv(text, "counts.csv", Model());
  ASSERT_EQ(log.size(), cells.size());
  const std::vector<double>* columns[2] = {&log.counts[static_cast<int>(Channel::kEncoderFrontLeft)],
                                           &log.counts[static_cast<int>(Channel::kRoll)]};
  for (std::size_t i = 0; i < cells.size(); ++i) {
    for (int c = 0; c < 2; ++c) {
      const std::string& cell = cells[i][c];
      const double got = (*columns[c])[i];
      if (cell.empty()) {
        ASSERT_TRUE(std::isnan(got)) << "row " << i;
        continue;
      }
      long long expected = 0;
      std::from_chars(cell.data(), cell.data() + cell.size(), expected);
      ASSERT_EQ(got, static_cast<double>(expected)) << "row " << i << ": '" << cell << "'";
    }
  }
}

// The same rows amid a long log (where the fast path reads 64 bytes at a time and the bytes
// before the row): the good ones read as alone, every bad one still an error on its line.
TEST(ParseTelemetryCsv, RowsAmidALongLogReadAsAlone) {
  const std::string header = "enc_fl,extra,t,compass\n";  // the time column not first
  std::string good_rows;
  for (int i = 0; i < 10; ++i) good_rows += "7,x," + std::to_string(i) + ".25,100\n";
  for (const char* row : {"5,,0.1,", "0007,ab,.5,1023", "12345678,9,12345678.12345,0", "1,1,5.,2", "1,1,-0.5,2",
                          "123456789,1,1,1", "1,1,1234567.123456789,1"}) {
    const TelemetryLog alone = ParseTelemetryCsv(header + row + "\n", "alone.csv", Model());
    const TelemetryLog amid = ParseTelemetryCsv(header + good_rows + row + "\n" + good_rows, "amid.csv", Model());
    ASSERT_EQ(amid.size(), 21u) << row;
    EXPECT_EQ(amid.t_s[10], alone.t_s[0]) << row;
    for (Channel c : {Channel::kEncoderFrontLeft, Channel::kCompass}) {
      const double a = alone.counts[static_cast<int>(c)][0], b = amid.counts[static_cast<int>(c)][10];
      EXPECT_TRUE(a == b || (std::isnan(a) && std::isnan(b))) << row;
    }
  }
  for (const char* bad : {"1,x,0.1,1.5", "1,x,0.1.2,5", "1,x,0.1", "1,x,0.1,5,6", "1,x,0.1,5a", "1.,x,0.1,5",
                          "1,x,,5", "1,x,.,5", "1,x,0.1,++5", "1,x,0.1,99999999999999999999"}) {
    try {
      ParseTelemetryCsv(header + good_rows + bad + "\n" + good_rows, "amid.csv", Model());
      ADD_FAILURE() << "accepted: " << bad;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("amid.csv:12"), std::string::npos) << e.what();
    }
  }
}

TEST(ParseTelemetryCsv, TimeStampsInTheDeclaredUnitsBecomeSeconds) {
  // Unix epoch nanoseconds, milliseconds and seconds of the same rows, 20 ms apart.
  const std::string ns = "t,compass\n1700000000000000000,1\n1700000000020000000,2\n";
  const std::string ms = "t,compass\n1700000000000,1\n1700000000020,2\n";
  const std::string s = "t,compass\n1700000000.00,1\n1700000000.02,2\n";
  SensorModel model = Model();
  model.time_units = TimeUnits::kNanoseconds;
  const TelemetryLog a = ParseTelemetryCsv(ns, "ns.csv", model);
  model.time_units = TimeUnits::kMilliseconds;
  const TelemetryLog b = ParseTelemetryCsv(ms, "ms.csv", model);
  model.time_units = TimeUnits::kSeconds;
  const TelemetryLog c = ParseTelemetryCsv(s, "s.csv", model);
  for (const TelemetryLog* log : {&a, &b, &c}) {
    ASSERT_EQ(log->size(), 2u);
    EXPECT_NEAR(log->t_s[0], 1.7e9, 1e-6);
    EXPECT_NEAR(log->t_s[1] - log->t_s[0], 0.02, 1e-6);
  }
}

TEST(ParseTelemetryCsv, ReadsColumnsByNameWithGapsAndComments) {
  const std::string text =
      "# logger v2\n"
      "t, compass, enc_fl, extra\n"
      "0.0, 100, 5, 1\n"
      "\n"
      "0.1,, 7, 2\r\n"
      "# pause\n"
      "0.2, 102, +9, 3\n";
  const TelemetryLog log = ParseTelemetryCsv(text, "log.csv", Model());
  ASSERT_EQ(log.size(), 3u);
  EXPECT_EQ(log.t_s[2], 0.2);
  EXPECT_EQ(log.line[0], 3);
  EXPECT_EQ(log.line[2], 7);
  EXPECT_TRUE(std::isnan(log.counts[static_cast<int>(Channel::kCompass)][1]));
  EXPECT_EQ(log.counts[static_cast<int>(Channel::kEncoderFrontLeft)][2], 9);
  EXPECT_FALSE(log.Has(Channel::kRoll));
  ASSERT_EQ(log.missing_columns.size(), 1u);
  EXPECT_EQ(log.missing_columns[0], Channel::kRoll);
  EXPECT_EQ(log.unused_columns, std::vector<std::string>{"extra"});
}

TEST(ParseTelemetryCsv, ErrorsNameTheFileAndLine) {
  auto expect_error = [](const std::string& text, const std::string& words) {
    try {
      ParseTelemetryCsv(text, "log.csv", Model());
      ADD_FAILURE() << "accepted: " << words;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  expect_error("", "log.csv: no header");
  expect_error("time,compass\n0,1\n", "log.csv:1: missing required column 't'");
  expect_error("t,compass\n0,1\n0.1,abc\n", "log.csv:3: column 'compass': 'abc' is not an integer count");
  expect_error("t,compass\n0,1\n0.1,1.5\n", "log.csv:3");
  expect_error("t,compass\n0,1\n0.1\n", "log.csv:3: 1 cells, the header has 2");
  expect_error("t,compass\nx,1\n", "log.csv:2: column 't': 'x' is not a time stamp");
  // The cell count is checked before the cells' text; the text is quoted trimmed.
  expect_error("t,compass\n0,1\nx,abc,3\n", "log.csv:3: 3 cells, the header has 2");
  expect_error("t,compass\n0,1\n0.1, a b \r\n", "log.csv:3: column 'compass': 'a b' is not an integer count");
  // A NUL in a cell is shown, not the end of the message.
  expect_error(std::string("t,compass\n0,1\n0.1,a\0b\n", 22), "log.csv:3: column 'compass': 'a\\x00b' is not an integer count");
  // A column named twice is ambiguous: both are named.
  expect_error("t,compass,compass\n0,1,2\n", "log.csv:1: column 'compass' appears twice (columns 2 and 3)");
}

// Spreadsheets start their CSV files with a UTF-8 byte-order mark.
TEST(ParseTelemetryCsv, AcceptsAByteOrderMark) {
  const TelemetryLog plain = ParseTelemetryCsv("t,compass\n0,1\n0.1,2\n", "log.csv", Model());
  const TelemetryLog marked = ParseTelemetryCsv("\xEF\xBB\xBFt,compass\n0,1\n0.1,2\n", "log.csv", Model());
  EXPECT_EQ(plain.t_s, marked.t_s);
  EXPECT_EQ(marked.t_s.size(), 2u);
  // Before a comment line too (the mark was taken for the header's first character).
  const TelemetryLog commented =
      ParseTelemetryCsv("\xEF\xBB\xBF# a log\nt,compass\n0,1\n0.1,2\n", "log.csv", Model());
  EXPECT_EQ(plain.t_s, commented.t_s);
}

void ExpectSameLog(const TelemetryLog& a, const TelemetryLog& b) {
  EXPECT_EQ(a.t_s, b.t_s);
  EXPECT_EQ(a.line, b.line);
  for (int c = 0; c < kNumChannels; ++c) {
    ASSERT_EQ(a.counts[c].size(), b.counts[c].size()) << c;
    for (std::size_t k = 0; k < a.counts[c].size(); ++k) {
      EXPECT_TRUE(a.counts[c][k] == b.counts[c][k] || (std::isnan(a.counts[c][k]) && std::isnan(b.counts[c][k])))
          << "channel " << c << ", row " << k;
    }
  }
}

// Regular files are mapped, other files (a pipe here) read: the same log either way.
TEST(ReadTelemetryCsv, ReadsFilesAndPipesAlike) {
  util::ScopedTempDir tmp;
  const std::string text = "t,compass,enc_fl\n0.0,100,5\n0.1,,7\n0.2,102,+9";  // no final newline
  const TelemetryLog expected = ParseTelemetryCsv(text, "log.csv", Model());
  ASSERT_EQ(expected.size(), 3u);
  std::ofstream(tmp.path() / "log.csv", std::ios::binary) << text;
  ExpectSameLog(ReadTelemetryCsv(tmp.path() / "log.csv", Model()), expected);

  const std::filesystem::path pipe = tmp.path() / "pipe.csv";
  ASSERT_EQ(mkfifo(pipe.c_str(), 0600), 0);
  std::thread writer([&] { std::ofstream(pipe, std::ios::binary) << text; });
  const TelemetryLog from_pipe = ReadTelemetryCsv(pipe, Model());
  writer.join();
  ExpectSameLog(from_pipe, expected);

  std::ofstream(tmp.path() / "empty.csv").close();
  EXPECT_THROW(ReadTelemetryCsv(tmp.path() / "empty.csv", Model()), InputError);
  EXPECT_THROW(ReadTelemetryCsv(tmp.path() / "missing.csv", Model()), InputError);
}

}  // namespace
}  // namespace lunarnav::telemetry
