#include "io/stereo_pairs.h"

#include <gtest/gtest.h>

#include <fstream>

#include "util/errors.h"
#include "util/testing.h"

namespace lunarnav::io {
namespace {
namespace fs = std::filesystem;

void Touch(const fs::path& path) {
  fs::create_directories(path.parent_path());
  std::ofstream(path) << "x";
}

TEST(ListStereoPairs, PairsByStemInNameOrderAndNamesEveryProblem) {
  util::ScopedTempDir tmp;
  const fs::path in = tmp.path();
  for (const char* stem : {"b", "a", "c10", "c9"}) {
    Touch(in / "left" / (std::string(stem) + ".png"));
    Touch(in / "right" / (std::string(stem) + ".png"));
  }
  Touch(in / "left" / "only_left.pgm");
  Touch(in / "right" / "only_right.tif");
  Touch(in / "left" / "twice.png");
  Touch(in / "left" / "twice.jpg");
  Touch(in / "right" / "twice.png");
  Touch(in / "left" / "notes.txt");      // not an image
  Touch(in / "left" / ".hidden.png");    // hidden
  const std::vector<PairFiles> pairs = ListStereoPairs(in);
  std::vector<std::string> stems;
  for (const PairFiles& p : pairs) stems.push_back(p.stem);
  EXPECT_EQ(stems, (std::vector<std::string>{"a", "b", "c10", "c9", "only_left", "only_right", "twice"}));
  EXPECT_TRUE(pairs[0].problem.empty());
  EXPECT_EQ(pairs[0].left, in / "left" / "a.png");
  EXPECT_NE(pairs[4].problem.find("missing"), std::string::npos);
  EXPECT_NE(pairs[5].problem.find("missing"), std::string::npos);
  EXPECT_NE(pairs[6].problem.find("several images"), std::string::npos);
}

TEST(ListStereoPairs, RejectsADirectoryWithoutBothSides) {
  util::ScopedTempDir tmp;
  EXPECT_THROW(ListStereoPairs(tmp.path() / "missing"), InputError);
  fs::create_directories(tmp.path() / "left");
  EXPECT_THROW(ListStereoPairs(tmp.path()), InputError);
}

TEST(SelectShard, TakesEveryNthItemFromK) {
  const std::vector<int> items = {0, 1, 2, 3, 4, 5, 6};
  std::vector<int> got;
  for (const int* item : SelectShard(items, 1, 3)) got.push_back(*item);
  EXPECT_EQ(got, (std::vector<int>{1, 4}));
  EXPECT_TRUE(SelectShard(std::vector<int>{}, 0, 1).empty());
  EXPECT_THROW(SelectShard(items, 3, 3), std::invalid_argument);
  EXPECT_THROW(SelectShard(items, 0, 0), std::invalid_argument);
  EXPECT_EQ(SummaryFileName(0, 1), "summary.json");
  EXPECT_EQ(SummaryFileName(2, 3), "summary.shard-2-of-3.json");
}

}  // namespace
}  // namespace lunarnav::io
