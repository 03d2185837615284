#include "stereo/disparity_filters.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "stereo/ncc_options.h"

namespace lunarnav::stereo {
namespace {

TEST(ParabolicPeakOffset, FindsTheVertexOfAParabola) {
  // c(t) = 1 - 0.3 (t - 0.27)^2 sampled at -1, 0, 1: the vertex is at 0.27.
  auto c = [](double t) { return 1.0 - 0.3 * (t - 0.27) * (t - 0.27); };
  EXPECT_NEAR(ParabolicPeakOffset(c(-1), c(0), c(1)), 0.27, 1e-12);
  EXPECT_NEAR(ParabolicPeakOffset(c(1), c(0), c(-1)), -0.27, 1e-12);
  EXPECT_EQ(ParabolicPeakOffset(0.5, 0.5, 0.5), 0.0);  // flat
}

TEST(MedianFilterDisparityGrid, ReplacesAnOutlierAndRejectsAnIsolatedMatch) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cv::Mat disparity(5, 5, CV_32FC1, cv::Scalar(10.0f));
  cv::Mat rejection(5, 5, CV_8UC1, cv::Scalar(0));
  disparity.at<float>(1, 1) = 30.0f;  // an outlier among accepted neighbours
  // Row 4: an accepted cell with only rejected evaluated neighbours.
  for (int c = 0; c < 5; ++c) {
    disparity.at<float>(3, c) = nan;
    rejection.at<std::uint8_t>(3, c) = static_cast<std::uint8_t>(Rejection::kLowCorrelation);
    disparity.at<float>(4, c) = nan;
    rejection.at<std::uint8_t>(4, c) = static_cast<std::uint8_t>(Rejection::kLowCorrelation);
  }
  disparity.at<float>(4, 2) = 12.0f;
  rejection.at<std::uint8_t>(4, 2) = 0;
  MedianFilterDisparityGrid(3, &disparity, &rejection);
  EXPECT_FLOAT_EQ(disparity.at<float>(1, 1), 10.0f);
  EXPECT_EQ(rejection.at<std::uint8_t>(4, 2), static_cast<int>(Rejection::kMedian));
  EXPECT_TRUE(std::isnan(disparity.at<float>(4, 2)));
  EXPECT_EQ(rejection.at<std::uint8_t>(0, 0), 0);  // corner: 4 of 4 accepted
}

TEST(MedianFilterDisparityGrid, PreservesAPlane) {
  // The median of a linear function over a symmetric window is its centre value.
  cv::Mat disparity(9, 9, CV_32FC1), rejection(9, 9, CV_8UC1, cv::Scalar(0));
  for (int r = 0; r < 9; ++r)
    for (int c = 0; c < 9; ++c) disparity.at<float>(r, c) = 5.0f + 0.25f * c + 0.5f * r;
  const cv::Mat before = disparity.clone();
  MedianFilterDisparityGrid(5, &disparity, &rejection);
  EXPECT_EQ(cv::norm(disparity(cv::Rect(2, 2, 5, 5)), before(cv::Rect(2, 2, 5, 5)), cv::NORM_INF), 0);
}


// The filter against its definition, brute force, on random grids where accepted cells with a
// fully accepted neighbourhood (the fast path) sit next to cells without one.
TEST(MedianFilterDisparityGrid, MatchesItsDefinitionOnRandomGrids) {
  cv::RNG rng(5);
  for (int trial = 0; trial < 20; ++trial) {
    const int size = trial % 2 == 0 ? 3 : 5;
    const float nan = std::numeric_limits<float>::quiet_NaN();
    cv::Mat disparity(24, 31, CV_32FC1), rejection(24, 31, CV_8UC1);
    const double rejected_share = 0.05 + 0.4 * rng.uniform(0.0, 1.0);
    for (int r = 0; r < disparity.rows; ++r) {
      for (int c = 0; c < disparity.cols; ++c) {
        const bool rejected = rng.uniform(0.0, 1.0) < rejected_share;
        const int code = rejected ? rng.uniform(1, kNumRejectionCodes) : 0;
        rejection.at<std::uint8_t>(r, c) = static_cast<std::uint8_t>(code);
        disparity.at<float>(r, c) = rejected ? nan : static_cast<float>(rng.uniform(0.0, 50.0));
      }
    }
    cv::Mat expected_d = disparity.clone(), expected_r = rejection.clone();
    const int half = size / 2;
    for (int r = 0; r < disparity.rows; ++r) {
      for (int c = 0; c < disparity.cols; ++c) {
        if (rejection.at<std::uint8_t>(r, c) != 0) continue;
        std::vector<float> values;
        int evaluated = 0;
        for (int rr = std::max(0, r - half); rr <= std::min(disparity.rows - 1, r + half); ++rr) {
          for (int cc = std::max(0, c - half); cc <= std::min(disparity.cols - 1, c + half); ++cc) {
            const int code = rejection.at<std::uint8_t>(rr, cc);
            if (code == 0) values.push_back(disparity.at<float>(rr, cc));
            evaluated += code != static_cast<int>(Rejection::kNotEvaluated) && code != static_cast<int>(Rejection::kBorder);
          }
        }
        if (2 * static_cast<int>(values.size()) < evaluated) {
          expected_d.at<float>(r, c) = nan;
          expected_r.at<std::uint8_t>(r, c) = static_cast<std::uint8_t>(Rejection::kMedian);
          continue;
        }
        std::sort(values.begin(), values.end());
        const std::size_t n = values.size();
        expected_d.at<float>(r, c) = n % 2 == 1 ? values[n / 2] : 0.5f * (values[n / 2 - 1] + values[n / 2]);
      }
    }
    MedianFilterDisparityGrid(size, &disparity, &rejection);
    EXPECT_EQ(cv::countNonZero(rejection != expected_r), 0) << "trial " << trial;
    int differ = 0;
    for (int r = 0; r < disparity.rows; ++r) {
      for (int c = 0; c < disparity.cols; ++c) {
        const float a = disparity.at<float>(r, c), b = expected_d.at<float>(r, c);
        differ += !((std::isnan(a) && std::isnan(b)) || std::abs(a - b) <= 1e-5f);
      }
    }
    EXPECT_EQ(differ, 0) << "trial " << trial;
  }
}

}  // namespace
}  // namespace lunarnav::stereo
