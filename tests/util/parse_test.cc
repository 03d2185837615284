#include "util/parse.h"

#include <gtest/gtest.h>

#include <stdexcept>

namespace lunarnav::util {
namespace {

TEST(ParseIntPair, ParsesAndRejects) {
  EXPECT_EQ(ParseIntPair("25x17", 'x', "window"), std::make_pair(25, 17));
  EXPECT_EQ(ParseIntPair("-4:118", ':', "disparity"), std::make_pair(-4, 118));
  EXPECT_THROW(ParseIntPair("25", 'x', "window"), std::invalid_argument);
  EXPECT_THROW(ParseIntPair("25xa", 'x', "window"), std::invalid_argument);
  EXPECT_THROW(ParseIntPair("2.5x3", 'x', "window"), std::invalid_argument);
}

TEST(ParseDoublePair, ParsesIntervalsAndRejectsHalfOnes) {
  EXPECT_EQ(ParseDoublePair("4.2:7.5", ':', "range"), std::make_pair(4.2, 7.5));
  EXPECT_EQ(ParseDoublePair("-0.5:1", ':', "range"), std::make_pair(-0.5, 1.0));
  EXPECT_THROW(ParseDoublePair("4.2", ':', "range"), std::invalid_argument);
  EXPECT_THROW(ParseDoublePair("4.2:", ':', "range"), std::invalid_argument);
}

TEST(ParseDouble, RejectsTrailingTextAndNonFinite) {
  EXPECT_DOUBLE_EQ(ParseDouble("0.25", "x"), 0.25);
  EXPECT_THROW(ParseDouble("0.25m", "x"), std::invalid_argument);
  EXPECT_THROW(ParseDouble("inf", "x"), std::invalid_argument);
  EXPECT_THROW(ParseDouble("", "x"), std::invalid_argument);
}

}  // namespace
}  // namespace lunarnav::util
