#include "io/atomic_file.h"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "util/testing.h"

namespace lunarnav::io {
namespace {
namespace fs = std::filesystem;

TEST(WriteFileAtomic, WritesCompleteFilesAndLeavesNoTemporary) {
  util::ScopedTempDir tmp;
  const fs::path path = tmp.path() / "sub" / "a.txt";
  WriteFileAtomic(path, "hello");
  WriteFileAtomic(path, "world!");
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_EQ(text.str(), "world!");
  int entries = 0;
  for (const auto& e : fs::directory_iterator(path.parent_path())) entries += e.is_regular_file();
  EXPECT_EQ(entries, 1);
}

TEST(RemoveStaleTempFiles, RemovesOnlyTemporaries) {
  util::ScopedTempDir tmp;
  const fs::path temp = TempPathFor(tmp.path() / "x.pfm");
  EXPECT_TRUE(IsTempFileName(temp));
  EXPECT_FALSE(IsTempFileName(tmp.path() / "x.pfm"));
  std::ofstream(temp) << "half";
  std::ofstream(tmp.path() / "keep.pfm") << "whole";
  EXPECT_EQ(RemoveStaleTempFiles(tmp.path()), 1);
  EXPECT_FALSE(fs::exists(temp));
  EXPECT_TRUE(fs::exists(tmp.path() / "keep.pfm"));
}

}  // namespace
}  // namespace lunarnav::io
