#include "calib/rectify_batch.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/paper_rig.h"
#include "calib/raw_pair.h"
#include "calib/rectify.h"
#include "calib/stereo_rig_io.h"
#include "io/image_io.h"
#include "io/json_io.h"
#include "sim/layered_scene.h"
#include "util/errors.h"
#include "util/testing.h"

namespace lunarnav::calib {
namespace {
namespace fs = std::filesystem;

RectifyBatchOptions Quiet() {
  RectifyBatchOptions options;
  options.show_progress = false;
  return options;
}

sim::RenderedPair RenderScene() {
  sim::LayeredSceneOptions scene;
  sim::PlaneLayer ground;  // a ground-like plane: disparity grows down the image
  ground.d0_px = 10;
  ground.slope_y = 0.08;
  ground.texture_scale_px = 5.0;
  sim::PlaneLayer box;
  box.d0_px = 52;
  box.support_right = cv::Rect2d(250, 150, 120, 100);
  box.texture_scale_px = 4.0;
  box.seed = 5;
  scene.layers = {ground, box};
  return sim::RenderLayeredPair(scene);
}

// Sub-pixel shift between two images over their central part (phase correlation).
cv::Point2d Shift(const cv::Mat& a, const cv::Mat& b) {
  const cv::Rect centre(120, 90, 400, 300);
  cv::Mat fa, fb;
  a(centre).convertTo(fa, CV_64F);
  b(centre).convertTo(fb, CV_64F);
  return cv::phaseCorrelate(fa, fb);
}

TEST(RunRectifyBatch, RecoversTheRectifiedPairFromRawDistortedImages) {
  // Raw images of a rig with lens distortion and a small rotation between the cameras, made
  // from a rendered rectified pair: rectifying them must give that pair back, aligned.
  const StereoRig rig = RectifyRig(testing::PaperRig());
  const Rectifier rectifier(rig);
  const sim::RenderedPair truth = RenderScene();
  util::ScopedTempDir tmp;
  const fs::path in = tmp.path() / "raw", out = tmp.path() / "out";
  fs::create_directories(in / "left");
  fs::create_directories(in / "right");
  const cv::Mat raw_left = testing::UnrectifyImage(rectifier, rig, truth.left, true);
  const cv::Mat raw_right = testing::UnrectifyImage(rectifier, rig, truth.right, false);
  // The raw images really are distorted: they differ from the rectified ones by pixels.
  EXPECT_GT(cv::norm(Shift(raw_left, truth.left)) + cv::norm(Shift(raw_right, truth.right)), 1.0);
  ASSERT_TRUE(cv::imwrite((in / "left" / "p0.png").string(), raw_left));
  ASSERT_TRUE(cv::imwrite((in / "right" / "p0.png").string(), raw_right));

  StereoRig unrectified = rig;
  unrectified.rectified.reset();
  const RectifyBatchSummary summary = RunRectifyBatch(Quiet(), unrectified, "rig.json", in, out);
  EXPECT_EQ(summary.pairs_ok, 1);
  EXPECT_EQ(StereoRigToJson(ReadStereoRig(out / "rig.json")), StereoRigToJson(rig));
  const cv::Mat left = io::ReadImage(out / "left" / "p0.png");
  const cv::Mat right = io::ReadImage(out / "right" / "p0.png");
  ASSERT_EQ(left.size(), truth.left.size());
  const cv::Point2d shift_left = Shift(left, truth.left), shift_right = Shift(right, truth.right);
  EXPECT_LT(cv::norm(shift_left), 0.05) << shift_left;
  EXPECT_LT(cv::norm(shift_right), 0.05) << shift_right;
  // Same rows in both images: the vertical shifts agree to a few hundredths of a pixel.
  EXPECT_NEAR(shift_left.y, shift_right.y, 0.03);
  cv::Mat diff;
  cv::absdiff(left(cv::Rect(120, 90, 400, 300)), truth.left(cv::Rect(120, 90, 400, 300)), diff);
  EXPECT_LT(cv::mean(diff)[0], 1.5);  // two interpolations blur a little, nothing more
}

TEST(RunRectifyBatch, KeepsColourAndBitDepthAndReportsBadPairs) {
  util::ScopedTempDir tmp;
  const fs::path in = tmp.path() / "raw", out = tmp.path() / "out";
  fs::create_directories(in / "left");
  fs::create_directories(in / "right");
  cv::Mat colour(480, 640, CV_16UC3);
  cv::randu(colour, 0, 65535);
  cv::GaussianBlur(colour, colour, cv::Size(9, 9), 3);
  ASSERT_TRUE(cv::imwrite((in / "left" / "a.png").string(), colour));
  ASSERT_TRUE(cv::imwrite((in / "right" / "a.png").string(), colour));
  ASSERT_TRUE(cv::imwrite((in / "left" / "b_small.png").string(), cv::Mat(240, 320, CV_8UC1, cv::Scalar(5))));
  ASSERT_TRUE(cv::imwrite((in / "right" / "b_small.png").string(), cv::Mat(240, 320, CV_8UC1, cv::Scalar(5))));
  ASSERT_TRUE(cv::imwrite((in / "left" / "c_alone.png").string(), cv::Mat(480, 640, CV_8UC1, cv::Scalar(5))));
  RectifyBatchOptions options = Quiet();
  options.image_format = "tif";
  const RectifyBatchSummary summary = RunRectifyBatch(options, testing::PaperRig(), "rig.json", in, out);
  EXPECT_EQ(summary.pairs_ok, 1);
  EXPECT_EQ(summary.pairs_failed, 2);
  EXPECT_NE(summary.pairs[1].error.find("not the rig's raw image size"), std::string::npos);
  EXPECT_NE(summary.pairs[2].error.find("missing"), std::string::npos);
  EXPECT_FALSE(fs::exists(out / "left" / "b_small.tif"));
  const cv::Mat left = io::ReadImage(out / "left" / "a.tif");
  EXPECT_EQ(left.type(), CV_16UC3);
  // The colour channels are warped alike: a grey-only warp would not keep them apart.
  std::vector<cv::Mat> in_channels, out_channels;
  cv::split(colour, in_channels);
  cv::split(left, out_channels);
  EXPECT_NE(cv::norm(out_channels[0], out_channels[2], cv::NORM_L1), 0.0);
  const nlohmann::json j = io::ReadJson(summary.summary_path);
  EXPECT_EQ(j["counts"]["pairs_failed"], 2);
  EXPECT_EQ(j["failed"].size(), 2u);
  EXPECT_EQ(j["rig"]["input_was_rectified"], false);
}

TEST(RunRectifyBatch, ResumesOnlyWithTheSameRectifiedRig) {
  util::ScopedTempDir tmp;
  const fs::path in = tmp.path() / "raw", out = tmp.path() / "out";
  for (const char* side : {"left", "right"}) {
    fs::create_directories(in / side);
    for (const char* stem : {"a", "b"}) {
      cv::Mat image(480, 640, CV_8UC1);
      cv::randu(image, 0, 255);
      ASSERT_TRUE(cv::imwrite((in / side / (std::string(stem) + ".png")).string(), image));
    }
  }
  RectifyBatchOptions options = Quiet();
  EXPECT_EQ(RunRectifyBatch(options, testing::PaperRig(), "rig.json", in, out).pairs_ok, 2);
  fs::remove(out / "right" / "b.png");  // as if killed between the two files of pair b
  options.resume = true;
  const RectifyBatchSummary resumed = RunRectifyBatch(options, testing::PaperRig(), "rig.json", in, out);
  EXPECT_EQ(resumed.pairs_resumed, 1);
  EXPECT_EQ(resumed.pairs_ok, 1);
  EXPECT_TRUE(fs::exists(out / "right" / "b.png"));
  options.alpha = 1.0;  // another rectification: the outputs on disk do not belong to it
  EXPECT_THROW(RunRectifyBatch(options, testing::PaperRig(), "rig.json", in, out), std::invalid_argument);
  options.resume = false;
  EXPECT_EQ(RunRectifyBatch(options, testing::PaperRig(), "rig.json", in, out).pairs_ok, 2);
}

TEST(RunRectifyBatch, ReportsARotationRepairedWhenTheRigWasRead) {
  // A rig whose rotation was printed to 6 significant digits: read, repaired, and the repair
  // listed in the run's summary.
  util::ScopedTempDir tmp;
  StereoRig rig = testing::PaperRig();
  nlohmann::json j = StereoRigToJson(rig);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      char text[32];
      std::snprintf(text, sizeof(text), "%.6g", rig.right_from_left_R(r, c));
      j["right_from_left"]["R"][r][c] = std::strtod(text, nullptr);
    }
  }
  const StereoRig read = StereoRigFromJson(j, "printed.json");
  ASSERT_EQ(read.notes.size(), 1u);
  const sim::RenderedPair pair = RenderScene();
  for (const char* side : {"left", "right"}) fs::create_directories(tmp.path() / "in" / side);
  cv::imwrite((tmp.path() / "in" / "left" / "a.png").string(), pair.left);
  cv::imwrite((tmp.path() / "in" / "right" / "a.png").string(), pair.right);
  const RectifyBatchSummary summary =
      RunRectifyBatch(Quiet(), read, "printed.json", tmp.path() / "in", tmp.path() / "out");
  EXPECT_EQ(summary.pairs_ok, 1);
  std::ifstream in(summary.summary_path);
  const nlohmann::json s = nlohmann::json::parse(in);
  ASSERT_EQ(s["rig"]["notes"].size(), 1u);
  EXPECT_NE(s["rig"]["notes"][0].get<std::string>().find("printed.json.right_from_left.R"), std::string::npos);
}

TEST(RunRectifyBatch, UsesTheRigsOwnRectificationUnlessAlphaIsGiven) {
  const StereoRig rectified = RectifyRig(testing::PaperRig(), 0.5);
  RectifyBatchOptions options;
  EXPECT_EQ(StereoRigToJson(RigForRectification(rectified, options)), StereoRigToJson(rectified));
  options.alpha = 0.0;
  EXPECT_EQ(StereoRigToJson(RigForRectification(rectified, options)),
            StereoRigToJson(RectifyRig(testing::PaperRig(), 0.0)));
  options.alpha = 1.5;
  EXPECT_THROW(options.Validate(), std::invalid_argument);
}

}  // namespace
}  // namespace lunarnav::calib
