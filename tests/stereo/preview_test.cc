#include "stereo/preview.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include <opencv2/imgproc.hpp>

namespace lunarnav::stereo {
namespace {

// A 40 x 30 result: accepted disparities rising along x, a band of left-right rejections,
// rows not evaluated.
NccResult MakeResult() {
  NccResult r;
  r.disparity_px.create(30, 40, CV_32FC1);
  r.rejection.create(30, 40, CV_8UC1);
  r.correlation = cv::Mat(30, 40, CV_32FC1, cv::Scalar(0.9));
  for (int y = 0; y < 30; ++y) {
    for (int x = 0; x < 40; ++x) {
      Rejection code = y < 5 ? Rejection::kNotEvaluated : (x >= 30 ? Rejection::kLeftRightMismatch : Rejection::kAccepted);
      r.rejection.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(code);
      r.disparity_px.at<float>(y, x) =
          code == Rejection::kAccepted ? static_cast<float>(x) : std::numeric_limits<float>::quiet_NaN();
      ++r.summary.pixels_by_reason[static_cast<int>(code)];
    }
  }
  r.summary.evaluated_pixels = 25 * 40;
  return r;
}

TEST(DisparityPreview, ColoursAcceptedPixelsByDisparityAndRejectedOnesByReason) {
  const NccResult r = MakeResult();
  const cv::Mat grey(30, 40, CV_8UC1, cv::Scalar(100));
  const cv::Mat p = DisparityPreview(r, grey, 8, 1, 1, 0.0, 63.0);
  ASSERT_EQ(p.type(), CV_8UC3);
  EXPECT_EQ(p.cols, 40);
  EXPECT_GT(p.rows, 30);  // the legend below
  // Turbo at 12 / 63 of the range, from OpenCV's own colour map (grey level round(255 12 / 63)
  // = 49), not from the function that drew it.
  cv::Mat level(1, 1, CV_8UC1, cv::Scalar(49)), turbo;
  cv::applyColorMap(level, turbo, cv::COLORMAP_TURBO);
  EXPECT_EQ(p.at<cv::Vec3b>(10, 12), turbo.at<cv::Vec3b>(0, 0));
  // The ends: dark blue (BGR, blue dominant) at the near end of the scale, dark red at the far.
  const cv::Vec3b low = p.at<cv::Vec3b>(10, 12), first = DisparityColour(0.0, 0.0, 63.0), last = DisparityColour(63.0, 0.0, 63.0);
  EXPECT_GT(first[0], first[2]);
  EXPECT_GT(last[2], last[0]);
  EXPECT_NE(low, first);
  EXPECT_EQ(p.at<cv::Vec3b>(2, 2), cv::Vec3b(100, 100, 100));  // not evaluated: the image
  const cv::Vec3b lr = RejectionColour(Rejection::kLeftRightMismatch);
  const cv::Vec3b got = p.at<cv::Vec3b>(10, 35);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(got[k], (3 * lr[k] + 100) / 4);
  // Every reason has its own colour.
  for (int a = static_cast<int>(Rejection::kBorder); a < kNumRejectionCodes; ++a) {
    for (int b = a + 1; b < kNumRejectionCodes; ++b) {
      EXPECT_NE(RejectionColour(static_cast<Rejection>(a)), RejectionColour(static_cast<Rejection>(b))) << a << " " << b;
    }
  }
}

// With partial subsampling each grid pixel fills its cell.
TEST(DisparityPreview, GridPixelsFillTheirCells) {
  NccResult r = MakeResult();
  const cv::Mat grey(30, 40, CV_16UC1, cv::Scalar(1000));
  const cv::Mat p = DisparityPreview(r, grey, 12, 4, 3, 0.0, 63.0);
  // The cell of grid pixel (12, 9) takes that pixel's colour: Turbo at 12 / 63 (OpenCV's map).
  cv::Mat level(1, 1, CV_8UC1, cv::Scalar(49)), turbo;
  cv::applyColorMap(level, turbo, cv::COLORMAP_TURBO);
  EXPECT_EQ(p.at<cv::Vec3b>(9, 12), turbo.at<cv::Vec3b>(0, 0));
  EXPECT_EQ(p.at<cv::Vec3b>(10, 13), turbo.at<cv::Vec3b>(0, 0));
}

}  // namespace
}  // namespace lunarnav::stereo
