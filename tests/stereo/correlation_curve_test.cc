#include "stereo/correlation_curve.h"

#include <gtest/gtest.h>

#include <cmath>

#include <opencv2/imgproc.hpp>

#include "sim/layered_scene.h"

namespace lunarnav::stereo {
namespace {

// A textured fronto-parallel plane at disparity d0 (integer, so the peak is exact).
sim::RenderedPair Plane(double d0) {
  sim::LayeredSceneOptions scene;
  scene.width = 200;
  scene.height = 120;
  sim::PlaneLayer plane;
  plane.d0_px = d0;
  scene.layers = {plane};
  return sim::RenderLayeredPair(scene);
}

NccOptions Options(int dx, int dy) {
  NccOptions o;
  o.half_window_x_px = 10;
  o.half_window_y_px = 8;
  o.step_x_px = dx;
  o.step_y_px = dy;
  o.min_disparity_px = 0;
  o.max_disparity_px = 40;
  return o;
}

// The window's grid samples gathered into a small image (rows j, columns i).
cv::Mat Gather(const cv::Mat& image, int x, int y, int mx, int my, int dx, int dy) {
  cv::Mat out(2 * my + 1, 2 * mx + 1, CV_8UC1);
  for (int j = -my; j <= my; ++j) {
    for (int i = -mx; i <= mx; ++i) out.at<std::uint8_t>(j + my, i + mx) = image.at<std::uint8_t>(y + j * dy, x + i * dx);
  }
  return out;
}

TEST(Correlation, EqualsOpenCvNormalizedCrossCorrelationOnTheWindowGrid) {
  const auto pair = Plane(17);
  for (const auto& [dx, dy] : std::vector<std::pair<int, int>>{{1, 1}, {3, 2}, {5, 4}}) {
    for (ReferenceImage reference : {ReferenceImage::kRight, ReferenceImage::kLeft}) {
      NccOptions o = Options(dx, dy);
      o.reference = reference;
      const int mx = o.half_window_x_px / dx, my = o.half_window_y_px / dy;
      const int x = 100, y = 60;
      for (int d : {0, 9, 17, 30}) {
        const bool right_ref = reference == ReferenceImage::kRight;
        const cv::Mat a = Gather(right_ref ? pair.right : pair.left, x, y, mx, my, dx, dy);
        const cv::Mat b = Gather(right_ref ? pair.left : pair.right, right_ref ? x + d : x - d, y, mx, my, dx, dy);
        cv::Mat score;
        cv::matchTemplate(a, b, score, cv::TM_CCOEFF_NORMED);
        EXPECT_NEAR(Correlation(pair.left, pair.right, o, x, y, d), score.at<float>(0, 0), 1e-4)
            << dx << "x" << dy << " d " << d;
      }
    }
  }
}

TEST(Correlation, IsUndefinedWhenTheWindowLeavesTheImage) {
  const auto pair = Plane(17);
  const NccOptions o = Options(1, 1);
  EXPECT_TRUE(std::isnan(Correlation(pair.left, pair.right, o, 5, 60, 0)));     // left edge
  EXPECT_TRUE(std::isnan(Correlation(pair.left, pair.right, o, 185, 60, 10)));  // match beyond the right edge
  EXPECT_TRUE(std::isnan(Correlation(pair.left, pair.right, o, 100, 3, 0)));    // top edge
  EXPECT_FALSE(std::isnan(Correlation(pair.left, pair.right, o, 100, 60, 10)));
}

TEST(CorrelationCurve, PeaksAtTheTrueDisparityForEverySubsampling) {
  // Figure 5's claim: partial subsampling keeps the best disparity.
  const auto pair = Plane(17);
  for (int dx : {1, 3, 5}) {
    for (int dy : {1, 2, 4}) {
      const CorrelationCurve c = ComputeCorrelationCurve(pair.left, pair.right, Options(dx, dy), 90, 60);
      ASSERT_EQ(c.values.size(), 41u);
      EXPECT_EQ(c.best_disparity_px, 17) << dx << "x" << dy;
      // The parabola has its usual small bias on the coarse (few-sample) windows.
      EXPECT_NEAR(c.subpixel_disparity_px, 17, 0.25) << dx << "x" << dy;
      EXPECT_GT(c.best_correlation, 0.9);
      EXPECT_DOUBLE_EQ(c.values[17], c.best_correlation);
    }
  }
}

TEST(CorrelationCurve, ConventionalSubsamplingSearchesMultiplesOfTheStep) {
  const auto pair = Plane(17);
  const CorrelationCurve c = ComputeConventionalCurve(pair.left, pair.right, Options(5, 4), 90, 60);
  EXPECT_EQ(c.min_disparity_px, 0);
  EXPECT_EQ(c.values.size(), 9u);  // d = 0, 5, ..., 40
  // The true 17 px is 3.4 decimated columns: the nearest searched disparity, 15 (2 px off),
  // beats 20 (3 px off), and the search cannot do better than that.
  EXPECT_EQ(c.best_disparity_px, 15);
  EXPECT_GT(c.values[3], c.values[4]);  // C(15) > C(20)
  const CorrelationCurve full = ComputeConventionalCurve(pair.left, pair.right, Options(1, 1), 90, 60);
  EXPECT_EQ(full.best_disparity_px, 17);  // no subsampling: the plain curve
}

}  // namespace
}  // namespace lunarnav::stereo
