#include "io/json_io.h"
#include "io/nesting.h"

#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "util/errors.h"
#include "util/testing.h"

namespace lunarnav::io {
namespace {

// Whatever is wrong with a JSON file is bad input naming the file: its syntax, and numbers
// beyond a double's range ("1e999", which the parser reports as another kind of error).
TEST(ReadJson, BadSyntaxAndOverflowingNumbersAreInputErrorsNamingTheFile) {
  util::ScopedTempDir tmp;
  const auto path = tmp.path() / "rig.json";
  for (const std::string text : {"{\"focal_px\": 1e999}", "{\"focal_px\": }", "[1, 2"}) {
    std::ofstream(path, std::ios::trunc) << text;
    try {
      ReadJson(path);
      ADD_FAILURE() << "no error for " << text;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(path.string()), std::string::npos) << e.what();
    }
  }
  std::ofstream(path, std::ios::trunc) << "{\"focal_px\": 1e300}";
  EXPECT_DOUBLE_EQ(ReadJson(path)["focal_px"].get<double>(), 1e300);
}

// A file whose size its writer chose is refused from its size before reading, and once it
// holds more values than allowed while parsing; within both it reads as ReadJson does.
TEST(ReadJsonBounded, RefusesFilesAboveTheirSizeOrValueCountNamingTheLimit) {
  util::ScopedTempDir tmp;
  const auto path = tmp.path() / "summary.shard-0-of-2.json";
  std::ofstream(path) << "{\"a\": [1, 2, 3], \"b\": {\"c\": \"x\"}}";  // 7 values: the object, [1, 2, 3] and its three, b's object and "x"
  EXPECT_EQ(ReadJsonBounded(path, 1000, 7), ReadJson(path));
  auto refused = [&](std::uintmax_t bytes, long values, const std::string& words) {
    try {
      ReadJsonBounded(path, bytes, values);
      ADD_FAILURE() << "accepted: " << words;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  refused(1000, 6, "summary.shard-0-of-2.json: more than 6 JSON values");
  refused(20, 100, "summary.shard-0-of-2.json: 33 bytes, more than the 20");
  // ReadJson, for every JSON file a tool reads, holds 4 million values at most.
  {
    std::ofstream out(path);
    out << "[0";
    for (int i = 0; i < 4'000'000; ++i) out << ",0";
    out << "]";
  }
  try {
    ReadJson(path);
    ADD_FAILURE() << "accepted 4,000,002 values";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("more than 4000000 JSON values"), std::string::npos) << e.what();
  }
}

// The nesting bound counts what a recursive parser descends, with hand-counted depths:
// YAML flow collections, block levels by indentation and "- " entries, XML elements; brackets
// inside quoted scalars and comments are text, not levels.
TEST(NestingDepth, CountsFlowBlockAndXmlLevelsButNotQuotedOrCommentedBrackets) {
  // An OpenCV calibration: M1 (level 1), its map (2), data's list (3).
  const std::string opencv =
      "%YAML:1.0\n---\nM1: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
      "   data: [ 800., 0., 320., 0., 800., 240., 0., 0., 1. ]\n";
  EXPECT_EQ(FirstLineDeeperThan(opencv, 3), std::nullopt);
  EXPECT_EQ(FirstLineDeeperThan(opencv, 2), 7);  // the data list is the third level
  EXPECT_EQ(FirstLineDeeperThan("a: [[[1]]]\n", 4), std::nullopt);
  EXPECT_EQ(FirstLineDeeperThan("a: [[[1]]]\n", 3), 1);
  EXPECT_EQ(FirstLineDeeperThan("a:\n  b:\n    c: 1\n  d: 2\n", 3), std::nullopt);
  EXPECT_EQ(FirstLineDeeperThan("a:\n  b:\n    c: 1\n  d: 2\n", 2), 3);
  EXPECT_EQ(FirstLineDeeperThan("a:\n  - - - 1\n", 4), 2);  // a, the line, three entries
  EXPECT_EQ(FirstLineDeeperThan("a:\n  - - - 1\n", 5), std::nullopt);
  // A flow collection over several lines is counted across them.
  EXPECT_EQ(FirstLineDeeperThan("a: [\n [\n  [\n   1]]]\n", 3), 3);
  // Quoted and commented brackets are text.
  EXPECT_EQ(FirstLineDeeperThan("a: \"[[[[\\\"[[\" # [[[[\nb: 'it''s [[[['\n", 1), std::nullopt);
  // An apostrophe inside a plain scalar does not open a quote that would hide brackets.
  EXPECT_EQ(FirstLineDeeperThan("a: it's [[[[1]]]]\n", 3), 1);
  // XML: elements open and close; declarations, comments and empty elements add nothing.
  const std::string xml =
      "<?xml version=\"1.0\"?>\n<opencv_storage>\n<M1 type_id=\"opencv-matrix\">\n"
      "  <rows>3</rows><empty/><!-- <a><b><c> --><![CDATA[<a><b>]]>\n</M1>\n</opencv_storage>\n";
  EXPECT_EQ(FirstLineDeeperThan(xml, 3), std::nullopt);
  EXPECT_EQ(FirstLineDeeperThan(xml, 2), 4);
  EXPECT_EQ(FirstLineDeeperThan(std::string(100000, '<') + "a>", 64), std::nullopt);  // '<<<' is not an element
  std::string deep_xml;
  for (int i = 0; i < 100; ++i) deep_xml += "<a>";
  EXPECT_EQ(FirstLineDeeperThan(deep_xml, 64), 1);
}

// A configuration file is refused before it is parsed: larger than the limit (from its size,
// before reading), or nested deeper than 64 levels, each naming the file.
TEST(ReadConfigText, RefusesFilesTooLargeOrTooDeepNamingThem) {
  util::ScopedTempDir tmp;
  const auto path = tmp.path() / "calib.yml";
  std::ofstream(path) << "a: " << std::string(65, '[') << std::string(65, ']') << "\n";
  try {
    ReadConfigText(path);
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("calib.yml: line 1: nested deeper than 64 levels"), std::string::npos)
        << e.what();
  }
  std::ofstream(path) << "a: " << std::string(63, '[') << std::string(63, ']') << "\n";  // 1 + 63 levels
  EXPECT_EQ(ReadConfigText(path).size(), 3u + 126u + 1u);
  try {
    ReadConfigText(path, 100);
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("calib.yml: 130 bytes, more than"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ReadConfigText(tmp.path() / "missing.yml"), InputError);
}

}  // namespace
}  // namespace lunarnav::io
