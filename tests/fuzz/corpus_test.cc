// Every fuzz target over its corpus (testdata/fuzz/TARGET/): the seeds, and every input that
// fuzzing once found to crash or misbehave (regression-*), kept as regression tests. A
// target returns when the input parsed or was refused with an InputError; anything else
// fails here. Seeds must parse.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "fuzz/targets.h"
#include "util/testing.h"

namespace lunarnav::fuzz {
namespace {
namespace fs = std::filesystem;

std::string ReadBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST(FuzzCorpus, EveryTargetTakesEveryInputOfItsCorpus) {
  for (const NamedTarget& target : AllTargets()) {
    const fs::path dir = util::TestDataPath("fuzz") / target.name;
    ASSERT_TRUE(fs::is_directory(dir)) << dir;
    int inputs = 0;
    for (const fs::directory_entry& entry : fs::directory_iterator(dir)) {
      if (!entry.is_regular_file()) continue;
      const std::string bytes = ReadBytes(entry.path());
      SCOPED_TRACE(entry.path().string());
      bool parsed = false;
      EXPECT_NO_THROW(parsed = target.run(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size()));
      // A seed is a good file (fuzzing starts from what parses); a regression input, named
      // regression-*, may rightly be refused.
      if (entry.path().filename().string().rfind("regression-", 0) != 0) {
        EXPECT_TRUE(parsed) << "a seed that does not parse";
      }
      ++inputs;
    }
    EXPECT_GE(inputs, 1) << target.name << ": no seed";
  }
}

}  // namespace
}  // namespace lunarnav::fuzz
