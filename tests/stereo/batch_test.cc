#include "stereo/batch.h"

#include <gtest/gtest.h>

#include <fstream>

#include "util/errors.h"
#include "util/testing.h"

namespace lunarnav::stereo {
namespace {
namespace fs = std::filesystem;

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
