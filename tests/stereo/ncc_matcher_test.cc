#include "stereo/ncc_matcher.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "sim/layered_scene.h"
#include "stereo/correlation_curve.h"
#include "util/errors.h"

namespace lunarnav::stereo {
namespace {

using sim::LayeredSceneOptions;
using sim::PlaneLayer;
using sim::RenderLayeredPair;
using sim::TextureKind;

LayeredSceneOptions OnePlane(double d0, double slope_x, double slope_y, int width = 320,
                             int height = 240) {
  LayeredSceneOptions scene;
  scene.width = width;
  scene.height = height;
  PlaneLayer plane;
  plane.d0_px = d0;
  plane.slope_x = slope_x;
  plane.slope_y = slope_y;
  scene.layers = {plane};
  return scene;
}

// Absolute disparity errors at accepted pixels, and the fraction of evaluated pixels accepted.
struct ErrorStats {
  std::vector<double> errors;
  double accepted_fraction = 0;
  double Median() {
    std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
    return errors[errors.size() / 2];
  }
  double Quantile(double q) {
    std::sort(errors.begin(), errors.end());
    return errors[static_cast<std::size_t>(q * (errors.size() - 1))];
  }
  double Max() { return *std::max_element(errors.begin(), errors.end()); }
};

// Fraction accepted among pixels on the grid whose window, and whose true match's window,
// lie inside the images (right reference).
double AcceptedFractionWhereMatchable(const NccResult& result, const cv::Mat& truth,
                                      const NccOptions& o) {
  int total = 0, accepted = 0;
  for (int y = o.half_window_y_px; y + o.half_window_y_px < truth.rows; y += o.step_y_px) {
    for (int x = 0; x < truth.cols; x += o.step_x_px) {
      const double d = truth.at<float>(y, x);
      if (x - o.half_window_x_px < 0 || x + d + o.half_window_x_px + 1 > truth.cols - 1) continue;
      ++total;
      accepted += !std::isnan(result.disparity_px.at<float>(y, x));
    }
  }
  return total > 0 ? static_cast<double>(accepted) / total : 0.0;
}

ErrorStats Compare(const NccResult& result, const cv::Mat& truth) {
  ErrorStats stats;
  for (int y = 0; y < truth.rows; ++y) {
    for (int x = 0; x < truth.cols; ++x) {
      const float d = result.disparity_px.at<float>(y, x);
      if (std::isnan(d)) continue;
      stats.errors.push_back(std::abs(d - truth.at<float>(y, x)));
    }
  }
  stats.accepted_fraction = static_cast<double>(result.summary.accepted_pixels) /
                            std::max(1, result.summary.evaluated_pixels);
  return stats;
}

NccOptions SmallWindow() {
  NccOptions options;
  options.half_window_x_px = 7;
  options.half_window_y_px = 5;
  options.min_disparity_px = 0;
  options.max_disparity_px = 47;
  return options;
}

TEST(MatchStereoPair, RecoversSubPixelConstantShift) {
  // A fronto-parallel plane at 23.37 px: every accepted pixel within 0.1 px (issue 2).
  const auto pair = RenderLayeredPair(OnePlane(23.37, 0, 0));
  NccOptions options;  // the paper's defaults, 51 x 35 window
  options.max_disparity_px = 63;
  const NccResult result = MatchStereoPair(options, pair.left, pair.right);
  ErrorStats stats = Compare(result, pair.disparity_right_px);
  ASSERT_GT(stats.errors.size(), 10000u);
  EXPECT_LT(stats.Max(), 0.1);
  // Every pixel whose window and true match lie inside the images is accepted.
  EXPECT_EQ(AcceptedFractionWhereMatchable(result, pair.disparity_right_px, options), 1.0);
}

TEST(MatchStereoPair, RecoversSlantedPlane) {
  // d = 12 + 0.03 x + 0.06 y: a ground-like plane, disparity growing towards the bottom.
  const auto pair = RenderLayeredPair(OnePlane(12.0, 0.03, 0.06));
  NccOptions options = SmallWindow();
  const NccResult result = MatchStereoPair(options, pair.left, pair.right);
  ErrorStats stats = Compare(result, pair.disparity_right_px);
  ASSERT_GT(stats.errors.size(), 20000u);
  EXPECT_GT(AcceptedFractionWhereMatchable(result, pair.disparity_right_px, options), 0.99);
  EXPECT_LT(stats.Median(), 0.05);
  EXPECT_LT(stats.Quantile(0.99), 0.2);
}

TEST(MatchStereoPair, LeftReferenceMatchesLeftGroundTruth) {
  const auto pair = RenderLayeredPair(OnePlane(18.6, 0.02, 0.04));
  NccOptions options = SmallWindow();
  options.reference = ReferenceImage::kLeft;
  const NccResult result = MatchStereoPair(options, pair.left, pair.right);
  ErrorStats stats = Compare(result, pair.disparity_left_px);
  ASSERT_GT(stats.errors.size(), 20000u);
  EXPECT_LT(stats.Median(), 0.05);
  EXPECT_LT(stats.Quantile(0.99), 0.2);
  // Left reference: the columns where x - d leaves the right image have no disparity.
  EXPECT_TRUE(std::isnan(result.disparity_px.at<float>(120, 10)));
  EXPECT_FALSE(std::isnan(result.disparity_px.at<float>(120, 310)));
}

TEST(MatchStereoPair, CorrelationEqualsBruteForce) {
  // With dx = dy = 1 (and subsampled), C at the chosen disparity equals the paper's formula.
  const auto pair = RenderLayeredPair(OnePlane(9.4, 0.01, 0.03, 120, 90));
  for (const auto& [dx, dy] : std::vector<std::pair<int, int>>{{1, 1}, {3, 2}, {5, 4}}) {
    NccOptions options = SmallWindow();
    options.half_window_x_px = 10;
    options.half_window_y_px = 8;
    options.step_x_px = dx;
    options.step_y_px = dy;
    options.max_disparity_px = 24;
    options.median_size = 0;
    const NccResult result = MatchStereoPair(options, pair.left, pair.right);
    int checked = 0;
    for (int y = 0; y < pair.right.rows; y += dy) {
      for (int x = 0; x < pair.right.cols; x += dx) {
        const float c = result.correlation.at<float>(y, x);
        const float d = result.disparity_px.at<float>(y, x);
        if (std::isnan(c) || std::isnan(d)) continue;
        // The integer disparity is the literal formula's argmax, and C matches to 1e-4.
        const int d_int = static_cast<int>(std::lround(d));
        const CorrelationCurve curve = ComputeCorrelationCurve(pair.left, pair.right, options, x, y);
        const int best_d = curve.best_disparity_px;
        const double best = curve.best_correlation;
        ASSERT_EQ(best_d, d_int) << "at " << x << "," << y << " step " << dx << "x" << dy;
        ASSERT_NEAR(c, best, 1e-4) << "at " << x << "," << y << " step " << dx << "x" << dy;
        ++checked;
      }
    }
    EXPECT_GT(checked, 100) << "step " << dx << "x" << dy;
  }
}

TEST(MatchStereoPair, PartialSubsamplingKeepsFullResolutionDisparity) {
  // The claim of the paper's Figure 5: the integer disparity at a sampled pixel is the same
  // at every (dx, dy) in {1,3,5} x {1,2,4} as at full resolution, for >= 95 % of pixels.
  // As in the paper's experiment: boxes with fronto-parallel faces in front of a background.
  // Disparities are kept away from half-integers, where the integer argmax is a coin toss.
  sim::LayeredSceneOptions scene = OnePlane(14.2, 0, 0);
  PlaneLayer box;
  box.d0_px = 34.3;
  box.support_right = cv::Rect2d(120, 60, 90, 70);
  box.seed = 5;
  scene.layers.push_back(box);
  scene.noise_sigma = 1.0;
  const auto pair = RenderLayeredPair(scene);
  NccOptions options;
  options.max_disparity_px = 63;
  options.median_size = 0;
  const NccResult full = MatchStereoPair(options, pair.left, pair.right);
  for (int dx : {1, 3, 5}) {
    for (int dy : {1, 2, 4}) {
      NccOptions sub = options;
      sub.step_x_px = dx;
      sub.step_y_px = dy;
      const NccResult result = MatchStereoPair(sub, pair.left, pair.right);
      int both = 0, agree = 0;
      for (int y = 0; y < pair.right.rows; y += dy) {
        for (int x = 0; x < pair.right.cols; x += dx) {
          const float a = full.disparity_px.at<float>(y, x), b = result.disparity_px.at<float>(y, x);
          if (std::isnan(a) || std::isnan(b)) continue;
          ++both;
          agree += std::lround(a) == std::lround(b);
        }
      }
      ASSERT_GT(both, 200) << dx << "x" << dy;
      EXPECT_GE(agree, 0.95 * both) << dx << "x" << dy;
    }
  }
}

TEST(MatchStereoPair, FlatPatchIsRejectedForLowTexture) {
  sim::LayeredSceneOptions scene = OnePlane(10.0, 0, 0);
  PlaneLayer flat;
  flat.d0_px = 10.4;  // nearer than the background, so it is seen
  flat.texture = TextureKind::kFlat;
  flat.support_right = cv::Rect2d(100, 60, 120, 120);
  scene.layers.push_back(flat);
  const auto pair = RenderLayeredPair(scene);
  const NccResult result = MatchStereoPair(SmallWindow(), pair.left, pair.right);
  EXPECT_EQ(result.rejection.at<std::uint8_t>(120, 160), static_cast<int>(Rejection::kLowTexture));
  EXPECT_EQ(result.rejection.at<std::uint8_t>(20, 40), static_cast<int>(Rejection::kAccepted));
}

TEST(MatchStereoPair, RepetitivePatternIsRejectedAsAmbiguous) {
  // Stripes with a 9 px period: peaks every 9 px of almost equal height.
  sim::LayeredSceneOptions scene = OnePlane(20.0, 0, 0);
  scene.layers[0].texture = TextureKind::kStripes;
  scene.layers[0].texture_scale_px = 9.0;
  scene.noise_sigma = 1.0;
  const auto pair = RenderLayeredPair(scene);
  const NccResult result = MatchStereoPair(SmallWindow(), pair.left, pair.right);
  const int ambiguous = result.summary.pixels_by_reason[static_cast<int>(Rejection::kAmbiguous)];
  EXPECT_GT(ambiguous, 0.8 * result.summary.evaluated_pixels);
  // Only near the right edge, where the searchable range holds a single period, can a
  // pixel pass; nowhere else.
  EXPECT_EQ(cv::countNonZero(result.rejection(cv::Rect(0, 0, 300, 240)) == 0), 0);
}

TEST(MatchStereoPair, UnrelatedPatchIsRejectedForLowCorrelation) {
  // The left image shows something else in a region: no disparity correlates well there.
  auto pair = RenderLayeredPair(OnePlane(10.0, 0, 0));
  sim::LayeredSceneOptions other = OnePlane(0.0, 0, 0);
  other.layers[0].seed = 99;
  const auto unrelated = RenderLayeredPair(other);
  unrelated.left(cv::Rect(60, 40, 200, 160)).copyTo(pair.left(cv::Rect(60, 40, 200, 160)));
  NccOptions options = SmallWindow();
  const NccResult result = MatchStereoPair(options, pair.left, pair.right);
  int low = 0, total = 0;
  for (int y = 70; y < 170; ++y) {
    for (int x = 100; x < 200; ++x) {
      ++total;
      low += result.rejection.at<std::uint8_t>(y, x) == static_cast<int>(Rejection::kLowCorrelation);
    }
  }
  EXPECT_GT(low, 0.7 * total);
}

TEST(MatchStereoPair, ProcessesOnlyTheRowAndDisparityBands) {
  const auto pair = RenderLayeredPair(OnePlane(12.0, 0.0, 0.1));  // d = 12 .. 36 by row
  NccOptions options = SmallWindow();
  options.min_row = 100;
  options.max_row = 180;
  options.min_disparity_px = 20;
  options.max_disparity_px = 30;
  const NccResult result = MatchStereoPair(options, pair.left, pair.right);
  for (int y = 0; y < pair.right.rows; ++y) {
    const bool in_band = y >= 100 && y <= 180;
    const int code = result.rejection.at<std::uint8_t>(y, 160);
    EXPECT_EQ(code == static_cast<int>(Rejection::kNotEvaluated), !in_band) << "row " << y;
    const float d = result.disparity_px.at<float>(y, 160);
    if (!std::isnan(d)) {
      EXPECT_GE(d, 20.0f);
      EXPECT_LE(d, 30.0f);
      // The disparity changes by 1 px over the window's rows here, so allow 0.3 px.
      EXPECT_NEAR(d, pair.disparity_right_px.at<float>(y, 160), 0.3);
    }
  }
  // Rows whose true disparity is outside [20, 30] have no accepted disparity.
  EXPECT_TRUE(std::isnan(result.disparity_px.at<float>(175, 160)));  // d = 29.5 + ... > 30
  EXPECT_FALSE(std::isnan(result.disparity_px.at<float>(140, 160)));  // d = 26
}

TEST(MatchStereoPair, SixteenBitImagesGiveTheSameDisparities) {
  const auto pair = RenderLayeredPair(OnePlane(15.3, 0.01, 0.02));
  cv::Mat left16, right16;
  pair.left.convertTo(left16, CV_16U, 257.0);
  pair.right.convertTo(right16, CV_16U, 257.0);
  const NccOptions options = SmallWindow();
  const NccResult r8 = MatchStereoPair(options, pair.left, pair.right);
  const NccResult r16 = MatchStereoPair(options, left16, right16);
  EXPECT_EQ(r16.summary.accepted_pixels, r8.summary.accepted_pixels);
  EXPECT_LT(cv::norm(r8.disparity_px, r16.disparity_px, cv::NORM_INF | cv::NORM_RELATIVE, r8.rejection == 0), 1e-3);
}

TEST(MatchStereoPair, ThreadCountDoesNotChangeTheResult) {
  const auto pair = RenderLayeredPair(OnePlane(15.3, 0.01, 0.02));
  NccOptions options = SmallWindow();
  options.num_threads = 1;
  const NccResult serial = MatchStereoPair(options, pair.left, pair.right);
  options.num_threads = 2;
  const NccResult parallel = MatchStereoPair(options, pair.left, pair.right);
  EXPECT_EQ(cv::norm(serial.rejection, parallel.rejection, cv::NORM_INF), 0);
  cv::Mat mask = serial.rejection == 0;
  EXPECT_EQ(cv::norm(serial.disparity_px, parallel.disparity_px, cv::NORM_INF, mask), 0);
}

TEST(MatchStereoPair, HandlesImagesSmallerThanTheWindowAndBandsOutsideTheImage) {
  const auto pair = RenderLayeredPair(OnePlane(5.0, 0, 0, 30, 20));
  const NccResult tiny = MatchStereoPair(NccOptions{}, pair.left, pair.right);  // 51 x 35 window
  EXPECT_EQ(tiny.summary.accepted_pixels, 0);
  EXPECT_EQ(tiny.summary.pixels_by_reason[static_cast<int>(Rejection::kBorder)], 30 * 20);
  NccOptions far_rows = SmallWindow();
  far_rows.min_row = 500;
  far_rows.max_row = 600;
  for (int step : {1, 2}) {
    far_rows.step_x_px = far_rows.step_y_px = step;
    const NccResult none = MatchStereoPair(far_rows, pair.left, pair.right);
    EXPECT_EQ(none.summary.evaluated_pixels, 0);
    EXPECT_EQ(cv::countNonZero(none.rejection == static_cast<int>(Rejection::kNotEvaluated)), 30 * 20);
  }
}

TEST(MatchStereoPair, RejectsMismatchedImages) {
  const cv::Mat a(20, 30, CV_8UC1, cv::Scalar(0)), b(20, 31, CV_8UC1, cv::Scalar(0));
  EXPECT_THROW(MatchStereoPair(NccOptions{}, a, b), InputError);
  NccOptions bad;
  bad.median_size = 4;
  EXPECT_THROW(MatchStereoPair(bad, a, a), std::invalid_argument);
}

}  // namespace
}  // namespace lunarnav::stereo
