#include "sim/layered_scene.h"

#include <gtest/gtest.h>

#include <cmath>

namespace lunarnav::sim {
namespace {

TEST(RenderLayeredPair, LeftPixelShowsTheSurfacePointOfItsTruthDisparity) {
  // Without noise or sampling, I_l(x + d(x), y) = I_r(x, y) up to quantisation, where d is
  // the right-reference truth; and the left-reference truth is consistent with it.
  LayeredSceneOptions scene;
  scene.width = 120;
  scene.height = 40;
  scene.samples_per_axis = 1;
  PlaneLayer plane;
  plane.d0_px = 10.0;
  plane.slope_x = 0.05;  // so d is an integer at x = 0, 20, 40, ...
  scene.layers = {plane};
  const RenderedPair pair = RenderLayeredPair(scene);
  for (int x = 0; x <= 80; x += 20) {
    const float d = pair.disparity_right_px.at<float>(20, x);
    EXPECT_FLOAT_EQ(d, 10.0f + 0.05f * x);
    const int xl = x + static_cast<int>(d);
    EXPECT_NEAR(pair.left.at<std::uint8_t>(20, xl), pair.right.at<std::uint8_t>(20, x), 1);
    EXPECT_NEAR(pair.disparity_left_px.at<float>(20, xl), d, 1e-4);
  }
}

TEST(RenderLayeredPair, NearerLayerOccludesAndIsDeterministic) {
  LayeredSceneOptions scene;
  scene.width = 100;
  scene.height = 50;
  PlaneLayer back, box;
  back.d0_px = 5;
  box.d0_px = 15;
  box.support_right = cv::Rect2d(30, 10, 20, 20);
  scene.layers = {back, box};
  const RenderedPair a = RenderLayeredPair(scene), b = RenderLayeredPair(scene);
  EXPECT_EQ(cv::norm(a.left, b.left, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(a.right, b.right, cv::NORM_INF), 0);
  EXPECT_FLOAT_EQ(a.disparity_right_px.at<float>(20, 40), 15.0f);
  EXPECT_FLOAT_EQ(a.disparity_right_px.at<float>(5, 40), 5.0f);
  // In the left view the box appears 15 px to the right.
  EXPECT_FLOAT_EQ(a.disparity_left_px.at<float>(20, 55), 15.0f);
}

}  // namespace
}  // namespace lunarnav::sim
