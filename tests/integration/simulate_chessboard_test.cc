// Integration tests of `simulate chessboard`, alone and chained with calibrate.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "calib/rectify.h"
#include "calib/stereo_rig_io.h"
#include "integration/run_tool.h"
#include "io/json_io.h"
#include "util/testing.h"

namespace lunarnav {
namespace {
namespace fs = std::filesystem;
using testing::RunTool;
using util::ScopedTempDir;

// `simulate chessboard -o DIR ARGS -q`, expecting success.
void Simulate(const fs::path& dir, const std::vector<std::string>& args, const fs::path& scratch) {
  std::vector<std::string> all = {"chessboard", "-o", dir.string(), "-q"};
  all.insert(all.end(), args.begin(), args.end());
  const auto run = RunTool("simulate", all, scratch);
  ASSERT_EQ(run.exit_code, 0) << run.stderr_text;
}

std::vector<cv::Point2d> Corners(const nlohmann::json& j) {
  std::vector<cv::Point2d> out;
  for (const auto& p : j) out.emplace_back(p[0].get<double>(), p[1].get<double>());
  return out;
}

TEST(SimulateChessboard, CalibrateRecoversTheTrueRig) {
  ScopedTempDir tmp;
  const fs::path sim = tmp.path() / "sim", rig_path = tmp.path() / "calib" / "rig.json";
  // The paper's rig at full size (at 320 x 240 the squares are 7-15 px wide and OpenCV's
  // detector misses most of them); 8 views keep the test at a few seconds.
  Simulate(sim, {"--views", "8", "-j", "2"}, tmp.path());
  for (const char* f : {"left/view_000.png", "right/view_007.png", "rig.json", "truth.json", "summary.json"}) {
    EXPECT_TRUE(fs::is_regular_file(sim / f)) << f;
  }
  EXPECT_FALSE(fs::exists(sim / "left" / "view_008.png"));
  const nlohmann::json summary = io::ReadJson(sim / "summary.json");
  EXPECT_EQ(summary["tool"], "simulate");
  EXPECT_EQ(summary["subcommand"], "chessboard");
  EXPECT_EQ(summary["counts"]["views"], 8);
  EXPECT_EQ(summary["options"]["views"]["board"]["inner_corners"], nlohmann::json({9, 6}));

  const auto run = RunTool("calibrate", {sim.string(), "-o", rig_path.string(), "--square", "0.1", "-j", "2", "-q"},
                           tmp.path());
  ASSERT_EQ(run.exit_code, 0) << run.stderr_text;
  const calib::StereoRig truth = calib::ReadStereoRig(sim / "rig.json");
  const calib::StereoRig rig = calib::ReadStereoRig(rig_path);
  EXPECT_EQ(truth.width_px, 640);
  EXPECT_EQ(truth.left.K(0, 0), 740.0);
  EXPECT_NEAR(truth.BaselineM(), 0.9, 0.001);
  // Focal lengths within 0.5 %, principal points within a few pixels, baseline within 1 %.
  for (const auto& [estimated, expected] : {std::pair{&rig.left, &truth.left}, {&rig.right, &truth.right}}) {
    EXPECT_NEAR(estimated->K(0, 0), expected->K(0, 0), 0.005 * expected->K(0, 0));
    EXPECT_NEAR(estimated->K(1, 1), expected->K(1, 1), 0.005 * expected->K(1, 1));
    EXPECT_NEAR(estimated->K(0, 2), expected->K(0, 2), 3.0);
    EXPECT_NEAR(estimated->K(1, 2), expected->K(1, 2), 3.0);
  }
  EXPECT_NEAR(rig.BaselineM(), truth.BaselineM(), 0.01 * truth.BaselineM());
  // Rectified with the estimated rig, the exact corners (truth.json) of every view lie on
  // the same row within 0.1 px.
  const calib::Rectifier rectifier(calib::RectifyRig(rig));
  const nlohmann::json views = io::ReadJson(sim / "truth.json")["views"];
  ASSERT_EQ(views.size(), 8u);
  double worst = 0;
  for (const auto& view : views) {
    const auto left = rectifier.RectifyPoints(Corners(view["left_corners_px"]), true);
    const auto right = rectifier.RectifyPoints(Corners(view["right_corners_px"]), false);
    ASSERT_EQ(left.size(), 54u);
    for (std::size_t i = 0; i < left.size(); ++i) worst = std::max(worst, std::abs(left[i].y - right[i].y));
  }
  EXPECT_LT(worst, 0.1);
  const nlohmann::json calib_summary = io::ReadJson(tmp.path() / "calib" / "summary.json");
  EXPECT_EQ(calib_summary["counts"]["views_used"], 8);  // the board is found in every rendered view
}

TEST(SimulateChessboard, SameSeedSameBytesOtherSeedOtherBytes) {
  ScopedTempDir tmp;
  const std::vector<std::string> args = {"--views", "3", "--width", "160", "--height", "120", "--focal", "185"};
  std::vector<std::string> two_threads = args;
  two_threads.insert(two_threads.end(), {"-j", "2"});
  Simulate(tmp.path() / "a", two_threads, tmp.path());
  std::vector<std::string> one_thread = args;
  one_thread.insert(one_thread.end(), {"-j", "1"});
  Simulate(tmp.path() / "b", one_thread, tmp.path());
  std::vector<std::string> other = args;
  other.insert(other.end(), {"--seed", "2"});
  Simulate(tmp.path() / "c", other, tmp.path());
  const std::vector<std::string> files = testing::DataFiles(tmp.path() / "a");
  EXPECT_EQ(files, testing::DataFiles(tmp.path() / "b"));
  EXPECT_EQ(files.size(), 8u);  // 3 + 3 images, rig.json, truth.json
  for (const std::string& f : files) EXPECT_EQ(testing::ReadFileBytes(tmp.path() / "a" / f), testing::ReadFileBytes(tmp.path() / "b" / f)) << f;
  EXPECT_NE(testing::ReadFileBytes(tmp.path() / "a" / "left" / "view_000.png"), testing::ReadFileBytes(tmp.path() / "c" / "left" / "view_000.png"));
  EXPECT_NE(testing::ReadFileBytes(tmp.path() / "a" / "truth.json"), testing::ReadFileBytes(tmp.path() / "c" / "truth.json"));
  EXPECT_EQ(testing::ReadFileBytes(tmp.path() / "a" / "rig.json"), testing::ReadFileBytes(tmp.path() / "c" / "rig.json"));  // the seed moves the board only
}

TEST(SimulateChessboard, TheRigIsTheOneSimulateStereoRendersWithTheSameRigOptions) {
  // So that calibrating on `simulate chessboard` output calibrates `simulate stereo`'s rig.
  ScopedTempDir tmp;
  const std::vector<std::string> rig = {"--width", "160", "--height", "120", "--focal", "185", "--baseline", "0.5",
                                        "--tilt", "20", "--no-rotation"};
  std::vector<std::string> chessboard = rig;
  chessboard.insert(chessboard.end(), {"--views", "1", "--square", "0.05"});
  Simulate(tmp.path() / "cb", chessboard, tmp.path());
  std::vector<std::string> stereo = {"stereo", "-o", (tmp.path() / "st").string(), "--terrain-cell", "0.05",
                                     "--rays", "1", "-q"};
  stereo.insert(stereo.end(), rig.begin(), rig.end());
  const auto run = RunTool("simulate", stereo, tmp.path());
  ASSERT_EQ(run.exit_code, 0) << run.stderr_text;
  EXPECT_EQ(testing::ReadFileBytes(tmp.path() / "cb" / "rig.json"), testing::ReadFileBytes(tmp.path() / "st" / "rig.json"));
  const calib::StereoRig read = calib::ReadStereoRig(tmp.path() / "cb" / "rig.json");
  EXPECT_EQ(read.left.K(0, 0), 185.0);
  EXPECT_NEAR(read.BaselineM(), 0.5, 1e-12);
  EXPECT_EQ(read.mast.tilt_deg, 20.0);
  EXPECT_TRUE(read.right_from_left_R.isIdentity(0.0));
}

TEST(SimulateChessboard, TheTestdataFixtureIsWhatItsCommandWrites) {
  // testdata/README.md: simulate chessboard --views 6 --noise 0 --seed 1 -o testdata/chessboard
  ScopedTempDir tmp;
  Simulate(tmp.path() / "cb", {"--views", "6", "--noise", "0", "--seed", "1"}, tmp.path());
  const std::vector<std::string> files = testing::DataFiles(tmp.path() / "cb");
  EXPECT_EQ(files, testing::DataFiles(util::TestDataPath("chessboard")));
  EXPECT_EQ(files.size(), 14u);
  for (const std::string& f : files) {
    EXPECT_EQ(testing::ReadFileBytes(tmp.path() / "cb" / f), testing::ReadFileBytes(util::TestDataPath("chessboard/" + f)))
        << f << " differs: regenerate the fixture (testdata/README.md)";
  }
}

TEST(SimulateChessboard, BadOptionsAreUsageErrorsWithOneErrorLine) {
  ScopedTempDir tmp;
  const fs::path out = tmp.path() / "out";
  for (const std::vector<std::string>& extra :
       {std::vector<std::string>{"--board", "2x6"}, {"--views", "0"}, {"--square", "-0.1"}, {"--distance", "5:2"},
        {"--noise", "-1"}, {"--width", "8"}, {"--square", "1"} /* cannot fit both images */}) {
    std::vector<std::string> args = {"chessboard", "-o", out.string(), "--height", "120", "--focal", "185"};
    args.insert(args.end(), extra.begin(), extra.end());
    if (extra[0] != "--views") args.insert(args.end(), {"--views", "2"});
    if (extra[0] != "--width") args.insert(args.end(), {"--width", "160"});
    const auto run = RunTool("simulate", args, tmp.path());
    EXPECT_EQ(run.exit_code, 2) << extra[0] << " " << extra[1] << ": " << run.stderr_text;
    EXPECT_EQ(run.ErrorLines(), 1) << extra[0] << " " << extra[1] << ": " << run.stderr_text;
  }
  EXPECT_EQ(RunTool("simulate", {"chessboard", "--views", "2"}, tmp.path()).exit_code, 2);  // no -o
  EXPECT_FALSE(fs::exists(out / "summary.json"));
  EXPECT_FALSE(fs::exists(out / "rig.json"));
}

}  // namespace
}  // namespace lunarnav
