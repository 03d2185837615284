#include "sim/chessboard_views.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/paper_rig.h"
#include "calib/stereo_rig_io.h"
#include "io/image_io.h"
#include "io/json_io.h"
#include "util/testing.h"

namespace lunarnav::sim {
namespace {

// Detected corners (the project's detector: OpenCV's, with sub-pixel refinement) against
// the exact projections: the median and the largest distance in pixels, or infinity when the
// board is not found.
std::pair<double, double> CornerErrors(const cv::Mat& image, const std::vector<cv::Point2d>& exact,
                                       const calib::ChessboardSpec& board) {
  const auto found = calib::DetectChessboardCorners(image, board);
  if (!found) return {INFINITY, INFINITY};
  std::vector<double> errors;
  for (std::size_t i = 0; i < exact.size(); ++i) errors.push_back(cv::norm(cv::Point2d((*found)[i]) - exact[i]));
  std::sort(errors.begin(), errors.end());
  return {errors[errors.size() / 2], errors.back()};
}

TEST(GenerateChessboardViews, DetectedCornersMatchTheExactProjections) {
  // The paper-like rig has barrel distortion (k1 = -0.12), so this also checks that the
  // renderer's inverse distortion agrees with cv::projectPoints.
  const calib::StereoRig rig = calib::testing::PaperRig();
  ChessboardViewsOptions options;
  options.num_views = 3;
  const std::vector<ChessboardView> views = GenerateChessboardViews(rig, options);
  ASSERT_EQ(views.size(), 3u);
  for (std::size_t k = 0; k < views.size(); ++k) {
    ASSERT_EQ(views[k].left.size(), cv::Size(640, 480));
    ASSERT_EQ(views[k].left.type(), CV_8UC1);
    ASSERT_EQ(views[k].left_corners_px.size(), 54u);
    // The detector's own bias on tilted, distorted corners (cornerSubPix fits straight
    // edges) is up to about 0.1 px whatever the rendering (more samples per pixel change
    // nothing, more blur makes it worse); typical corners are found to a few hundredths.
    for (const auto& [image, exact] : {std::pair{&views[k].left, &views[k].left_corners_px},
                                       {&views[k].right, &views[k].right_corners_px}}) {
      const auto [median, max] = CornerErrors(*image, *exact, options.board);
      EXPECT_LT(median, 0.05) << "view " << k;
      EXPECT_LT(max, 0.12) << "view " << k;
    }
  }
}

TEST(GenerateChessboardViews, ExactCornersFollowThePoseAndTheRig) {
  const calib::StereoRig rig = calib::testing::PaperRig();
  ChessboardViewsOptions options;
  options.num_views = 3;
  options.render_images = false;
  const std::vector<ChessboardView> views = GenerateChessboardViews(rig, options);
  cv::Mat k, r;
  cv::eigen2cv(rig.right.K, k);
  for (const ChessboardView& view : views) {
    EXPECT_TRUE(view.left.empty());
    // Right corners: the board through right_from_left, projected by OpenCV directly.
    const Eigen::Matrix3d right_r = rig.right_from_left_R * view.left_from_board.linear();
    const Eigen::Vector3d right_t =
        rig.right_from_left_R * view.left_from_board.translation() + rig.right_from_left_t_m;
    cv::eigen2cv(right_r, r);
    cv::Mat rvec;
    cv::Rodrigues(r, rvec);
    std::vector<cv::Point3d> object;
    for (const cv::Point3f& p : options.board.ObjectPointsM()) object.emplace_back(p.x, p.y, p.z);
    std::vector<cv::Point2d> expected;
    cv::projectPoints(object, rvec, cv::Vec3d(right_t.x(), right_t.y(), right_t.z()), k,
                      cv::Mat(rig.right.distortion), expected);
    for (std::size_t i = 0; i < expected.size(); ++i) {
      EXPECT_LT(cv::norm(expected[i] - view.right_corners_px[i]), 1e-4) << i;  // float object points
    }
    // The board lies in the requested distance range and is tilted as requested.
    const double z = view.left_from_board.translation().z();
    EXPECT_GT(z, 1.0);
    EXPECT_LT(z, 6.0);
    const double tilt_deg =
        std::acos(std::clamp(view.left_from_board.linear()(2, 2), -1.0, 1.0)) * 180.0 / M_PI;
    EXPECT_GE(tilt_deg, 0.3 * options.max_tilt_deg - 1e-9);
    EXPECT_LE(tilt_deg, options.max_tilt_deg + 1e-9);
  }
}

TEST(GenerateChessboardViews, CoversTheStereoOverlapOverNineViews) {
  ChessboardViewsOptions options;
  options.num_views = 9;
  options.render_images = false;
  const std::vector<ChessboardView> views = GenerateChessboardViews(calib::testing::PaperRig(), options);
  // With a 0.9 m baseline the left image's left part and the right image's right part are
  // seen by one camera only at these distances; everywhere else, the corners reach within a
  // fifth of the image size of the image's edges (the board centre visits all 3 x 3 cells).
  double left_min_y = 1e9, left_max_y = -1e9, left_max_x = -1e9, right_min_x = 1e9;
  for (const ChessboardView& view : views) {
    for (const cv::Point2d& p : view.left_corners_px) {
      left_min_y = std::min(left_min_y, p.y);
      left_max_y = std::max(left_max_y, p.y);
      left_max_x = std::max(left_max_x, p.x);
    }
    for (const cv::Point2d& p : view.right_corners_px) right_min_x = std::min(right_min_x, p.x);
  }
  EXPECT_LT(left_min_y, 0.2 * 480);
  EXPECT_GT(left_max_y, 0.8 * 480);
  EXPECT_GT(left_max_x, 0.8 * 640);
  EXPECT_LT(right_min_x, 0.2 * 640);
}

TEST(GenerateChessboardViews, IsDeterministicAndAddsTheRequestedNoise) {
  const calib::StereoRig rig = calib::testing::PaperRig();
  ChessboardViewsOptions options;
  options.num_views = 1;
  options.samples_per_axis = 1;
  const auto a = GenerateChessboardViews(rig, options), b = GenerateChessboardViews(rig, options);
  EXPECT_EQ(cv::norm(a[0].left, b[0].left, cv::NORM_INF), 0.0);
  options.seed = 2;
  const auto c = GenerateChessboardViews(rig, options);
  EXPECT_GT(cv::norm(a[0].left_corners_px[0] - c[0].left_corners_px[0]), 1.0);  // another pose

  options.seed = 1;
  options.noise_sigma = 4.0;
  const auto noisy = GenerateChessboardViews(rig, options);
  cv::Mat diff;
  cv::subtract(noisy[0].left, a[0].left, diff, cv::noArray(), CV_64F);
  cv::Scalar mean, sd;
  cv::meanStdDev(diff, mean, sd);
  EXPECT_NEAR(sd[0], 4.0, 0.2);  // 8-bit rounding adds 1/12 in variance
  EXPECT_NEAR(mean[0], 0.0, 0.1);
}

TEST(GenerateChessboardViews, RefusesABoardThatCannotFitBothImages) {
  ChessboardViewsOptions options;
  options.render_images = false;
  options.min_distance_m = 0.5;  // at 0.5-0.6 m the 0.9 m baseline leaves no overlap
  options.max_distance_m = 0.6;
  EXPECT_THROW(GenerateChessboardViews(calib::testing::PaperRig(), options), std::invalid_argument);
  options = ChessboardViewsOptions();
  options.samples_per_axis = 0;
  EXPECT_THROW(GenerateChessboardViews(calib::testing::PaperRig(), options), std::invalid_argument);
}

TEST(WriteChessboardViews, WritesACalibrateInputDirectoryWithTheTruth) {
  const calib::StereoRig rig = calib::testing::PaperRig();
  ChessboardViewsOptions options;
  options.num_views = 2;
  options.samples_per_axis = 1;
  const std::vector<ChessboardView> views = GenerateChessboardViews(rig, options);
  util::ScopedTempDir dir;
  WriteChessboardViews(dir.path() / "views", rig, options, views);
  for (int k = 0; k < 2; ++k) {
    const std::string stem = ChessboardViewStem(k);
    const cv::Mat left = io::ReadGreyImage(dir.path() / "views" / "left" / (stem + ".png"));
    const cv::Mat right = io::ReadGreyImage(dir.path() / "views" / "right" / (stem + ".png"));
    EXPECT_EQ(cv::norm(left, views[k].left, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(right, views[k].right, cv::NORM_INF), 0.0);
  }
  EXPECT_EQ(ChessboardViewStem(1), "view_001");
  const calib::StereoRig read = calib::ReadStereoRig(dir.path() / "views" / "rig.json");
  EXPECT_LT((read.left.K - rig.left.K).norm(), 1e-12);
  EXPECT_LT((read.right_from_left_t_m - rig.right_from_left_t_m).norm(), 1e-12);
  const nlohmann::json truth = io::ReadJson(dir.path() / "views" / "truth.json");
  ASSERT_EQ(truth["views"].size(), 2u);
  EXPECT_EQ(truth["views"][1]["stem"], "view_001");
  EXPECT_DOUBLE_EQ(truth["views"][1]["right_corners_px"][53][0].get<double>(), views[1].right_corners_px[53].x);

  options.render_images = false;
  EXPECT_THROW(WriteChessboardViews(dir.path() / "none", rig, options, GenerateChessboardViews(rig, options)),
               std::invalid_argument);
}

}  // namespace
}  // namespace lunarnav::sim
