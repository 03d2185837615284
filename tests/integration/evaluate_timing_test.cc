// Integration tests of `evaluate timing` (Figure 2) and `evaluate requests` (Figure 3) on
// rendered pairs of a quarter-size paper rig, with stereo-batch's window selection.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/rectified_rig.h"
#include "calib/stereo_rig_io.h"
#include "calib/window_selection.h"
#include "integration/run_tool.h"
#include "io/json_io.h"
#include "sim/layered_scene.h"
#include "util/testing.h"

namespace lunarnav {
namespace {
namespace fs = std::filesystem;
using testing::RunTool;
using util::ScopedTempDir;

// As in stereo_batch_rig_test: 160 x 120, f = 185 px, B = 0.9 m, 1.5 m up, 25 deg down, the
// rectified frame rolled and yawed, principal points 3 px apart.
calib::StereoRig TestRig() {
  return calib::testing::IdealRectifiedRig(160, 120, 185, 0.9, calib::testing::RollYaw(1.0, -2.0), -3.0);
}

struct Fixture {
  ScopedTempDir tmp;
  calib::StereoRig rig = TestRig();
  fs::path pairs, rig_file;
  std::vector<std::string> stems = {"f0", "f1", "f2", "f3", "f4"};
  Fixture() {
    pairs = tmp.path() / "pairs";
    for (const char* side : {"left", "right"}) fs::create_directories(pairs / side);
    for (std::size_t i = 0; i < stems.size(); ++i) {
      sim::LayeredSceneOptions scene;
      scene.width = 160;
      scene.height = 120;
      sim::PlaneLayer plane;  // the content does not matter here, only that it is not blank
      plane.d0_px = 30;
      plane.seed = static_cast<std::uint32_t>(i + 1);
      scene.layers = {plane};
      const sim::RenderedPair pair = sim::RenderLayeredPair(scene);
      cv::imwrite((pairs / "left" / (stems[i] + ".png")).string(), pair.left);
      cv::imwrite((pairs / "right" / (stems[i] + ".png")).string(), pair.right);
    }
    rig_file = tmp.path() / "rig.json";
    calib::WriteStereoRig(rig_file, rig);
  }
};

TEST(EvaluateRequests, AveragesTheWindowsStereoBatchUsedForTheRequests) {
  Fixture fx;
  // The planner's requests: an adjustment phase (f0), then steady intervals; f4 not requested.
  const std::vector<std::pair<double, double>> intervals = {{2.0, 3.0}, {4.0, 7.2}, {4.2, 7.5}, {4.4, 7.7}};
  {
    std::ofstream out(fx.tmp.path() / "requests.csv");
    out << "stem,y_min_m,y_max_m\n";
    for (std::size_t i = 0; i < intervals.size(); ++i) {
      out << fx.stems[i] << "," << intervals[i].first << "," << intervals[i].second << "\n";
    }
  }
  const fs::path run = fx.tmp.path() / "run", eval = fx.tmp.path() / "eval";
  const auto batch = RunTool("stereo-batch",
                             {fx.pairs.string(), "-o", run.string(), "-q", "--rig", fx.rig_file.string(), "--window",
                              "5x3", "--requests", (fx.tmp.path() / "requests.csv").string()},
                             fx.tmp.path());
  ASSERT_EQ(batch.exit_code, 0) << batch.stderr_text;
  const auto result = RunTool("evaluate", {"requests", run.string(), "-o", eval.string(), "-q"}, fx.tmp.path());
  ASSERT_EQ(result.exit_code, 0) << result.stderr_text;

  // The reference: each request's window by window selection (the heights stereo-batch uses by
  // default), averaged here.
  std::vector<calib::ImageWindow> windows;
  double sums[6] = {0, 0, 0, 0, 0, 0};
  for (const auto& [y0, y1] : intervals) {
    windows.push_back(calib::SelectWindow(fx.rig, {y0, y1, -0.5, 1.0}, calib::ReferenceImage::kRight));
    const calib::ImageWindow& w = windows.back();
    const double values[6] = {double(w.min_row), double(w.max_row), double(w.min_disparity_px),
                              double(w.max_disparity_px), y0, y1};
    for (int k = 0; k < 6; ++k) sums[k] += values[k];
  }
  const nlohmann::json summary = io::ReadJson(eval / "summary.json");
  EXPECT_EQ(summary["subcommand"], "requests");
  EXPECT_EQ(summary["counts"]["pairs"], 4);
  EXPECT_EQ(summary["counts"]["without_window"], 1);  // f4
  const nlohmann::json& rows = summary["table"]["rows"];
  ASSERT_EQ(rows.size(), 3u);
  for (int q = 0; q < 3; ++q) {
    EXPECT_NEAR(rows[q]["mean_min"].get<double>(), sums[2 * q] / 4, 1e-9) << q;
    EXPECT_NEAR(rows[q]["mean_max"].get<double>(), sums[2 * q + 1] / 4, 1e-9) << q;
  }
  EXPECT_DOUBLE_EQ(rows[2]["min_lowest"].get<double>(), 2.0);
  EXPECT_DOUBLE_EQ(rows[2]["max_highest"].get<double>(), 7.7);
  int lowest_d = windows[0].min_disparity_px;
  for (const auto& w : windows) lowest_d = std::min(lowest_d, w.min_disparity_px);
  EXPECT_EQ(rows[1]["min_lowest"].get<int>(), lowest_d);

  // Each pair's "within" flag against a brute-force check of its six bounds (10 % of the means).
  std::ifstream in(eval / "request_pairs.csv");
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "index,stem,source,y_min_px,y_max_px,d_min_px,d_max_px,Y_min_m,Y_max_m,within");
  int within = 0;
  for (std::size_t i = 0; i < windows.size(); ++i) {
    ASSERT_TRUE(std::getline(in, line));
    const calib::ImageWindow& w = windows[i];
    const double values[6] = {double(w.min_row), double(w.max_row), double(w.min_disparity_px),
                              double(w.max_disparity_px), intervals[i].first, intervals[i].second};
    bool ok = true;
    for (int k = 0; k < 6; ++k) ok = ok && std::abs(values[k] - sums[k] / 4) <= 0.1 * std::abs(sums[k] / 4) + 1e-12;
    within += ok;
    EXPECT_EQ(line.rfind(std::to_string(i) + "," + fx.stems[i] + ",requests,", 0), 0u) << line;
    EXPECT_EQ(line.back(), ok ? '1' : '0') << line;
  }
  EXPECT_FALSE(std::getline(in, line)) << "f4 has no window: " << line;
  EXPECT_EQ(summary["counts"]["within"], within);
  for (const char* f : {"requests.csv", "requests.json", "requests.md", "request_pairs.csv", "requests.gp"}) {
    EXPECT_TRUE(fs::exists(eval / f)) << f;
  }
  EXPECT_GT(fs::file_size(eval / "requests.png"), 1000u);

