#include "calib/calibration.h"

#include <gtest/gtest.h>

#include <random>

#include "calib/paper_rig.h"
#include "calib/rectify.h"
#include "sim/chessboard_views.h"
#include "util/errors.h"

namespace lunarnav::calib {
namespace {

// Views of the paper-like rig (0.9 m baseline, k1 = -0.12): exact corner projections from
// the chessboard simulator plus Gaussian detection noise of `noise_px` per coordinate.
std::vector<StereoCorners> NoisyViews(const StereoRig& rig, int count, double noise_px, std::uint32_t seed) {
  sim::ChessboardViewsOptions options;
  options.num_views = count;
  options.render_images = false;
  options.seed = seed;
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_px);
  std::vector<StereoCorners> views;
  for (const sim::ChessboardView& view : sim::GenerateChessboardViews(rig, options)) {
    StereoCorners corners;
    corners.stem = sim::ChessboardViewStem(static_cast<int>(views.size()));
    for (const cv::Point2d& p : view.left_corners_px) {
      corners.left.emplace_back(static_cast<float>(p.x + noise(rng)), static_cast<float>(p.y + noise(rng)));
    }
    for (const cv::Point2d& p : view.right_corners_px) {
      corners.right.emplace_back(static_cast<float>(p.x + noise(rng)), static_cast<float>(p.y + noise(rng)));
    }
    views.push_back(std::move(corners));
  }
  return views;
}

void ExpectRecovers(const StereoRig& truth, const CalibrationResult& result) {
  // The brief's tolerances: focal length within 0.5 %, principal point within a few pixels,
  // baseline within 1 %.
  for (const auto& [estimated, expected] :
       {std::pair{&result.rig.left, &truth.left}, {&result.rig.right, &truth.right}}) {
    EXPECT_NEAR(estimated->K(0, 0), expected->K(0, 0), 0.005 * expected->K(0, 0));
    EXPECT_NEAR(estimated->K(1, 1), expected->K(1, 1), 0.005 * expected->K(1, 1));
    EXPECT_NEAR(estimated->K(0, 2), expected->K(0, 2), 3.0);
    EXPECT_NEAR(estimated->K(1, 2), expected->K(1, 2), 3.0);
    EXPECT_NEAR(estimated->distortion[0], expected->distortion[0], 0.02);
  }
  EXPECT_NEAR(result.rig.BaselineM(), truth.BaselineM(), 0.01 * truth.BaselineM());
  const Eigen::AngleAxisd rotation_error(result.rig.right_from_left_R.transpose() * truth.right_from_left_R);
  EXPECT_LT(rotation_error.angle(), 1e-3);  // rad; 0.06 deg
}

TEST(CalibrateStereoRig, RecoversThePaperRigFromNoisyCorners) {
  const StereoRig truth = testing::PaperRig();
  CalibrationOptions options;
  options.mast = MastPose{1.2, 20.0, 0.1, 0.0};
  // 0.05 px: about the accuracy of sub-pixel corners on the rendered views (see the
  // integration test); at 0.1 px the principal point wanders by up to 5 px with 12 views.
  const std::vector<StereoCorners> views = NoisyViews(truth, 15, 0.05, 7);
  const CalibrationResult result = CalibrateStereoRig(options, cv::Size(640, 480), views);
  ExpectRecovers(truth, result);
  // OpenCV's RMS is that of the 2-D residual: sigma sqrt(2) = 0.071 px, a little less as
  // the fit absorbs some of the noise.
  EXPECT_GT(result.rms_stereo_px, 0.06);
  EXPECT_LT(result.rms_stereo_px, 0.072);
  // The reported row error is that of the noisy corners: |n_l - n_r| with n ~ N(0, 0.05),
  // mean 0.05 sqrt(2) sqrt(2/pi) = 0.056 px.
  EXPECT_NEAR(result.mean_row_error_px, 0.056, 0.015);
  ASSERT_EQ(result.views.size(), 15u);
  for (const ViewReport& v : result.views) {
    EXPECT_EQ(v.status, ViewReport::Status::kUsed);
    EXPECT_LT(v.rms_left_px, 0.1);
    EXPECT_TRUE(v.reason.empty());
  }
  // The calibration's own epipolar accuracy: exact (noise-free) corners of new views
  // rectified with the estimated rig lie on the same row within 0.1 px.
  const Rectifier rectifier(RectifyRig(result.rig));
  double max_row_error = 0;
  for (const StereoCorners& view : NoisyViews(truth, 6, 0.0, 99)) {
    const auto left = rectifier.RectifyPoints(std::vector<cv::Point2d>(view.left.begin(), view.left.end()), true);
    const auto right = rectifier.RectifyPoints(std::vector<cv::Point2d>(view.right.begin(), view.right.end()), false);
    for (std::size_t i = 0; i < left.size(); ++i) {
      max_row_error = std::max(max_row_error, std::abs(left[i].y - right[i].y));
    }
  }
  EXPECT_LT(max_row_error, 0.1);
  EXPECT_EQ(result.rig.mast.height_m, 1.2);  // the mast pose is passed through
  EXPECT_EQ(result.rig.mast.lateral_offset_m, 0.1);
  EXPECT_FALSE(result.rig.rectified.has_value());
}

TEST(CalibrateStereoRig, ExactCornersGiveAnExactRig) {
  const StereoRig truth = testing::PaperRig();
  CalibrationOptions options;
  options.fix_intrinsics = true;
  const CalibrationResult result = CalibrateStereoRig(options, cv::Size(640, 480), NoisyViews(truth, 8, 0.0, 3));
  // Only float rounding of the corners remains.
  EXPECT_LT(result.rms_stereo_px, 1e-3);
  EXPECT_NEAR(result.rig.left.K(0, 0), 740.0, 0.05);
  EXPECT_NEAR(result.rig.BaselineM(), truth.BaselineM(), 1e-4);
  EXPECT_LT(result.max_row_error_px, 1e-2);
  // With k3 estimated too, the true k3 = 0 comes out (a model with more freedom that the
  // data do not need).
  options.estimate_k3 = true;
  const CalibrationResult with_k3 = CalibrateStereoRig(options, cv::Size(640, 480), NoisyViews(truth, 8, 0.0, 3));
  ASSERT_EQ(with_k3.rig.left.distortion.size(), 5u);
  EXPECT_NEAR(with_k3.rig.left.distortion[4], 0.0, 1e-3);
  EXPECT_NEAR(with_k3.rig.left.distortion[0], -0.12, 1e-3);
}

TEST(CalibrateStereoRig, FlagsAViewWithSwappedCorners) {
  const StereoRig truth = testing::PaperRig();
  std::vector<StereoCorners> views = NoisyViews(truth, 8, 0.05, 11);
  std::swap(views[2].right[0], views[2].right[20]);  // a detector mix-up
  const CalibrationResult result = CalibrateStereoRig(CalibrationOptions(), cv::Size(640, 480), views);
  EXPECT_FALSE(result.views[2].reason.empty());
  EXPECT_TRUE(result.views[3].reason.empty());
  EXPECT_GT(result.views[2].rms_right_px, 3 * result.views[3].rms_right_px);
}

TEST(CalibrateStereoRig, TooFewViewsIsAnInputError) {
  const StereoRig truth = testing::PaperRig();
  EXPECT_THROW(CalibrateStereoRig(CalibrationOptions(), cv::Size(640, 480), NoisyViews(truth, 4, 0.05, 1)),
               InputError);
  CalibrationOptions options;
  options.min_views = 2;
  EXPECT_THROW(options.Validate(), std::invalid_argument);
}

TEST(CalibrationResult, TableAndJsonListEveryView) {
  const StereoRig truth = testing::PaperRig();
  CalibrationResult result =
      CalibrateStereoRig(CalibrationOptions(), cv::Size(640, 480), NoisyViews(truth, 6, 0.05, 5));
  ViewReport skipped;
  skipped.stem = "view_zzz";
  skipped.status = ViewReport::Status::kSkipped;
  skipped.reason = "board not found in the left image";
  result.views.push_back(skipped);
  const std::string table = result.Table();
  EXPECT_NE(table.find("view_005"), std::string::npos);
  EXPECT_NE(table.find("board not found in the left image"), std::string::npos);
  const nlohmann::json j = result.ToJson();
  ASSERT_EQ(j["views"].size(), 7u);
  EXPECT_EQ(j["not_used"].size(), 1u);
  EXPECT_EQ(j["views"][6]["status"], "skipped");
  EXPECT_TRUE(j["views"][0]["rms_left_px"].is_number());
}

}  // namespace
}  // namespace lunarnav::calib
