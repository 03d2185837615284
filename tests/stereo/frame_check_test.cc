#include "stereo/frame_check.h"

#include <gtest/gtest.h>

#include <stdexcept>

namespace lunarnav::stereo {
namespace {

TEST(CheckFrame, FlagsBlankAndSaturatedFramesOnly) {
  const FrameCheckOptions options;
  cv::Mat textured(60, 80, CV_8UC1);
  cv::randu(textured, 20, 230);
  EXPECT_FALSE(CheckFrame(options, textured).has_value());
  // A disconnected cable: black with a trace of noise (std dev 0.5 < 1 grey level).
  cv::Mat blank(60, 80, CV_8UC1, cv::Scalar(2));
  blank(cv::Rect(0, 0, 80, 3)).setTo(3);
  const auto blank_reason = CheckFrame(options, blank);
  ASSERT_TRUE(blank_reason.has_value());
  EXPECT_NE(blank_reason->find("blank"), std::string::npos);
  // Light overwhelming the iris: 70 % of the pixels at full scale (16-bit here).
  cv::Mat bright(60, 80, CV_16UC1, cv::Scalar(65535));
  cv::Mat rest = bright(cv::Rect(0, 0, 80, 18));
  cv::randu(rest, 0, 60000);
  const auto bright_reason = CheckFrame(options, bright);
  ASSERT_TRUE(bright_reason.has_value());
  EXPECT_NE(bright_reason->find("saturated"), std::string::npos);
  // Thresholds that disable the checks.
  FrameCheckOptions off;
  off.blank_max_sigma = 0;
  off.saturated_max_fraction = 1;
  EXPECT_FALSE(CheckFrame(off, blank).has_value());
  EXPECT_FALSE(CheckFrame(off, bright).has_value());
}

TEST(FrameCheckOptions, RejectsImpossibleThresholds) {
  FrameCheckOptions bad;
  bad.saturated_max_fraction = 0;
  EXPECT_THROW(bad.Validate(), std::invalid_argument);
  bad = FrameCheckOptions{};
  bad.blank_max_sigma = -1;
  EXPECT_THROW(bad.Validate(), std::invalid_argument);
}

}  // namespace
}  // namespace lunarnav::stereo
