// Integration tests of the rectify tool, alone and chained with stereo-batch.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/paper_rig.h"
#include "calib/raw_pair.h"
#include "calib/rectify.h"
#include "calib/stereo_rig_io.h"
#include "integration/run_tool.h"
#include "io/image_io.h"
#include "io/json_io.h"
#include "sim/layered_scene.h"
#include "util/testing.h"

namespace lunarnav {
namespace {
namespace fs = std::filesystem;
using testing::RunTool;
using util::ScopedTempDir;

struct RawSequence {
  fs::path dir, rig;
  std::vector<sim::RenderedPair> truth;
};

// Two raw pairs of a paper-like rig (distortion, a small rotation between the cameras) made
// from rendered rectified pairs with exact disparity, and the unrectified rig file.
RawSequence MakeRawSequence(const fs::path& root) {
  const calib::StereoRig rig = calib::RectifyRig(calib::testing::PaperRig());
  const calib::Rectifier rectifier(rig);
  RawSequence seq{root / "raw", root / "rig.json", {}};
  fs::create_directories(seq.dir / "left");
  fs::create_directories(seq.dir / "right");
  for (int k = 0; k < 2; ++k) {
    sim::LayeredSceneOptions scene;
    sim::PlaneLayer ground;
    ground.d0_px = 8 + 4 * k;
    ground.slope_y = 0.08;
    ground.texture_scale_px = 4.0;
    ground.seed = 11 + k;
    sim::PlaneLayer box;
    box.d0_px = 45;
    box.support_right = cv::Rect2d(220 + 40 * k, 140, 140, 110);
    box.seed = 3 + k;
    scene.layers = {ground, box};
    seq.truth.push_back(sim::RenderLayeredPair(scene));
    const std::string name = "frame" + std::to_string(k) + ".png";
    cv::imwrite((seq.dir / "left" / name).string(),
                calib::testing::UnrectifyImage(rectifier, rig, seq.truth.back().left, true));
    cv::imwrite((seq.dir / "right" / name).string(),
                calib::testing::UnrectifyImage(rectifier, rig, seq.truth.back().right, false));
  }
  calib::WriteStereoRig(seq.rig, calib::testing::PaperRig());
  return seq;
}

TEST(Rectify, ThenStereoBatchRecoversTheTrueDisparity) {
  ScopedTempDir tmp;
  const RawSequence seq = MakeRawSequence(tmp.path());
  const fs::path rect = tmp.path() / "rect", disp = tmp.path() / "disp";
  const auto run = RunTool("rectify", {seq.dir.string(), "-o", rect.string(), "--rig", seq.rig.string(), "-q"},
                           tmp.path());
  ASSERT_EQ(run.exit_code, 0) << run.stderr_text;
  const calib::StereoRig rectified = calib::ReadStereoRig(rect / "rig.json");
  ASSERT_TRUE(rectified.rectified.has_value());
  const nlohmann::json summary = io::ReadJson(rect / "summary.json");
  EXPECT_EQ(summary["tool"], "rectify");
  EXPECT_EQ(summary["counts"]["pairs_ok"], 2);

  // The raw pairs are not row-aligned; the rectified ones match to a tenth of a pixel.
  for (const fs::path& input : {seq.dir, rect}) {
    const fs::path out = input == rect ? disp : tmp.path() / "disp_raw";
    const auto matched = RunTool("stereo-batch", {input.string(), "-o", out.string(), "-q"}, tmp.path());
    ASSERT_EQ(matched.exit_code, 0) << matched.stderr_text;
    for (int k = 0; k < 2; ++k) {
      const cv::Mat d = io::ReadPfm(out / "disparity" / ("frame" + std::to_string(k) + ".pfm"));
      const cv::Mat& truth = seq.truth[k].disparity_right_px;
      std::vector<double> errors;
      for (int y = 60; y < d.rows - 60; ++y) {
        for (int x = 80; x < d.cols - 80; ++x) {
          const float v = d.at<float>(y, x), t = truth.at<float>(y, x);
          if (std::isfinite(v) && std::isfinite(t)) errors.push_back(std::abs(v - t));
        }
      }
      std::sort(errors.begin(), errors.end());
      const double median = errors.empty() ? 1e9 : errors[errors.size() / 2];
      if (input == rect) {
        EXPECT_GT(errors.size(), 100000u) << k;
        EXPECT_LT(median, 0.1) << k;
      } else {
        EXPECT_GT(median, 0.3) << k;  // without rectification the matcher is lost
      }
    }
  }
}

// A 12-bit camera's raw pairs in 16-bit PNGs without sBIT: rectify tells the depth from the
// data and writes it as sBIT, so that stereo-batch reads it from the file.
TEST(Rectify, WritesTheDepthToldFromTwelveBitDataAsSbit) {
  ScopedTempDir tmp;
  const RawSequence seq = MakeRawSequence(tmp.path());
  const fs::path raw16 = tmp.path() / "raw16", rect = tmp.path() / "rect16";
  for (const char* side : {"left", "right"}) {
    fs::create_directories(raw16 / side);
    for (const auto& entry : fs::directory_iterator(seq.dir / side)) {
      cv::Mat deep;
      cv::imread(entry.path().string(), cv::IMREAD_GRAYSCALE).convertTo(deep, CV_16U, 4095.0 / 255.0);
      io::WriteImageAtomic(raw16 / side / entry.path().filename(), deep);  // no sBIT
      EXPECT_EQ(io::PngSignificantBits(raw16 / side / entry.path().filename()), 0);
    }
  }
  const auto run = RunTool("rectify", {raw16.string(), "-o", rect.string(), "--rig", seq.rig.string(), "-q"},
                           tmp.path());
  ASSERT_EQ(run.exit_code, 0) << run.stderr_text;
  const nlohmann::json summary = io::ReadJson(rect / "summary.json");
  ASSERT_EQ(summary["pairs"].size(), 2u);
  EXPECT_EQ(summary["pairs"][0]["bit_depth"], 12);
  EXPECT_EQ(summary["pairs"][0]["bit_depth_source"].get<std::string>().rfind("data (no sBIT)", 0), 0u);
  EXPECT_EQ(io::PngSignificantBits(rect / "left" / "frame0.png"), 12);
  EXPECT_EQ(io::PngSignificantBits(rect / "right" / "frame1.png"), 12);
  const fs::path disp = tmp.path() / "disp16";
  ASSERT_EQ(RunTool("stereo-batch", {rect.string(), "-o", disp.string(), "-q"}, tmp.path()).exit_code, 0);
  EXPECT_EQ(io::ReadJson(disp / "disparity" / "frame0.json")["result"]["bit_depth_source"], "PNG sBIT");
}

TEST(Rectify, ReportsBadPairsAndUsageErrorsWithTheirExitCodes) {
  ScopedTempDir tmp;
  const RawSequence seq = MakeRawSequence(tmp.path());
  {  // A truncated image: that pair fails, the other is written, exit 4.
    std::string bytes;
    {
      std::ifstream in(seq.dir / "right" / "frame1.png", std::ios::binary);
      bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    }
    std::ofstream(seq.dir / "right" / "frame1.png", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  }
  const fs::path out = tmp.path() / "out";
  auto run = RunTool("rectify", {seq.dir.string(), "-o", out.string(), "--rig", seq.rig.string(), "-q"}, tmp.path());
  EXPECT_EQ(run.exit_code, 4) << run.stderr_text;
  EXPECT_EQ(run.ErrorLines(), 1) << run.stderr_text;
  EXPECT_NE(run.stderr_text.find("frame1"), std::string::npos);
  EXPECT_TRUE(fs::exists(out / "right" / "frame0.png"));
  EXPECT_FALSE(fs::exists(out / "left" / "frame1.png"));

  // A shard writes its own summary.
  run = RunTool("rectify", {seq.dir.string(), "-o", out.string(), "--rig", seq.rig.string(), "--shard", "0/2", "-q"},
                tmp.path());
  EXPECT_EQ(run.exit_code, 0) << run.stderr_text;
  EXPECT_TRUE(fs::exists(out / "summary.shard-0-of-2.json"));

  // Usage errors: 2. A missing or impossible rig file: 3.
  EXPECT_EQ(RunTool("rectify", {seq.dir.string(), "-o", out.string()}, tmp.path()).exit_code, 2);
  EXPECT_EQ(RunTool("rectify", {seq.dir.string(), "-o", out.string(), "--rig", seq.rig.string(), "--alpha", "2"},
                    tmp.path()).exit_code, 2);
  std::ofstream(tmp.path() / "bad_rig.json") << R"({"format": "lunarnav.rig/1"})";
  run = RunTool("rectify", {seq.dir.string(), "-o", out.string(), "--rig", (tmp.path() / "bad_rig.json").string()},
                tmp.path());
  EXPECT_EQ(run.exit_code, 3);
  EXPECT_EQ(run.ErrorLines(), 1) << run.stderr_text;
  EXPECT_EQ(RunTool("rectify", {(tmp.path() / "nowhere").string(), "-o", out.string(), "--rig", seq.rig.string()},
                    tmp.path()).exit_code, 3);
}

}  // namespace
}  // namespace lunarnav
