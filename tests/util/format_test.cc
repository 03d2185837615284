// util::Format: the whole text, however long the values make it.
#include "util/format.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <string>

namespace lunarnav::util {
namespace {

TEST(Format, GivesTheWholeTextOfAnyLength) {
  EXPECT_EQ(Format("%s,%.4f,%d", "000001", 5.28459, 7), "000001,5.2846,7");
  EXPECT_EQ(Format("%s", ""), "");
  // 1e300 with six decimals: 301 digits, a point and six more, where fixed buffers of 96-320
  // bytes cut output rows.
  const std::string big = Format(",%.6f,%.6f\n", 1e300, -1e300);
  EXPECT_EQ(big.size(), 1 + 308 + 1 + 309 + 1);
  char expected[400];
  std::snprintf(expected, sizeof expected, "%.6f", 1e300);
  EXPECT_EQ(big.substr(1, 308), expected);
  EXPECT_EQ(big.back(), '\n');
}

}  // namespace
}  // namespace lunarnav::util
