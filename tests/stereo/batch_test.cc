#include "stereo/batch.h"

#include <gtest/gtest.h>

#include <fstream>

#include "util/errors.h"
#include "util/testing.h"

namespace lunarnav::stereo {
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

TEST(BatchOptions, ValidatesShards) {
  BatchOptions options;
  options.shard_index = 3;
  options.shard_count = 3;
  EXPECT_THROW(options.Validate(), std::invalid_argument);
  options.shard_index = 2;
  EXPECT_NO_THROW(options.Validate());
  EXPECT_EQ(SummaryFileName(options), "summary.shard-2-of-3.json");
}

}  // namespace
}  // namespace lunarnav::stereo
