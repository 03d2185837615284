#include "io/atomic_file.h"

#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <sstream>
#include <string>

#include "util/errors.h"
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

TEST(RemoveStaleTempFiles, RemovesOnlyTemporariesOfRunsThatAreOver) {
  util::ScopedTempDir tmp;
  const fs::path temp = TempPathFor(tmp.path() / "x.pfm");
  EXPECT_TRUE(IsTempFileName(temp));
  EXPECT_FALSE(IsTempFileName(tmp.path() / "x.pfm"));
  std::ofstream(temp) << "half";
  std::ofstream(tmp.path() / "keep.pfm") << "whole";
  // This process's file is being written: kept.
  EXPECT_EQ(RemoveStaleTempFiles(tmp.path()), 0);
  EXPECT_TRUE(fs::exists(temp));
  // The same name from a process of this host that has ended (a child, reaped): deleted.
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) _exit(0);
  waitpid(child, nullptr, 0);
  std::string dead = temp.filename().string();
  const std::string own_pid = "-" + std::to_string(getpid()) + ".";
  dead.replace(dead.find(own_pid), own_pid.size(), "-" + std::to_string(child) + ".");
  std::ofstream(tmp.path() / dead) << "half";
  // Another host's: kept while recent (a shard on another node may be writing it), deleted
  // once untouched for more than an hour.
  const fs::path recent = tmp.path() / ".y.pfm.othernode-12.0.lunarnav-tmp";
  const fs::path old = tmp.path() / ".z.pfm.othernode-12.1.lunarnav-tmp";
  std::ofstream(recent) << "half";
  std::ofstream(old) << "half";
  fs::last_write_time(old, fs::file_time_type::clock::now() - std::chrono::hours(2));
  EXPECT_EQ(RemoveStaleTempFiles(tmp.path()), 2);
  EXPECT_FALSE(fs::exists(tmp.path() / dead));
  EXPECT_FALSE(fs::exists(old));
  EXPECT_TRUE(fs::exists(recent));
  EXPECT_TRUE(fs::exists(temp));
  EXPECT_TRUE(fs::exists(tmp.path() / "keep.pfm"));
}

// An input directory that is not one says which: missing, or a file.
TEST(CheckInputDirectory, SaysMissingOrAFile) {
  util::ScopedTempDir tmp;
  EXPECT_NO_THROW(CheckInputDirectory(tmp.path()));
  std::ofstream(tmp.path() / "f") << "x";
  auto message = [](const fs::path& p, const std::string& hint) {
    try {
      CheckInputDirectory(p, hint);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_EQ(message(tmp.path() / "f", ""), (tmp.path() / "f").string() + ": not a directory (a file)");
  EXPECT_EQ(message(tmp.path() / "none", "(run X)"), (tmp.path() / "none").string() + ": no such directory (run X)");
}

}  // namespace
}  // namespace lunarnav::io
