#include "stereo/window_requests.h"

#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "util/errors.h"
#include "util/testing.h"

namespace lunarnav::stereo {
namespace {
namespace fs = std::filesystem;

fs::path Write(const util::ScopedTempDir& tmp, const std::string& text) {
  const fs::path path = tmp.path() / "requests.csv";
  std::ofstream(path, std::ios::trunc) << text;
  return path;
}

TEST(ReadWindowRequests, ReadsStemsIntervalsAndLines) {
  util::ScopedTempDir tmp;
  const auto requests = ReadWindowRequests(
      Write(tmp, "# planner requests\nstem,y_min_m,y_max_m\r\nframe0001, 4.2, 7.5\r\n\n  frame0002 ,5,5\n"));
  ASSERT_EQ(requests.size(), 2u);
  EXPECT_EQ(requests[0].stem, "frame0001");
  EXPECT_DOUBLE_EQ(requests[0].y_min_m, 4.2);
  EXPECT_DOUBLE_EQ(requests[0].y_max_m, 7.5);
  EXPECT_EQ(requests[0].line, 3);
  EXPECT_EQ(requests[1].stem, "frame0002");
  EXPECT_EQ(requests[1].line, 5);
  EXPECT_TRUE(ReadWindowRequests(Write(tmp, "stem,y_min_m,y_max_m\n")).empty());
  // A spreadsheet's byte-order mark before the header.
  const auto bom = ReadWindowRequests(Write(tmp, "\xEF\xBB\xBFstem,y_min_m,y_max_m\na,2,3\n"));
  ASSERT_EQ(bom.size(), 1u);
  EXPECT_EQ(bom[0].stem, "a");
}

TEST(ReadWindowRequests, BadFilesNameTheLineAndTheReason) {
  util::ScopedTempDir tmp;
  struct Case {
    std::string text, expected;
  };
  for (const Case& c : std::vector<Case>{
           {"stem,y_min,y_max\na,4,5\n", "requests.csv:1: expected the header"},
           {"stem,y_min_m,y_max_m\na,4,five\n", "requests.csv:2: column 'y_max_m': 'five'"},
           {"stem,y_min_m,y_max_m\na,4,inf\n", "requests.csv:2: column 'y_max_m'"},
           {"stem,y_min_m,y_max_m\na,4 m,5\n", "requests.csv:2: column 'y_min_m'"},
           {"stem,y_min_m,y_max_m\na,4\n", "requests.csv:2: 2 cells"},
           {"stem,y_min_m,y_max_m\na,4,5,6\n", "requests.csv:2: 4 cells"},
           {"stem,y_min_m,y_max_m\n,4,5\n", "requests.csv:2: empty stem"},
           {"stem,y_min_m,y_max_m\na,6,5\n", "requests.csv:2: Y_min 6 m is greater than Y_max 5 m"},
           {"stem,y_min_m,y_max_m\na,5,8\nb,1e300,1e301\n", "requests.csv:3: Y 1e+300 to 1e+301 m: a request reaches at most 1000 m"},
           {"stem,y_min_m,y_max_m\na,4,5\nb,4,5\na,5,6\n", "requests.csv:4: stem 'a' already requested on line 2"},
           {"", "no header"},
           {"# only a comment\n", "no header"}}) {
    try {
      ReadWindowRequests(Write(tmp, c.text));
      ADD_FAILURE() << "accepted: " << c.text;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(c.expected), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(ReadWindowRequests(tmp.path() / "missing.csv"), InputError);
}

}  // namespace
}  // namespace lunarnav::stereo
