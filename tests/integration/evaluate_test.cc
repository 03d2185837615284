// Integration tests of the evaluate tool.
#include <gtest/gtest.h>

#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>

#include <nlohmann/json.hpp>

#include "integration/run_tool.h"
#include "evaluation/disparity_eval.h"
#include "io/image_io.h"
#include "io/json_io.h"
#include "positioning/trajectory_io.h"
#include "util/testing.h"

namespace lunarnav {
namespace {
namespace fs = std::filesystem;
using testing::RunTool;
using util::ScopedTempDir;
using util::TestDataPath;

TEST(EvaluateDisparity, ScoresStereoBatchOutputAgainstTheTestdataTruth) {
  ScopedTempDir tmp;
  const fs::path run = tmp.path() / "run", eval = tmp.path() / "eval";
  ASSERT_EQ(RunTool("stereo-batch", {TestDataPath("stereo_pairs").string(), "-o", run.string(), "-q"}, tmp.path())
                .exit_code, 0);
  const auto result = RunTool("evaluate", {"disparity", run.string(), "--truth",
                                           (TestDataPath("stereo_pairs") / "truth").string(), "-o", eval.string()},
                              tmp.path());
  ASSERT_EQ(result.exit_code, 0) << result.stderr_text;
  for (const char* ext : {".csv", ".json", ".md"}) EXPECT_TRUE(fs::exists(eval / (std::string("disparity") + ext)));
  const nlohmann::json summary = io::ReadJson(eval / "summary.json");
  EXPECT_EQ(summary["subcommand"], "disparity");
  EXPECT_EQ(summary["counts"]["scored"], 3);
  const nlohmann::json& all = summary["table"]["rows"][3];
  EXPECT_GT(all["density"].get<double>(), 60.0);
  EXPECT_LT(all["bad_1"].get<double>(), 5.0);  // the matcher on the fixture (see stereo_batch_test)

  // A truth made from the run's own maps with known errors: every 4th row's estimates 0.75 px
  // off, and a truth of 50 px where the map has no estimate. By hand: the density is the
  // share of pixels with an estimate, bad-0.5 and bad-1 the share of estimates on the shifted
  // rows and none, the mean |error| 0.75 px times that share.
  const fs::path perturbed = tmp.path() / "perturbed";
  fs::create_directories(perturbed);
  long pixels = 0, estimated = 0, shifted = 0;
  for (const char* stem : {"frame0000", "frame0001", "frame0002"}) {
    const cv::Mat estimate = io::ReadPfm(run / "disparity" / (std::string(stem) + ".pfm"));
    cv::Mat truth(estimate.size(), CV_32FC1);
    for (int r = 0; r < estimate.rows; ++r) {
      for (int c = 0; c < estimate.cols; ++c) {
        const float e = estimate.at<float>(r, c);
        ++pixels;
        if (!std::isfinite(e)) {
          truth.at<float>(r, c) = 50.0f;
          continue;
        }
        ++estimated;
        shifted += r % 4 == 0;
        truth.at<float>(r, c) = r % 4 == 0 ? e + 0.75f : e;
      }
    }
    io::WriteImageAtomic(perturbed / (std::string(stem) + ".pfm"), truth);
  }
  ASSERT_GT(estimated, pixels / 2);
  const auto known =
      RunTool("evaluate",
              {"disparity", run.string(), "--truth", perturbed.string(), "-o", (tmp.path() / "known").string(), "-q"},
              tmp.path());
  ASSERT_EQ(known.exit_code, 0) << known.stderr_text;
  const nlohmann::json known_all = io::ReadJson(tmp.path() / "known" / "summary.json")["table"]["rows"][3];
  EXPECT_EQ(known_all["truth_pixels"].get<long>(), pixels);
  EXPECT_NEAR(known_all["density"].get<double>(), 100.0 * estimated / pixels, 1e-9);
  EXPECT_NEAR(known_all["bad_0.5"].get<double>(), 100.0 * shifted / estimated, 1e-9);
  EXPECT_NEAR(known_all["bad_1"].get<double>(), 0.0, 1e-12);
  EXPECT_NEAR(known_all["mean_abs_error"].get<double>(), 0.75 * shifted / estimated, 1e-5);

  // A stem without truth: reported, n/a in the table, exit 4. No truth at all: exit 3.
  fs::copy_file(run / "disparity" / "frame0000.pfm", run / "disparity" / "extra.pfm");
  const auto partial = RunTool("evaluate", {"disparity", run.string(), "--truth",
                                            (TestDataPath("stereo_pairs") / "truth").string(), "-o", eval.string(),
                                            "-q"},
                               tmp.path());
  EXPECT_EQ(partial.exit_code, 4);
  EXPECT_EQ(partial.ErrorLines(), 1) << partial.stderr_text;
  EXPECT_NE(partial.stderr_text.find("extra"), std::string::npos);
  EXPECT_EQ(RunTool("evaluate", {"disparity", run.string(), "--truth", (tmp.path() / "none").string(), "-o",
                                 eval.string()}, tmp.path()).exit_code, 3);
  EXPECT_EQ(RunTool("evaluate", {"disparity", run.string(), "-o", eval.string()}, tmp.path()).exit_code, 2);
  EXPECT_EQ(RunTool("evaluate", {}, tmp.path()).exit_code, 2);
}

TEST(EvaluateTrials, ScoresAPosfilterTrajectoryAgainstTapeMeasuredTrials) {
  ScopedTempDir tmp;
  const fs::path pos = tmp.path() / "pos", eval = tmp.path() / "eval";
  ASSERT_EQ(RunTool("posfilter", {TestDataPath("telemetry/turning.csv").string(), "--sensors",
                                  TestDataPath("telemetry/ratler_sensors.json").string(), "-o", pos.string(), "-q"},
                    tmp.path()).exit_code, 0);
  // Trials whose "true" end points are the computed ones pulled 20 % closer to the start
  // (so the computed distance is 25 % long) and whose true turn is the computed one + 9 deg.
  const auto samples = positioning::ReadTrajectoryCsv(pos / "trajectory.csv");
  ASSERT_GT(samples.size(), 1000u);
  nlohmann::json trials = nlohmann::json::array();
  for (std::size_t a : {0ul, 400ul}) {
    const auto& s = samples[a];
    const auto& e = samples[a + 400];
    trials.push_back({{"start", {{"t_s", s.t_s}, {"x_m", s.x_m}, {"y_m", s.y_m}, {"heading_deg", s.heading_rad * 180 / M_PI}}},
                      {"end",
                       {{"t_s", e.t_s},
                        {"x_m", s.x_m + 0.8 * (e.x_m - s.x_m)},
                        {"y_m", s.y_m + 0.8 * (e.y_m - s.y_m)},
                        {"heading_deg", e.heading_rad * 180 / M_PI + 9}}}});
  }
  io::WriteJsonAtomic(tmp.path() / "trials.json", {{"format", "lunarnav.trials/1"}, {"trials", trials}});
  // The truth trajectory: the computed one 0.3 m east and 0.4 m south (0.5 m off everywhere).
  auto truth = samples;
  for (auto& p : truth) {
    p.x_m += 0.3;
    p.y_m -= 0.4;
  }
  positioning::WriteTrajectoryCsv(tmp.path() / "truth.csv", truth);
  const std::string set = "A=" + (pos / "trajectory.csv").string() + "," + (tmp.path() / "trials.json").string() + "," +
                          (tmp.path() / "truth.csv").string();
  const auto result = RunTool("evaluate", {"trials", "--set", set, "--align", "none", "-o", eval.string()}, tmp.path());
  ASSERT_EQ(result.exit_code, 0) << result.stderr_text;
  for (const char* name : {"trials", "trial_details", "trajectory_errors"}) {
    for (const char* ext : {".csv", ".json", ".md"}) EXPECT_TRUE(fs::exists(eval / (std::string(name) + ext)));
  }
  // The figure is drawn (gnuplot is one of the project's dependencies) and not empty.
  EXPECT_TRUE(fs::exists(eval / "trials.gp"));
  ASSERT_TRUE(fs::exists(eval / "trials.png"));
  EXPECT_GT(fs::file_size(eval / "trials.png"), 5000u);
  const nlohmann::json summary = io::ReadJson(eval / "summary.json");
  EXPECT_EQ(summary["counts"]["trials"], 2);
  const nlohmann::json& row = summary["table"]["rows"][0];
  EXPECT_NEAR(row["mean_distance"].get<double>(), 25.0, 0.05);
  EXPECT_NEAR(row["stdev_distance"].get<double>(), 0.0, 0.05);
  EXPECT_NEAR(row["mean_orient"].get<double>(), -100 * 9.0 / 360, 0.01);
  // Without alignment every pose is the 0.5 m shift off; the shift moves no pose relative to
  // another.
  const nlohmann::json& errors = summary["trajectory_errors"]["rows"][0];
  EXPECT_NEAR(errors["ape_rmse"].get<double>(), 0.5, 1e-6);
  EXPECT_NEAR(errors["ape_max"].get<double>(), 0.5, 1e-6);
  EXPECT_NEAR(errors["rpe_rmse"].get<double>(), 0.0, 1e-6);

  // A malformed --set is a usage error; a trial outside the trajectory is bad input.
  EXPECT_EQ(RunTool("evaluate", {"trials", "--set", "A=only-one-path", "-o", eval.string()}, tmp.path()).exit_code,
            2);
  trials[1]["end"]["t_s"] = 1e6;
  io::WriteJsonAtomic(tmp.path() / "trials.json", {{"format", "lunarnav.trials/1"}, {"trials", trials}});
  const auto outside = RunTool("evaluate", {"trials", "--set", set, "-o", eval.string()}, tmp.path());
  EXPECT_EQ(outside.exit_code, 3);
  EXPECT_EQ(outside.ErrorLines(), 1) << outside.stderr_text;
}

// posfilter's trajectory and baseline against a truth that is the trajectory itself turned by
// 20 deg and moved: after the 2-D alignment the trajectory has no error, the baseline its
// difference from the trajectory, and the ratio is 0.
TEST(EvaluateTrajectory, GivesEachEstimatesErrorAndItsRatioToTheReference) {
  ScopedTempDir tmp;
  const fs::path pos = tmp.path() / "pos", eval = tmp.path() / "eval";
  ASSERT_EQ(RunTool("posfilter", {TestDataPath("telemetry/turning.csv").string(), "--sensors",
                                  TestDataPath("telemetry/ratler_sensors.json").string(), "-o", pos.string(), "-q"},
                    tmp.path()).exit_code, 0);
  auto samples = positioning::ReadTrajectoryCsv(pos / "trajectory.csv");
  const double c = std::cos(0.35), s = std::sin(0.35);
  for (auto& p : samples) {
    const double x = p.x_m, y = p.y_m;
    p.x_m = 3 + c * x - s * y;
    p.y_m = -2 + s * x + c * y;
  }
  positioning::WriteTrajectoryCsv(tmp.path() / "truth.csv", samples);
  const auto result = RunTool("evaluate", {"trajectory", "filtered=" + (pos / "trajectory.csv").string(),
                                           "baseline=" + (pos / "baseline.csv").string(), "--truth",
                                           (tmp.path() / "truth.csv").string(), "-o", eval.string(), "-q"},
                              tmp.path());
  ASSERT_EQ(result.exit_code, 0) << result.stderr_text;
  const nlohmann::json summary = io::ReadJson(eval / "summary.json");
  EXPECT_NEAR(summary["estimates"]["filtered"]["ape_mean_m"].get<double>(), 0.0, 1e-3);
  EXPECT_NEAR(summary["estimates"]["filtered"]["ape_mean_ratio"].get<double>(), 0.0, 1e-2);

  // Without alignment, against the trajectory moved 0.3 m east and 0.4 m north: the
  // trajectory is 0.5 m off at every pose, the baseline as far as it is from that truth at
  // its own poses (once a second, at times the trajectory also has a pose), and the ratio is
  // their quotient.
  auto trajectory = positioning::ReadTrajectoryCsv(pos / "trajectory.csv");
  const auto baseline = positioning::ReadTrajectoryCsv(pos / "baseline.csv");
  std::map<double, std::size_t> at_time;
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    trajectory[i].x_m += 0.3;
    trajectory[i].y_m += 0.4;
    at_time[trajectory[i].t_s] = i;
  }
  double baseline_sum = 0;
  for (const auto& b : baseline) {
    ASSERT_EQ(at_time.count(b.t_s), 1u) << b.t_s;
    const auto& t = trajectory[at_time[b.t_s]];
    baseline_sum += std::sqrt(std::pow(b.x_m - t.x_m, 2) + std::pow(b.y_m - t.y_m, 2) + std::pow(b.z_m - t.z_m, 2));
  }
  positioning::WriteTrajectoryCsv(tmp.path() / "shifted.csv", trajectory);
  const auto none = RunTool(
      "evaluate",
      {"trajectory", "filtered=" + (pos / "trajectory.csv").string(), "baseline=" + (pos / "baseline.csv").string(),
       "--truth", (tmp.path() / "shifted.csv").string(), "--align", "none", "-o", (tmp.path() / "none").string(), "-q"},
      tmp.path());
  ASSERT_EQ(none.exit_code, 0) << none.stderr_text;
  const nlohmann::json estimates = io::ReadJson(tmp.path() / "none" / "summary.json")["estimates"];
  const double baseline_mean = baseline_sum / baseline.size();
  EXPECT_NEAR(estimates["filtered"]["ape_mean_m"].get<double>(), 0.5, 1e-6);
  EXPECT_NEAR(estimates["baseline"]["ape_mean_m"].get<double>(), baseline_mean, 1e-6);
  EXPECT_NEAR(estimates["filtered"]["ape_mean_ratio"].get<double>(), 0.5 / baseline_mean, 1e-6);
  // A malformed estimate or alignment is a usage error.
  EXPECT_EQ(RunTool("evaluate", {"trajectory", "no-name", "--truth", (tmp.path() / "truth.csv").string(), "-o",
                                 eval.string()}, tmp.path()).exit_code, 2);
  EXPECT_EQ(RunTool("evaluate", {"trajectory", "a=" + (pos / "trajectory.csv").string(), "--align", "wobbly",
                                 "--truth", (tmp.path() / "truth.csv").string(), "-o", eval.string()}, tmp.path())
                .exit_code, 2);
  // So is a name given twice (the table's rows and --reference are by name).
  const auto twice = RunTool("evaluate", {"trajectory", "a=" + (pos / "trajectory.csv").string(),
                                          "a=" + (pos / "baseline.csv").string(), "--reference", "a", "--truth",
                                          (tmp.path() / "truth.csv").string(), "-o", eval.string()},
                             tmp.path());
  EXPECT_EQ(twice.exit_code, 2);
  EXPECT_NE(twice.stderr_text.find("the name 'a' is given twice"), std::string::npos) << twice.stderr_text;
  // An estimate that meets the truth at one pose only: bad input naming both files.
  const fs::path one = tmp.path() / "one_pose_truth.csv";
  {
    std::ifstream in(tmp.path() / "truth.csv");
    std::ofstream out(one);
    std::string line;
    int data = 0;
    while (std::getline(in, line) && data < 1) {
      out << line << "\n";
      data += !line.empty() && std::isdigit(static_cast<unsigned char>(line[0])) ? 1 : 0;
    }
  }
  const auto short_truth = RunTool("evaluate", {"trajectory", "a=" + (pos / "trajectory.csv").string(), "--reference",
                                                "a", "--truth", one.string(), "-o", eval.string()},
                                   tmp.path());
  EXPECT_EQ(short_truth.exit_code, 3) << short_truth.stderr_text;
  EXPECT_NE(short_truth.stderr_text.find("trajectory.csv against " + one.string()), std::string::npos)
      << short_truth.stderr_text;
}

TEST(EvaluateCorrelation, FindsTheTrueDisparityAtEverySubsampling) {
  ScopedTempDir tmp;
  const fs::path pairs = TestDataPath("stereo_pairs"), out = tmp.path() / "corr";
  const cv::Mat truth = evaluation::ReadTruthDisparity(pairs / "truth" / "disparity" / "frame0000.png", 256);
  const int x = 320, y = 300;
  const double d_true = truth.at<float>(y, x);
  ASSERT_TRUE(std::isfinite(d_true));
  const auto result = RunTool("evaluate", {"correlation", (pairs / "left" / "frame0000.png").string(),
                                           (pairs / "right" / "frame0000.png").string(), "--pixel", "320,300",
                                           "-o", out.string(), "-q"},
                              tmp.path());
  ASSERT_EQ(result.exit_code, 0) << result.stderr_text;
  ASSERT_TRUE(fs::exists(out / "correlation.png"));
  EXPECT_GT(fs::file_size(out / "correlation.png"), 5000u);
  const nlohmann::json rows = io::ReadJson(out / "summary.json")["table"]["rows"];
  ASSERT_EQ(rows.size(), 9u);
  for (const auto& row : rows) {
    // Partial subsampling finds the true disparity at every (dx, dy), as in Figure 5.
    EXPECT_NEAR(row["subpixel_disparity"].get<double>(), d_true, 0.5) << row.dump();
  }
  // The curves file: a header and one row per disparity 0..127.
  std::ifstream curves(out / "correlation_curves.csv");
  std::string header;
  std::getline(curves, header);
  EXPECT_EQ(header.rfind("d_px,C_dx1_dy1,C_dx1_dy2", 0), 0u) << header;
  // The full-resolution curve at the true disparity (rounded) against normalized correlation
  // computed here by hand over the 51 x 35 window: right (reference) pixel (x, y), left (x + d, y).
  const int d = static_cast<int>(std::lround(d_true));
  const cv::Mat left = io::ReadGreyImage(pairs / "left" / "frame0000.png");
  const cv::Mat right = io::ReadGreyImage(pairs / "right" / "frame0000.png");
  cv::Mat l, r;
  left.convertTo(l, CV_64F);
  right.convertTo(r, CV_64F);
  const cv::Rect window_right(x - 25, y - 17, 51, 35), window_left(x + d - 25, y - 17, 51, 35);
  cv::Mat a = r(window_right) - cv::mean(r(window_right))[0], b = l(window_left) - cv::mean(l(window_left))[0];
  const double c_hand = a.dot(b) / std::sqrt(a.dot(a) * b.dot(b));
  int lines = 0;
  double c_file = NAN;
  for (std::string line; std::getline(curves, line);) {
    if (lines++ == d) c_file = std::stod(line.substr(line.find(',') + 1));
  }
  EXPECT_EQ(lines, 128);
  EXPECT_NEAR(c_file, c_hand, 1e-4) << "d = " << d;
  EXPECT_GT(c_hand, 0.5);

  EXPECT_EQ(RunTool("evaluate", {"correlation", (pairs / "left" / "frame0000.png").string(),
                                 (pairs / "right" / "frame0000.png").string(), "--pixel", "9999,3", "-o", out.string()},
                    tmp.path()).exit_code, 3);
  EXPECT_EQ(RunTool("evaluate", {"correlation", (pairs / "left" / "frame0000.png").string(),
                                 (pairs / "right" / "frame0000.png").string(), "-o", out.string()},
                    tmp.path()).exit_code, 2);
}

TEST(EvaluateBoxes, SimulatedBoxExperimentStaysWithinThePredictedError) {
  ScopedTempDir tmp;
  const fs::path sim = tmp.path() / "sim";
  // The box experiment of sec. 3.4 at half the paper's resolution (and focal length).
  ASSERT_EQ(RunTool("simulate", {"stereo", "--preset", "boxes", "--rectified", "--width", "320", "--height", "240",
                                 "--focal", "370", "-o", sim.string(), "-q"},
                    tmp.path()).exit_code, 0);
  std::vector<std::string> args = {"boxes"};
  for (const char* step : {"1x1", "5x4"}) {
    const fs::path run = tmp.path() / (std::string("run-") + step);
    ASSERT_EQ(RunTool("stereo-batch", {sim.string(), "-o", run.string(), "--preset", "paper", "--rig",
                                       (sim / "rig.json").string(), "--disparity", "0:160", "--window", "13x9",
                                       "--step", step, "-q"},
                      tmp.path()).exit_code, 0);
    args.push_back(run.string());
  }
  const fs::path eval = tmp.path() / "eval";
  args.insert(args.end(), {"--boxes", (sim / "truth" / "boxes.json").string(), "--truth", (sim / "truth").string(),
                           "--rig", (sim / "rig.json").string()});
  // Selected by the truth, with no gate: every measurement of every face counts, the wrong
  // matches too.
  std::vector<std::string> ungated = args;
  ungated.insert(ungated.end(), {"-o", (tmp.path() / "ungated").string()});
  const auto result = RunTool("evaluate", ungated, tmp.path());
  ASSERT_EQ(result.exit_code, 0) << result.stderr_text;
  const nlohmann::json summary = io::ReadJson(tmp.path() / "ungated" / "summary.json");
  EXPECT_EQ(summary["counts"]["gated_out"], 0);
  EXPECT_TRUE(summary["options"]["y_gate_fraction"].is_null());
  long points = 0;
  for (const auto& row : summary["table"]["rows"]) {
    points += row["points_dx1_dy1"].get<long>() + row["points_dx5_dy4"].get<long>();
  }
  EXPECT_EQ(summary["counts"]["face_points"].get<long>(), points);

  // A gate of 30 % of Y: it drops the gross errors, counts every one, and they are few.
  std::vector<std::string> gated = args;
  gated.insert(gated.end(), {"--y-gate", "0.3", "-o", eval.string()});
  ASSERT_EQ(RunTool("evaluate", gated, tmp.path()).exit_code, 0);
  ASSERT_TRUE(fs::exists(eval / "boxes.png"));
  EXPECT_GT(fs::file_size(eval / "boxes.png"), 5000u);
  const nlohmann::json gated_summary = io::ReadJson(eval / "summary.json");
  const nlohmann::json& rows = gated_summary["table"]["rows"];
  ASSERT_EQ(rows.size(), 7u);  // boxes at 2, 3, ..., 8 m
  EXPECT_EQ(gated_summary["counts"]["face_points"].get<long>(), points);
  long kept = 0;
  for (const auto& row : rows) {
    kept += row["points_dx1_dy1"].get<long>() + row["points_dx5_dy4"].get<long>();
    // Full resolution: every face measured, within the rig's predicted 1-pixel error
    // (the matcher's sub-pixel disparities are better than 1 px on these clean faces).
    EXPECT_GT(row["points_dx1_dy1"].get<double>(), 100) << row.dump();
    EXPECT_LT(row["e_y_dx1_dy1"].get<double>(), row["predicted_1px"].get<double>()) << row.dump();
    // Figure 4's claim, E_Y independent of the subsampling: (5, 4) within half the 1-pixel
    // prediction of (1, 1) at every distance.
    EXPECT_GT(row["points_dx5_dy4"].get<double>(), 0) << row.dump();
    EXPECT_NEAR(row["e_y_dx5_dy4"].get<double>(), row["e_y_dx1_dy1"].get<double>(),
                0.5 * row["predicted_1px"].get<double>())
        << row.dump();
  }
  const long dropped = gated_summary["counts"]["gated_out"].get<long>();
  EXPECT_EQ(dropped, points - kept);
  // Measured when written: 24 of 7990 (all on the 7 m face at full resolution).
  EXPECT_LT(dropped, 0.01 * points) << dropped << " of " << points;
  args.insert(args.end(), {"-o", eval.string()});
  // A run without XYZ maps is bad input; no box list is a usage error.
  fs::remove_all(tmp.path() / "run-5x4" / "xyz");
  EXPECT_EQ(RunTool("evaluate", args, tmp.path()).exit_code, 3);
  EXPECT_EQ(RunTool("evaluate", {"boxes", args[1], "-o", eval.string()}, tmp.path()).exit_code, 2);
}

}  // namespace
}  // namespace lunarnav
