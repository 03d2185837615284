// Integration tests of `simulate stereo`, alone and chained with rectify.
#include <gtest/gtest.h>

#include <cmath>
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "integration/run_tool.h"
#include "io/image_io.h"
#include "io/json_io.h"
#include "util/testing.h"

namespace lunarnav {
namespace {
namespace fs = std::filesystem;
using testing::RunTool;
using util::ScopedTempDir;

const char* kTool = "simulate";

std::vector<std::string> SmallArgs(const fs::path& out) {
  return {"stereo", "-o", out.string(), "--width", "160", "--height", "120", "--focal", "185",
          "--terrain-cell", "0.05", "-j", "2", "-q"};
}

TEST(SimulateStereo, WritesASequenceThatRectifyReadsAsItIs) {
  ScopedTempDir tmp;
  const fs::path sim = tmp.path() / "sim";
  std::vector<std::string> args = SmallArgs(sim);
  for (const char* a : {"--frames", "2", "--fault", "1:saturated"}) args.push_back(a);
  const auto run = RunTool(kTool, args, tmp.path());
  ASSERT_EQ(run.exit_code, 0) << run.stderr_text;
  for (const char* f : {"left/000000.png", "right/000001.png", "truth/disparity/000001.pfm", "truth/xyz/000000.exr",
                        "truth/labels/000000.png", "truth/poses.csv", "truth/boxes.json", "truth/terrain.tif",
                        "truth/rocks.csv", "rig.json"}) {
    EXPECT_TRUE(fs::is_regular_file(sim / f)) << f;
  }
  const nlohmann::json summary = io::ReadJson(sim / "summary.json");
  EXPECT_EQ(summary["tool"], "simulate");
  EXPECT_EQ(summary["subcommand"], "stereo");
  EXPECT_EQ(summary["counts"]["frames"], 2);
  EXPECT_EQ(summary["counts"]["faults"], 1);
  EXPECT_EQ(summary["frames"][1]["fault"], "saturated");
  EXPECT_EQ(summary["options"]["rays_per_pixel"], 4);

  // The output directory is a raw sequence: rectify takes it with its rig file.
  const fs::path rect = tmp.path() / "rect";
  const auto rectify = RunTool("rectify", {sim.string(), "-o", rect.string(), "--rig", (sim / "rig.json").string(), "-q"},
                               tmp.path());
  ASSERT_EQ(rectify.exit_code, 0) << rectify.stderr_text;
  const cv::Mat left = io::ReadGreyImage(rect / "left" / "000000.png");
  EXPECT_EQ(left.cols, 160);
  EXPECT_GT(cv::mean(left)[0], 40);
}

TEST(SimulateStereo, TheBoxesFixtureIsWhatItsCommandWrites) {
  // testdata/README.md: simulate stereo --preset boxes --rectified --width 320 --height 240
  //                     --focal 370 --seed 1 -o testdata/boxes
  ScopedTempDir tmp;
  const fs::path sim = tmp.path() / "boxes";
  const auto run = RunTool(kTool,
                           {"stereo", "--preset", "boxes", "--rectified", "--width", "320", "--height", "240",
                            "--focal", "370", "--seed", "1", "-o", sim.string(), "-q"},
                           tmp.path());
  ASSERT_EQ(run.exit_code, 0) << run.stderr_text;
  const std::vector<std::string> files = testing::DataFiles(sim);
  EXPECT_EQ(files, testing::DataFiles(util::TestDataPath("boxes")));
  EXPECT_EQ(files.size(), 8u);  // 2 images, disparity, xyz, labels, poses, boxes, rig
  for (const std::string& f : files) {
    EXPECT_EQ(testing::ReadFileBytes(sim / f), testing::ReadFileBytes(util::TestDataPath("boxes/" + f)))
        << f << " differs: regenerate the fixture (testdata/README.md)";
  }
}

TEST(SimulateStereo, BadOptionsAreUsageErrors) {
  ScopedTempDir tmp;
  for (const std::vector<std::string>& extra :
       {std::vector<std::string>{"--rays", "3"}, {"--fault", "5:blank"}, {"--fault", "0:smoke"},
        {"--preset", "moon"}, {"--frames", "0"}}) {
    std::vector<std::string> args = SmallArgs(tmp.path() / "out");
    args.insert(args.end(), extra.begin(), extra.end());
    const auto run = RunTool(kTool, args, tmp.path());
    EXPECT_EQ(run.exit_code, 2) << extra[0] << " " << extra[1] << ": " << run.stderr_text;
  }
  EXPECT_FALSE(fs::exists(tmp.path() / "out" / "summary.json"));
}

}  // namespace
}  // namespace lunarnav
