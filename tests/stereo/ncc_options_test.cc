#include "stereo/ncc_options.h"

#include <gtest/gtest.h>

#include <stdexcept>

namespace lunarnav::stereo {
namespace {

TEST(NccOptions, DefaultsAreThePapers) {
  const NccOptions o;
  EXPECT_EQ(o.half_window_x_px, 25);  // 51 x 35 window (sec. 3.2)
  EXPECT_EQ(o.half_window_y_px, 17);
  EXPECT_EQ(o.min_sigma, 2.0);
  EXPECT_EQ(o.min_correlation, 0.5);
  EXPECT_EQ(o.ambiguity, 0.10);
  EXPECT_EQ(o.reference, ReferenceImage::kRight);
  EXPECT_NO_THROW(o.Validate());
}

TEST(NccOptions, ValidateNamesTheOffendingOption) {
  auto expect_invalid = [](NccOptions o, const std::string& name) {
    try {
      o.Validate();
      ADD_FAILURE() << name << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
  };
  NccOptions o;
  o.step_x_px = 0;
  expect_invalid(o, "step");
  o = NccOptions{};
  o.min_disparity_px = 10;
  o.max_disparity_px = 5;
  expect_invalid(o, "disparity");
  o = NccOptions{};
  o.min_row = 10;
  expect_invalid(o, "rows");
  o = NccOptions{};
  o.min_correlation = 1.5;
  expect_invalid(o, "c-min");
  o = NccOptions{};
  o.median_size = 2;
  expect_invalid(o, "median");
}

TEST(Rejection, NamesAndReferenceRoundTrip) {
  EXPECT_EQ(ToString(Rejection::kLowTexture), "low_texture");
  EXPECT_EQ(ToString(Rejection::kMedian), "median");
  EXPECT_EQ(ReferenceImageFromString(ToString(ReferenceImage::kLeft)), ReferenceImage::kLeft);
  EXPECT_THROW(ReferenceImageFromString("centre"), std::invalid_argument);
}

}  // namespace
}  // namespace lunarnav::stereo
