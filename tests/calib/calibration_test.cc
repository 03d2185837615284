#include "calib/calibration.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "calib/paper_rig.h"
#include "calib/rectify.h"
#include "sim/chessboard_views.h"
#include "util/errors.h"

namespace lunarnav::calib {
namespace {

// Views of the paper-like rig (0.9 m baseline, k1 = -0.12): exact corner projections from
// the chessboard simulator plus Gaussian detection noise of `noise_px` per coordinate.
std::vector<StereoCorners> NoisyViews(const StereoRig& rig, int count, double noise_px, std::uint32_t seed,
                                      double max_roll_deg = 30.0) {
  sim::ChessboardViewsOptions options;
  options.num_views = count;
  options.max_roll_deg = max_roll_deg;
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

// The corners of one image in another of the board's symmetric orders (what a detector may
// return for the same board).
std::vector<cv::Point2f> InOrder(const std::vector<cv::Point2f>& corners, const std::vector<int>& order) {
  std::vector<cv::Point2f> out;
  for (int k : order) out.push_back(corners[static_cast<std::size_t>(k)]);
  return out;
}

// The angle of the first row of corners in the image, degrees in (-180, 180].
double FirstRowAngleDeg(const std::vector<cv::Point2f>& corners, int cols) {
  const cv::Point2f row = corners[static_cast<std::size_t>(cols - 1)] - corners[0];
  return std::atan2(row.y, row.x) * 180.0 / M_PI;
}

TEST(CalibrateStereoRig, RecoversTheSameRigWhateverTheBoardsTurnAndTheCornerOrder) {
  const StereoRig truth = testing::PaperRig();
  const ChessboardSpec board;
  // In-plane rotations anywhere in +-180 deg: boards turned by about 90 deg (near-vertical
  // rows) and 180 deg among them (checked below), seed 21.
  const std::vector<StereoCorners> views = NoisyViews(truth, 14, 0.05, 21, 180.0);
  bool near_vertical = false, upside_down = false;
  for (const StereoCorners& v : views) {
    const double angle = std::abs(FirstRowAngleDeg(v.left, board.cols));
    near_vertical |= std::abs(angle - 90.0) < 15.0;
    upside_down |= angle > 160.0;
  }
  ASSERT_TRUE(near_vertical && upside_down) << "the seed no longer gives the turns this test is about";
  const CalibrationResult reference = CalibrateStereoRig(CalibrationOptions(), cv::Size(640, 480), views);
  ExpectRecovers(truth, reference);

  // Every image's corners in a random one of the board's symmetric orders, as a detector may
  // return them independently in the two images; view 3's right image reversed outright.
  const std::vector<std::vector<int>> orders = SymmetricCornerOrders(board);
  std::mt19937 rng(5);
  std::uniform_int_distribution<std::size_t> pick(0, orders.size() - 1);
  std::vector<StereoCorners> shuffled = views;
  for (StereoCorners& v : shuffled) {
    v.left = InOrder(v.left, orders[pick(rng)]);
    v.right = InOrder(v.right, orders[pick(rng)]);
  }
  shuffled[3].right = views[3].right;
  std::reverse(shuffled[3].right.begin(), shuffled[3].right.end());
  const CalibrationResult result = CalibrateStereoRig(CalibrationOptions(), cv::Size(640, 480), shuffled);
  ExpectRecovers(truth, result);
  EXPECT_EQ(result.views_used, 14);
  EXPECT_EQ(result.views_dropped, 0);
  // The same rig as from the views in the simulator's own order: the same corner pairs.
  EXPECT_NEAR(result.rig.left.K(0, 0), reference.rig.left.K(0, 0), 1e-3);
  EXPECT_NEAR(result.rig.right.K(1, 2), reference.rig.right.K(1, 2), 1e-3);
  EXPECT_NEAR(result.rig.BaselineM(), reference.rig.BaselineM(), 1e-6);
  EXPECT_NEAR(result.rms_stereo_px, reference.rms_stereo_px, 1e-6);
  EXPECT_LT(result.mean_row_error_px, 0.1);
}

TEST(CalibrateStereoRig, RecoversTheRigFromRenderedViewsOfBoardsTurnedAnyWay) {
  // Rendered views (noise-free) with in-plane turns anywhere in +-180 deg, the
  // corners found by the detector in each image on its own, as `calibrate` does.
  const StereoRig truth = testing::PaperRig();
  sim::ChessboardViewsOptions options;
  options.num_views = 14;
  options.max_roll_deg = 180.0;
  options.noise_sigma = 0.0;
  options.seed = 4;
  const ChessboardSpec board;
  std::vector<StereoCorners> views;
  int near_vertical = 0, orders_differ = 0;
  for (const sim::ChessboardView& view : sim::GenerateChessboardViews(truth, options)) {
    const auto left = DetectChessboardCorners(view.left, board), right = DetectChessboardCorners(view.right, board);
    if (!left || !right) continue;
    views.push_back({sim::ChessboardViewStem(static_cast<int>(views.size())), *left, *right});
    near_vertical += std::abs(std::abs(FirstRowAngleDeg(*left, board.cols)) - 90.0) < 30.0;
    // Whether the detector listed the right image from another corner than the left image.
    const bool left_turned = cv::norm((*left)[0] - cv::Point2f(view.left_corners_px[0])) > 1.0;
    const bool right_turned = cv::norm((*right)[0] - cv::Point2f(view.right_corners_px[0])) > 1.0;
    orders_differ += left_turned != right_turned;
  }
  ASSERT_GE(views.size(), 12u);
  EXPECT_GT(near_vertical, 0) << "the seed no longer gives a sideways board";
  EXPECT_GT(orders_differ, 0) << "the seed no longer gives a view whose two images are listed differently";
  const CalibrationResult result = CalibrateStereoRig(CalibrationOptions(), cv::Size(640, 480), views);
  ExpectRecovers(truth, result);
  // One view (seed 4: view_009) has a corner of its left image detected 2 px off, RMS 0.55 px
  // against 0.02-0.05 px for the others: it is dropped as an outlier.
  EXPECT_LE(result.views_dropped, 1);
  EXPECT_EQ(result.views_used + result.views_dropped, static_cast<int>(views.size()));
  EXPECT_LT(result.rms_stereo_px, 0.06);
  std::printf("rendered views: %zu, sideways %d, right listed from another corner than left %d\n", views.size(),
              near_vertical, orders_differ);
}

TEST(CalibrateStereoRig, DropsAndNamesAGrosslyWrongView) {
  const StereoRig truth = testing::PaperRig();
  std::vector<StereoCorners> views = NoisyViews(truth, 12, 0.05, 13);
  // View 4's right corners 15 px too low and drifting along the board: a gross error that
  // the order match cannot mend (every order is as far off).
  for (std::size_t k = 0; k < views[4].right.size(); ++k) views[4].right[k].y += 15.0f + 0.2f * static_cast<float>(k);
  const CalibrationResult result = CalibrateStereoRig(CalibrationOptions(), cv::Size(640, 480), views);
  ASSERT_EQ(result.views.size(), 12u);
  EXPECT_EQ(result.views[4].status, ViewReport::Status::kDropped);
  EXPECT_NE(result.views[4].reason.find("outlier"), std::string::npos) << result.views[4].reason;
  EXPECT_EQ(result.views_dropped, 1);
  EXPECT_EQ(result.views_used, 11);
  EXPECT_EQ(result.calibrations, 2);
  EXPECT_GT(result.first_rms_stereo_px, 1.0);
  EXPECT_LT(result.rms_stereo_px, 0.1);
  // The rig of the other eleven views alone.
  std::vector<StereoCorners> clean = views;
  clean.erase(clean.begin() + 4);
  const CalibrationResult without = CalibrateStereoRig(CalibrationOptions(), cv::Size(640, 480), clean);
  EXPECT_NEAR(result.rig.left.K(0, 0), without.rig.left.K(0, 0), 1e-6);
  EXPECT_NEAR(result.rig.BaselineM(), without.rig.BaselineM(), 1e-9);
  EXPECT_NEAR(result.rms_stereo_px, without.rms_stereo_px, 1e-9);
  EXPECT_NEAR(result.rig.left.K(0, 0), truth.left.K(0, 0), 0.005 * truth.left.K(0, 0));
  EXPECT_NEAR(result.rig.BaselineM(), truth.BaselineM(), 0.01 * truth.BaselineM());
  const nlohmann::json j = result.ToJson();
  ASSERT_EQ(j["dropped"].size(), 1u);
  EXPECT_EQ(j["dropped"][0]["stem"], views[4].stem);
  EXPECT_EQ(j["views"][4]["status"], "dropped");
  EXPECT_NE(result.Table().find("dropped"), std::string::npos);
  // Without dropping, the same views are a calibration that did not converge to the bound,
  // and the error speaks of views and RMS, not of projection matrices.
  CalibrationOptions keep;
  keep.drop_outliers = false;
  keep.max_rms_px = 0.5;
  try {
    CalibrateStereoRig(keep, cv::Size(640, 480), views);
    ADD_FAILURE() << "expected an InputError";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("did not converge"), std::string::npos) << message;
    EXPECT_NE(message.find(views[4].stem), std::string::npos) << message;
    EXPECT_NE(message.find("RMS"), std::string::npos) << message;
    EXPECT_EQ(message.find("P_left"), std::string::npos) << message;
  }
}

TEST(CalibrateStereoRig, SkipsAViewWhoseOrientationCannotBeDecided) {
  const StereoRig truth = testing::PaperRig();
  std::vector<StereoCorners> views = NoisyViews(truth, 8, 0.05, 17);
  // View 2's right board shrunk to a tenth about its centre: every order pairs the corners
  // with displacements of the board's own size (a collapsed detection).
  cv::Point2f centre(0, 0);
  for (const cv::Point2f& p : views[2].right) centre += p / static_cast<float>(views[2].right.size());
  for (cv::Point2f& p : views[2].right) p = centre + 0.1f * (p - centre);
  const CalibrationResult result = CalibrateStereoRig(CalibrationOptions(), cv::Size(640, 480), views);
  EXPECT_EQ(result.views[2].status, ViewReport::Status::kSkipped);
  EXPECT_NE(result.views[2].reason.find("orientation undecided"), std::string::npos) << result.views[2].reason;
  EXPECT_EQ(result.views_used, 7);
  EXPECT_NE(result.Table().find("orientation undecided"), std::string::npos);
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