  // A run without window selection, a missing run: bad input.
  const fs::path plain = fx.tmp.path() / "plain";
  ASSERT_EQ(RunTool("stereo-batch", {fx.pairs.string(), "-o", plain.string(), "-q", "--window", "5x3"}, fx.tmp.path())
                .exit_code, 0);
  const auto no_windows = RunTool("evaluate", {"requests", plain.string(), "-o", eval.string()}, fx.tmp.path());
  EXPECT_EQ(no_windows.exit_code, 3);
  EXPECT_EQ(no_windows.ErrorLines(), 1) << no_windows.stderr_text;
  EXPECT_EQ(RunTool("evaluate", {"requests", (fx.tmp.path() / "none").string(), "-o", eval.string()}, fx.tmp.path())
                .exit_code, 3);
  EXPECT_EQ(RunTool("evaluate", {"requests", run.string(), "-o", eval.string(), "--tolerance", "2"}, fx.tmp.path())
                .exit_code, 2);
}

TEST(EvaluateTiming, TimesTheMatcherOverTheWindowsOfEachDeltaY) {
  Fixture fx;
  const fs::path out = fx.tmp.path() / "timing";
  const auto result =
      RunTool("evaluate",
              {"timing", fx.pairs.string(), "--rig", fx.rig_file.string(), "--delta-y", "1,2,4", "--repeat", "3",
               "--max-pairs", "2", "--window", "5x3", "--disparity", "0:60", "-o", out.string(), "-q"},
              fx.tmp.path());
  ASSERT_EQ(result.exit_code, 0) << result.stderr_text;
  const nlohmann::json summary = io::ReadJson(out / "summary.json");
  EXPECT_EQ(summary["subcommand"], "timing");
  EXPECT_EQ(summary["counts"]["pairs"], 2);
  const nlohmann::json& rows = summary["table"]["rows"];
  ASSERT_EQ(rows.size(), 4u);
  const double delta_y[3] = {1, 2, 4};
  // Each row's time is the median of its window's three recorded runs (ms), with their
  // quartiles; the normalised time divides by the slowest ΔY row's median.
  double medians[3];
  for (int i = 0; i < 3; ++i) {
    std::vector<double> runs = summary["windows"][i]["repeat_s"].get<std::vector<double>>();
    ASSERT_EQ(runs.size(), 3u);
    std::sort(runs.begin(), runs.end());
    medians[i] = 1e3 * runs[1];
    EXPECT_NEAR(rows[i]["time"].get<double>(), medians[i], 1e-9);
    // Three runs: h = 2 p puts the quartiles halfway between the 1st and 2nd, 2nd and 3rd.
    EXPECT_NEAR(rows[i]["time_q1"].get<double>(), 1e3 * 0.5 * (runs[0] + runs[1]), 1e-9);
    EXPECT_NEAR(rows[i]["time_q3"].get<double>(), 1e3 * 0.5 * (runs[1] + runs[2]), 1e-9);
  }
  const double largest = *std::max_element(medians, medians + 3);
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(rows[i]["time_normalised"].get<double>(), medians[i] / largest, 1e-12);
    const calib::ImageWindow w =
        calib::SelectWindow(fx.rig, {5.0, 5.0 + delta_y[i], -0.5, 1.0}, calib::ReferenceImage::kRight);
    EXPECT_EQ(rows[i]["delta_y"].get<double>(), delta_y[i]);
    EXPECT_EQ(rows[i]["row_min"].get<int>(), w.min_row);
    EXPECT_EQ(rows[i]["rows"].get<int>(), w.Rows());
    EXPECT_EQ(rows[i]["d_min"].get<int>(), w.min_disparity_px);
    EXPECT_EQ(rows[i]["disparities"].get<int>(), w.Disparities());
    EXPECT_NEAR(rows[i]["work_share"].get<double>(), 100.0 * w.Rows() * w.Disparities() / (120 * 61), 1e-9);
  }
  EXPECT_TRUE(rows[3]["delta_y"].contains("n/a"));  // the whole image
  EXPECT_EQ(rows[3]["rows"].get<int>(), 120);
  EXPECT_EQ(rows[3]["disparities"].get<int>(), 61);
  EXPECT_EQ(summary["windows"][3]["repeat_s"].size(), 3u);
  std::ifstream curve(out / "timing_curve.csv");
  std::string line;
  int lines = 0;
  while (std::getline(curve, line)) ++lines;
  EXPECT_EQ(lines, 4);
  EXPECT_GT(fs::file_size(out / "timing.png"), 1000u);
  for (const char* f : {"timing.csv", "timing.json", "timing.md", "timing.gp"}) EXPECT_TRUE(fs::exists(out / f)) << f;

  // Usage errors (no rig; a negative width) exit 2; an unreadable pairs directory exits 3.
  EXPECT_EQ(RunTool("evaluate", {"timing", fx.pairs.string(), "-o", out.string()}, fx.tmp.path()).exit_code, 2);
  EXPECT_EQ(RunTool("evaluate",
                    {"timing", fx.pairs.string(), "--rig", fx.rig_file.string(), "--delta-y", "-1", "-o",
                     out.string()},
                    fx.tmp.path()).exit_code, 2);
  const auto missing = RunTool("evaluate",
                               {"timing", (fx.tmp.path() / "none").string(), "--rig", fx.rig_file.string(), "-o",
                                out.string()},
                               fx.tmp.path());
  EXPECT_EQ(missing.exit_code, 3);
  EXPECT_EQ(missing.ErrorLines(), 1) << missing.stderr_text;
}

}  // namespace
}  // namespace lunarnav
