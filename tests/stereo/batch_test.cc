#include "stereo/batch.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <vector>

#include <opencv2/core.hpp>

#include "io/image_io.h"
#include "sim/layered_scene.h"
#include "util/errors.h"
#include "util/testing.h"

namespace lunarnav::stereo {
namespace {
namespace fs = std::filesystem;

TEST(BatchOptions, ValidatesShards) {
  BatchOptions options;
  options.shard_index = 3;
  options.shard_count = 3;
  EXPECT_THROW(options.Validate(), std::invalid_argument);
  options.shard_index = 2;
  EXPECT_NO_THROW(options.Validate());
  EXPECT_EQ(SummaryFileName(options), "summary.shard-2-of-3.json");
}

// Three pairs of a textured fronto-parallel plane at 12, 20 and 28 px (integer, so the
// matcher's peaks are exact), 120 x 80, as INPUT_DIR/left/<stem>.png and right/<stem>.png.
void WritePlanes(const fs::path& dir) {
  fs::create_directories(dir / "left");
  fs::create_directories(dir / "right");
  const double disparities[3] = {12, 20, 28};
  for (int i = 0; i < 3; ++i) {
    sim::LayeredSceneOptions scene;
    scene.width = 120;
    scene.height = 80;
    sim::PlaneLayer plane;
    plane.d0_px = disparities[i];
    scene.layers = {plane};
    const sim::RenderedPair pair = sim::RenderLayeredPair(scene);
    const std::string stem = "plane" + std::to_string(i);
    io::WriteImageAtomic(dir / "left" / (stem + ".png"), pair.left);
    io::WriteImageAtomic(dir / "right" / (stem + ".png"), pair.right);
  }
}

BatchOptions SmallWindow() {
  BatchOptions options;
  options.matcher.half_window_x_px = 5;
  options.matcher.half_window_y_px = 4;
  options.matcher.min_disparity_px = 0;
  options.matcher.max_disparity_px = 40;
  options.num_threads = 1;
  options.show_progress = false;
  return options;
}

// The median of the finite values of a disparity map and their share of its pixels.
std::pair<double, double> MedianAndDensity(const cv::Mat& disparity) {
  std::vector<float> values;
  for (int r = 0; r < disparity.rows; ++r) {
    for (int c = 0; c < disparity.cols; ++c) {
      if (std::isfinite(disparity.at<float>(r, c))) values.push_back(disparity.at<float>(r, c));
    }
  }
  if (values.empty()) return {NAN, 0.0};
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return {values[values.size() / 2], static_cast<double>(values.size()) / disparity.total()};
}

TEST(RunStereoBatch, MatchesEveryPairAndReportsAnUnreadableOne) {
  util::ScopedTempDir tmp;
  const fs::path in = tmp.path() / "in", out = tmp.path() / "out";
  WritePlanes(in);
  std::ofstream(in / "right" / "plane1.png", std::ios::trunc) << "not a png";  // pair 1 unreadable
  const BatchSummary summary = RunStereoBatch(SmallWindow(), in, out);
  EXPECT_EQ(summary.pairs_listed, 3);
  EXPECT_EQ(summary.pairs_ok, 2);
  EXPECT_EQ(summary.pairs_failed, 1);
  ASSERT_EQ(summary.pairs.size(), 3u);
  EXPECT_EQ(summary.pairs[1].status, PairOutcome::Status::kFailed);
  EXPECT_NE(summary.pairs[1].error.find("plane1.png"), std::string::npos) << summary.pairs[1].error;
  EXPECT_FALSE(fs::exists(OutputPathsFor(out, "plane1").disparity));
  // Each readable pair's map: the plane's disparity on most pixels (the border of half a
  // window and the disparity search's margin have none).
  for (const auto& [stem, d0] : {std::pair<std::string, double>{"plane0", 12}, {"plane2", 28}}) {
    const auto [median, density] = MedianAndDensity(io::ReadPfm(OutputPathsFor(out, stem).disparity));
    EXPECT_NEAR(median, d0, 0.1) << stem;
    EXPECT_GT(density, 0.5) << stem;
  }
  EXPECT_TRUE(fs::exists(out / "summary.json"));
}

TEST(RunStereoBatch, AShardProcessesEveryShardCountthPair) {
  util::ScopedTempDir tmp;
  const fs::path in = tmp.path() / "in", out = tmp.path() / "out";
  WritePlanes(in);
  BatchOptions options = SmallWindow();
  options.shard_index = 1;
  options.shard_count = 2;
  const BatchSummary summary = RunStereoBatch(options, in, out);
  EXPECT_EQ(summary.pairs_listed, 3);
  EXPECT_EQ(summary.pairs_in_shard, 1);  // pairs 0, 1, 2: only 1 % 2 == 1
  EXPECT_EQ(summary.pairs_ok, 1);
  EXPECT_TRUE(fs::exists(OutputPathsFor(out, "plane1").disparity));
  EXPECT_FALSE(fs::exists(OutputPathsFor(out, "plane0").disparity));
  EXPECT_FALSE(fs::exists(OutputPathsFor(out, "plane2").disparity));
  EXPECT_NEAR(MedianAndDensity(io::ReadPfm(OutputPathsFor(out, "plane1").disparity)).first, 20, 0.1);
  EXPECT_EQ(summary.summary_path.filename(), "summary.shard-1-of-2.json");
}

}  // namespace
}  // namespace lunarnav::stereo
