// Integration tests of stereo-batch with a rig: XYZ in the vehicle frame, point clouds,
// predicted errors and window selection, on rendered pairs of known geometry.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <tuple>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/rectified_rig.h"
#include "calib/stereo_rig_io.h"
#include "calib/window_selection.h"
#include "integration/run_tool.h"
#include "io/float_array_io.h"
#include "io/image_io.h"
#include "io/json_io.h"
#include "io/ply_io.h"
#include "sim/layered_scene.h"
#include "util/testing.h"

namespace lunarnav {
namespace {
namespace fs = std::filesystem;
using testing::RunTool;
using util::ScopedTempDir;

// A quarter-size version of the paper's rig (160 x 120, f = 185 px, B = 0.9 m, 1.5 m up, 25 deg
// down: the same angles), its rectified frame rolled and yawed against the cameras and its
// rectified principal points 3 px apart, so that nothing relies on an aligned rig.
calib::StereoRig TestRig() {
  return calib::testing::IdealRectifiedRig(160, 120, 185, 0.9, calib::testing::RollYaw(1.0, -2.0), -3.0);
}

// Where the ray of right-image pixel (x, y) meets the flat ground (vehicle Z = 0), by
// intersecting the ray with the plane; NaN when it does not.
Eigen::Vector3d GroundPoint(const calib::StereoRig& rig, double x, double y) {
  const calib::RectifiedGeometry& g = *rig.rectified;
  const double f = g.P_right(0, 0), baseline = -g.P_right(0, 3) / f;
  const Eigen::Isometry3d vehicle_from_left = rig.VehicleFromLeft();
  const Eigen::Matrix3d vehicle_from_rect = vehicle_from_left.linear() * g.rect_from_left.transpose();
  const Eigen::Vector3d origin = vehicle_from_left * (g.rect_from_left.transpose() * Eigen::Vector3d(baseline, 0, 0));
  const Eigen::Vector3d ray = vehicle_from_rect * Eigen::Vector3d((x - g.P_right(0, 2)) / f, (y - g.P_right(1, 2)) / f, 1);
  const double t = -origin.z() / ray.z();
  return t > 0 ? Eigen::Vector3d(origin + t * ray) : Eigen::Vector3d::Constant(NAN);
}

// Disparity x_left - x_right of the ground seen at right-image pixel (x, y).
double GroundDisparity(const calib::StereoRig& rig, double x, double y) {
  const calib::RectifiedGeometry& g = *rig.rectified;
  const Eigen::Vector3d in_rect = g.rect_from_left * (rig.VehicleFromLeft().inverse() * GroundPoint(rig, x, y));
  const Eigen::Vector3d l = g.P_left * in_rect.homogeneous();
  return l.x() / l.z() - x;
}

// Renders the textured ground as a rectified pair (its disparity is affine in the right image:
// a plane) into DIR/left/STEM.png and DIR/right/STEM.png; returns the right image.
cv::Mat RenderGroundPair(const calib::StereoRig& rig, const fs::path& dir, const std::string& stem,
                         std::uint32_t seed) {
  sim::PlaneLayer ground;  // from the bottom rows, which see the ground whatever the tilt
  const double bottom = rig.rectified->height_px - 1, d_bottom = GroundDisparity(rig, 0, bottom);
  ground.slope_x = GroundDisparity(rig, 1, bottom) - d_bottom;
  ground.slope_y = d_bottom - GroundDisparity(rig, 0, bottom - 1);
  ground.d0_px = d_bottom - bottom * ground.slope_y;
  EXPECT_NEAR(ground.d0_px + 150 * ground.slope_x + 110 * ground.slope_y, GroundDisparity(rig, 150, 110), 1e-6)
      << "the ground's disparity is not affine";
  ground.texture_scale_px = 2.0;
  ground.seed = seed;
  sim::LayeredSceneOptions scene;
  scene.width = rig.rectified->width_px;
  scene.height = rig.rectified->height_px;
  scene.layers = {ground};
  const sim::RenderedPair pair = sim::RenderLayeredPair(scene);
  for (const char* side : {"left", "right"}) fs::create_directories(dir / side);
  cv::imwrite((dir / "left" / (stem + ".png")).string(), pair.left);
  cv::imwrite((dir / "right" / (stem + ".png")).string(), pair.right);
  return pair.right;
}

struct Fixture {
  ScopedTempDir tmp;
  calib::StereoRig rig = TestRig();
  fs::path in, rig_file;
  cv::Mat right_a;
  Fixture() {
    in = tmp.path() / "pairs";
    right_a = RenderGroundPair(rig, in, "a", 1);
    RenderGroundPair(rig, in, "b", 2);
    rig_file = tmp.path() / "rig.json";
    calib::WriteStereoRig(rig_file, rig);
  }
  std::vector<std::string> Args(const fs::path& out, std::vector<std::string> extra = {}) const {
    std::vector<std::string> args = {in.string(), "-o", out.string(), "-q", "--rig", rig_file.string(),
                                     "--window", "12x3"};
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  }
};

double Quantile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(q * (v.size() - 1))];
}

TEST(StereoBatchRig, XyzAgreesWithTheGroundAndThePredictedErrorScalesIt) {
  Fixture fx;
  const fs::path out = fx.tmp.path() / "out";
  const auto run = RunTool("stereo-batch", fx.Args(out, {"--disparity", "0:100", "--ply", "--xyz-sigma"}), fx.tmp.path());
  ASSERT_EQ(run.exit_code, 0) << run.stderr_text;
  const io::ExrImage xyz = io::ReadExr(out / "xyz" / "a.exr");
  const io::ExrImage sigma = io::ReadExr(out / "xyz_sigma" / "a.exr");
  const cv::Mat disparity = io::ReadPfm(out / "disparity" / "a.pfm");
  ASSERT_EQ(xyz.pixels.type(), CV_32FC3);
  ASSERT_EQ(xyz.pixels.size(), cv::Size(160, 120));
  ASSERT_EQ(sigma.pixels.type(), CV_32FC3);
  EXPECT_EQ(xyz.attributes.at("lunarnav:units"), "m");

  // Each measured point against the ground point of its pixel, in units of the predicted
  // error of a one-pixel disparity error (the error runs along the ray, so the distance
  // between the two is the disparity error times the predicted error's length).
  std::vector<double> error_in_px, height_m;
  int points = 0;
  for (int y = 0; y < 120; ++y) {
    for (int x = 0; x < 160; ++x) {
      const cv::Vec3f p = xyz.pixels.at<cv::Vec3f>(y, x);
      const bool has_point = std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
      // NaN where there is no disparity, or a (false) one at or beyond infinity.
      const double offset = fx.rig.rectified->P_left(0, 2) - fx.rig.rectified->P_right(0, 2);
      const float d = disparity.at<float>(y, x);
      ASSERT_EQ(has_point, std::isfinite(d) && d > offset) << x << "," << y;
      if (!has_point) continue;
      ++points;
      const cv::Vec3f s = sigma.pixels.at<cv::Vec3f>(y, x);
      const Eigen::Vector3d truth = GroundPoint(fx.rig, x, y);
      const double error_m = (Eigen::Vector3d(p[0], p[1], p[2]) - truth).norm();
      error_in_px.push_back(error_m / Eigen::Vector3d(s[0], s[1], s[2]).norm());
      height_m.push_back(std::abs(p[2]));
      // The measured disparity's own error predicts the 3-D error (up to the direction of the
      // ray, which is the same for both).
      // With d' = d - (c_left - c_right): |P - P_true| / |dP/dd| = |d - d_true| d' / d'_true.
      const double d_true = GroundDisparity(fx.rig, x, y);
      EXPECT_NEAR(error_in_px.back(), std::abs(d - d_true) * (d - offset) / (d_true - offset), 1e-3)
          << x << "," << y;
    }
  }
  // Most of the image: the far right columns (x + d beyond the left image, d up to 80 px
  // here) have no match, and the steep slant of the ground near the bottom lowers C.
  ASSERT_GT(points, 0.4 * 160 * 120);
  // Sub-pixel matching of a steeply slanted plane (the ground's disparity changes by 0.55 px
  // per row here, 3.5 px over the 7-row window): measured 0.21 px median, 0.62 px 95 %.
  EXPECT_LT(Quantile(error_in_px, 0.5), 0.3);
  EXPECT_LT(Quantile(error_in_px, 0.95), 1.0);
  EXPECT_LT(Quantile(height_m, 0.5), 0.05);     // the ground is flat at Z = 0
  const nlohmann::json summary = io::ReadJson(out / "summary.json");
  EXPECT_EQ(summary["counts"]["points"], points + summary["pairs"][1]["result"]["points"].get<int>());
  // Where the time went (docs/performance.md's profile): every stage in the order it ran,
  // summed over the pairs; the matcher's stages add up to its match time, and every output
  // written has its stage.
  std::vector<std::string> stages;
  double match_stages = 0;
  for (const nlohmann::json& st : summary["timings_s"]["stages_sum"]) {
    stages.push_back(st["stage"]);
    EXPECT_GE(st["seconds"].get<double>(), 0.0) << stages.back();
    if (stages.back().rfind("match: ", 0) == 0) match_stages += st["seconds"].get<double>();
  }
  const std::vector<std::string> expected = {
      "vertical alignment (measure)",  // with a rig it measures (and finds these rows aligned)
      "decode and check",         "match: census",          "match: aggregation",     "match: texture",
      "match: selection",         "match: left_right",      "match: filters",         "match: scatter",
      "write disparity (PFM)",    "write confidence (TIFF)", "write rejections (PNG)", "triangulate",
      "write xyz (EXR)",          "write cloud (PLY)",      "predict xyz_sigma",      "write xyz_sigma (EXR)"};
  EXPECT_EQ(stages, expected);
  const double match_sum = summary["timings_s"]["match_sum"].get<double>();
  EXPECT_LE(match_stages, match_sum);
  EXPECT_GE(match_stages, 0.9 * match_sum);

  // The point cloud holds the same points, in row order, grey from the right image.
  const io::PlyPointCloud cloud = io::ReadPly(out / "cloud" / "a.ply");
  ASSERT_EQ(static_cast<int>(cloud.points.size()), points);
  ASSERT_EQ(cloud.colours.size(), cloud.points.size());
  std::size_t k = 0;
  for (int y = 0; y < 120; ++y) {
    for (int x = 0; x < 160; ++x) {
      const cv::Vec3f p = xyz.pixels.at<cv::Vec3f>(y, x);
      if (!std::isfinite(p[0])) continue;
      ASSERT_EQ(cloud.points[k], cv::Point3f(p[0], p[1], p[2])) << k;
      const std::uint8_t grey = fx.right_a.at<std::uint8_t>(y, x);
      ASSERT_EQ(cloud.colours[k], cv::Vec3b(grey, grey, grey)) << k;
      ++k;
    }
  }
}

TEST(StereoBatchRig, LeftReferenceAndSubsampledMapsTriangulateToTheSameGround) {
  Fixture fx;
  const fs::path out = fx.tmp.path() / "out";
  const auto run = RunTool("stereo-batch",
                           fx.Args(out, {"--disparity", "0:100", "--reference", "left", "--step", "3x2"}),
                           fx.tmp.path());
  ASSERT_EQ(run.exit_code, 0) << run.stderr_text;
  const cv::Mat xyz = io::ReadExr(out / "xyz" / "a.exr").pixels;
  std::vector<double> height_m;
  for (int y = 0; y < 120; ++y) {
    for (int x = 0; x < 160; ++x) {
      const cv::Vec3f p = xyz.at<cv::Vec3f>(y, x);
      if (x % 3 != 0 || y % 2 != 0) {
        EXPECT_TRUE(std::isnan(p[0])) << "off the grid " << x << "," << y;
      } else if (std::isfinite(p[0])) {
        height_m.push_back(std::abs(p[2]));
      }
    }
  }
  ASSERT_GT(height_m.size(), 0.35 * 160 * 120 / 6) << io::ReadJson(out / "summary.json")["pairs"][0].dump();
  EXPECT_LT(Quantile(height_m, 0.5), 0.05);
  EXPECT_LT(Quantile(height_m, 0.9), 0.2);
}

TEST(StereoBatchRig, RangeYRestrictsRowsAndDisparitiesToTheBand) {
  Fixture fx;
  const fs::path full = fx.tmp.path() / "full", band = fx.tmp.path() / "band";
  const auto full_run = RunTool("stereo-batch", fx.Args(full, {"--disparity", "0:100"}), fx.tmp.path());
  ASSERT_EQ(full_run.exit_code, 0) << full_run.stderr_text;
  const auto run = RunTool("stereo-batch", fx.Args(band, {"--range-y", "4.2:7.5", "--z-range", "-0.5:1.0"}),
                           fx.tmp.path());
  ASSERT_EQ(run.exit_code, 0) << run.stderr_text;

  calib::RegionOfInterest region;
  region.y_min_m = 4.2;
  region.y_max_m = 7.5;
  region.z_min_m = -0.5;
  region.z_max_m = 1.0;
  const calib::ImageWindow expected = calib::SelectWindow(fx.rig, region, calib::ReferenceImage::kRight);
  ASSERT_TRUE(expected.visible);
  const nlohmann::json summary = io::ReadJson(band / "summary.json");
  for (const nlohmann::json& pair : summary["pairs"]) {
    EXPECT_EQ(pair["result"]["window"]["rows"], nlohmann::json({expected.min_row, expected.max_row}));
    EXPECT_EQ(pair["result"]["window"]["disparity_px"],
              nlohmann::json({expected.min_disparity_px, expected.max_disparity_px}));
    EXPECT_EQ(pair["result"]["window"]["source"], "range-y");
  }
  // A real restriction of this scene's search (rows 0..119, disparities 0..100).
  EXPECT_LT(expected.Rows(), 120 * 0.75);
  EXPECT_LT(expected.Disparities(), 101 / 2);

  const cv::Mat rejections = cv::imread((band / "rejections" / "a.png").string(), cv::IMREAD_UNCHANGED);
  const cv::Mat d_band = io::ReadPfm(band / "disparity" / "a.pfm");
  const cv::Mat xyz_band = io::ReadExr(band / "xyz" / "a.exr").pixels;
  const cv::Mat xyz_full = io::ReadExr(full / "xyz" / "a.exr").pixels;
  int in_interval = 0, kept = 0;
  for (int y = 0; y < 120; ++y) {
    for (int x = 0; x < 160; ++x) {
      const bool in_band = y >= expected.min_row && y <= expected.max_row;
      if (!in_band) {
        ASSERT_EQ(rejections.at<std::uint8_t>(y, x), 1) << "row " << y << " outside the band was evaluated";
        ASSERT_TRUE(std::isnan(xyz_band.at<cv::Vec3f>(y, x)[0]));
      }
      const float d = d_band.at<float>(y, x);
      if (std::isfinite(d)) {
        EXPECT_GE(d, expected.min_disparity_px);
        EXPECT_LE(d, expected.max_disparity_px);
      }
      // Points of the interval that the full search measured are measured in the band too.
      const cv::Vec3f p = xyz_full.at<cv::Vec3f>(y, x);
      if (std::isfinite(p[1]) && p[1] >= 4.2 && p[1] <= 7.5) {
        ++in_interval;
        kept += std::isfinite(xyz_band.at<cv::Vec3f>(y, x)[1]);
      }
    }
  }
  ASSERT_GT(in_interval, 500);
  EXPECT_GT(kept, 0.95 * in_interval);
}

// With a rig and no --disparity, --rows or --range-y, stereo-batch searches the ground the rig
// sees (calib::SelectGroundWindow), says so in summary.json, and measures the ground as the
// hand-picked range does.
TEST(StereoBatchRig, WithoutARangeTheRigsGroundIsSearched) {
  Fixture fx;
  const fs::path chosen = fx.tmp.path() / "chosen", by_rig = fx.tmp.path() / "by-rig";
  ASSERT_EQ(RunTool("stereo-batch", fx.Args(chosen, {"--disparity", "0:100"}), fx.tmp.path()).exit_code, 0);
  const auto run = RunTool("stereo-batch", fx.Args(by_rig), fx.tmp.path());
  ASSERT_EQ(run.exit_code, 0) << run.stderr_text;
  const calib::GroundWindow expected =
      calib::SelectGroundWindow(fx.rig, calib::ReferenceImage::kRight, calib::GroundWindowOptions{});
  const nlohmann::json summary = io::ReadJson(by_rig / "summary.json");
  const nlohmann::json& from_rig = summary["geometry"]["window_from_rig"];
  EXPECT_EQ(from_rig["window"]["disparity_px"],
            nlohmann::json({expected.window.min_disparity_px, expected.window.max_disparity_px}));
  EXPECT_NEAR(from_rig["region"]["y_m"][0].get<double>(), expected.region.y_min_m, 1e-9);
  EXPECT_FALSE(io::ReadJson(chosen / "summary.json")["geometry"].contains("window_from_rig"));
  for (const nlohmann::json& pair : summary["pairs"]) {
    EXPECT_EQ(pair["result"]["window"]["source"], "rig-ground");
  }
  // With a rig the aperture filter, the occlusion margin and the doubled P2 are on (the map
  // pipeline's defaults), unless told otherwise; without one the preset's.
  EXPECT_EQ(summary["options"]["semi_global"]["aperture"],
            nlohmann::json({{"ratio", 0.4}, {"gradient_levels_per_px", 1.5}}));
  EXPECT_EQ(summary["options"]["semi_global"]["occlusion_margin_px"], 4);
  EXPECT_EQ(summary["options"]["semi_global"]["p2"], 480);
  const fs::path plain = fx.tmp.path() / "plain", off = fx.tmp.path() / "aperture-off";
  ASSERT_EQ(RunTool("stereo-batch", {fx.in.string(), "-o", plain.string(), "-q"}, fx.tmp.path()).exit_code, 0);
  EXPECT_EQ(io::ReadJson(plain / "summary.json")["options"]["semi_global"]["aperture"], "off");
  EXPECT_EQ(io::ReadJson(plain / "summary.json")["options"]["semi_global"]["occlusion_margin_px"], 0);
  EXPECT_EQ(io::ReadJson(plain / "summary.json")["options"]["semi_global"]["p2"], 240);
  ASSERT_EQ(RunTool("stereo-batch", fx.Args(off, {"--aperture", "off", "--p2", "300"}), fx.tmp.path()).exit_code, 0);
  EXPECT_EQ(io::ReadJson(off / "summary.json")["options"]["semi_global"]["aperture"], "off");
  EXPECT_EQ(io::ReadJson(off / "summary.json")["options"]["semi_global"]["p2"], 300);
  // Rows subsampled: the preset's P2 (slanted ground steps more than a pixel between grid rows).
  const fs::path sub = fx.tmp.path() / "rows-subsampled";
  ASSERT_EQ(RunTool("stereo-batch", fx.Args(sub, {"--step", "1x2"}), fx.tmp.path()).exit_code, 0);
  EXPECT_EQ(io::ReadJson(sub / "summary.json")["options"]["semi_global"]["p2"], 240);
  for (const char* bad : {"2:1.5", "0.4", "0.4:0", "0:1.5", "x:y"}) {
    EXPECT_EQ(RunTool("stereo-batch", fx.Args(fx.tmp.path() / "bad", {"--aperture", bad}), fx.tmp.path()).exit_code, 2)
        << bad;
  }
  for (const char* bad : {"-1", "65", "x"}) {
    EXPECT_EQ(RunTool("stereo-batch", fx.Args(fx.tmp.path() / "bad", {"--occlusion-margin", bad}), fx.tmp.path()).exit_code,
              2)
        << bad;
  }
  // The hand-picked range's ground points within the region (Y up to the far limit, where a
  // 1 px error moves a point by a map cell) are measured alike.
  const cv::Mat xyz_rig = io::ReadExr(by_rig / "xyz" / "a.exr").pixels;
  const cv::Mat xyz_chosen = io::ReadExr(chosen / "xyz" / "a.exr").pixels;
  int in_region = 0, both = 0, differ = 0;
  for (int y = 0; y < 120; ++y) {
    for (int x = 0; x < 160; ++x) {
      const cv::Vec3f a = xyz_chosen.at<cv::Vec3f>(y, x), b = xyz_rig.at<cv::Vec3f>(y, x);
      if (!std::isfinite(a[1])) continue;
      if (a[1] < expected.region.y_max_m - 0.5) {
        ++in_region;
        both += std::isfinite(b[1]);
        differ += std::isfinite(b[1]) && std::abs(a[2] - b[2]) > 0.05f;
      }
    }
  }
  ASSERT_GT(in_region, 5000);
  EXPECT_GT(both, 0.98 * in_region);
  EXPECT_LT(differ, 0.01 * in_region);
}

TEST(StereoBatchRig, RequestsGiveEachPairItsOwnBand) {
  Fixture fx;
  const fs::path out = fx.tmp.path() / "out", requests = fx.tmp.path() / "requests.csv";
  std::ofstream(requests) << "stem,y_min_m,y_max_m\n# the planner's intervals\na, 2.0, 3.0\n";
  // b has no request: it falls back to --range-y.
  const auto run = RunTool("stereo-batch", fx.Args(out, {"--requests", requests.string(), "--range-y", "5:9"}),
                           fx.tmp.path());
  ASSERT_EQ(run.exit_code, 0) << run.stderr_text;
  const nlohmann::json summary = io::ReadJson(out / "summary.json");
  ASSERT_EQ(summary["pairs"].size(), 2u);
  for (const auto& [k, y_min, y_max, source] : {std::tuple{0, 2.0, 3.0, "requests"}, std::tuple{1, 5.0, 9.0, "range-y"}}) {
    calib::RegionOfInterest region;
    region.y_min_m = y_min;
    region.y_max_m = y_max;
    const calib::ImageWindow expected = calib::SelectWindow(fx.rig, region, calib::ReferenceImage::kRight);
    const nlohmann::json& window = summary["pairs"][k]["result"]["window"];
    EXPECT_EQ(window["source"], source);
    EXPECT_EQ(window["rows"], nlohmann::json({expected.min_row, expected.max_row})) << source;
    EXPECT_EQ(window["disparity_px"], nlohmann::json({expected.min_disparity_px, expected.max_disparity_px}));
  }
  EXPECT_NE(summary["pairs"][0]["result"]["window"]["rows"], summary["pairs"][1]["result"]["window"]["rows"]);
  EXPECT_EQ(summary["pairs"][0]["result"]["window"]["request_line"], 3);
}

// A requested interval on flat ground: the window's rows, which hold the heights -0.5 to 1 m
// over 3-4 m, see in their top rows the ground beyond 4 m and in their bottom rows the ground
// nearer than 3 m. The quality preset searches each row's band with a far and a near guard:
// every point it accepts is its pixel's ground within the interval (as far as each row's band
// holds it), and the rest is rejected as beyond_far or beyond_near. The paper's matcher
// searches the window's one range, as the paper does: some of the far ground matches falsely
// inside it, points in the air (what the guards are for; that it happens here shows the scene
// tests them).
TEST(StereoBatchRig, EveryPointOfARequestedWindowLiesInsideItsIntervalWithTheGuards) {
  Fixture fx;
  const fs::path requests = fx.tmp.path() / "requests.csv";
  std::ofstream(requests) << "stem,y_min_m,y_max_m\na,3.0,4.0\nb,3.0,4.0\n";
  // The pixels whose ground lies in the interval.
  long inside = 0;
  for (int y = 0; y < 120; ++y) {
    for (int x = 0; x < 160; ++x) {
      const Eigen::Vector3d p = GroundPoint(fx.rig, x, y);
      inside += p.y() >= 3.0 && p.y() <= 4.0;
    }
  }
  ASSERT_GT(inside, 1000);
  for (const char* preset : {"quality", "paper"}) {
    const fs::path out = fx.tmp.path() / (std::string("out-") + preset);
    const auto run = RunTool("stereo-batch", fx.Args(out, {"--preset", preset, "--requests", requests.string()}),
                             fx.tmp.path());
    ASSERT_EQ(run.exit_code, 0) << preset << ": " << run.stderr_text;
    const cv::Mat xyz = io::ReadExr(out / "xyz" / "a.exr").pixels;
    long accepted = 0, outside = 0;
    for (int y = 0; y < xyz.rows; ++y) {
      for (int x = 0; x < xyz.cols; ++x) {
        const cv::Vec3f p = xyz.at<cv::Vec3f>(y, x);
        if (!std::isfinite(p[0])) continue;
        ++accepted;
        // Not this pixel's ground (a false match: in the air, or far ground matched inside the
        // band), or beyond what the row's band holds: each row searches the disparities of all its
        // pixels' stretches of the interval, and the rig's roll moves them along the row (a
        // correct point 0.26 m beyond 4 m was measured).
        const Eigen::Vector3d truth = GroundPoint(fx.rig, x, y);
        outside += (Eigen::Vector3d(p[0], p[1], p[2]) - truth).norm() > 0.15 || p[1] < 2.5 || p[1] > 4.5;
      }
    }
    EXPECT_GT(accepted, inside / 2) << preset;
    const nlohmann::json rejected = io::ReadJson(out / "disparity" / "a.json")["result"]["pixels_rejected"];
    if (std::string(preset) == "quality") {
      EXPECT_EQ(outside, 0) << accepted << " points";
      EXPECT_GT(rejected.value("beyond_far", 0), 0) << rejected.dump();
      EXPECT_GT(rejected.value("beyond_near", 0), 0) << rejected.dump();
    } else {
      EXPECT_GT(outside, 0) << "the paper's matcher, without guards, kept no point in the air: the scene does not test them";
    }
  }
}

TEST(StereoBatchRig, ShardsAndResumeWriteTheSameGeometryAsOneRun) {
  Fixture fx;
  const fs::path single = fx.tmp.path() / "single", sharded = fx.tmp.path() / "sharded";
  const std::vector<std::string> geometry = {"--range-y", "3:9", "--ply", "--xyz-sigma"};
  ASSERT_EQ(RunTool("stereo-batch", fx.Args(single, geometry), fx.tmp.path()).exit_code, 0);
  for (const char* shard : {"0/2", "1/2"}) {
    std::vector<std::string> extra = geometry;
    extra.insert(extra.end(), {"--shard", shard});
    ASSERT_EQ(RunTool("stereo-batch", fx.Args(sharded, extra), fx.tmp.path()).exit_code, 0);
  }
  for (const char* stem : {"a", "b"}) {
    for (const char* dir : {"xyz", "xyz_sigma"}) {
      const cv::Mat a = io::ReadExr(single / dir / (std::string(stem) + ".exr")).pixels;
      const cv::Mat b = io::ReadExr(sharded / dir / (std::string(stem) + ".exr")).pixels;
      ASSERT_EQ(a.size(), b.size());
      // Bit for bit, NaN included.
      EXPECT_EQ(0, std::memcmp(a.data, b.data, a.total() * a.elemSize())) << dir << "/" << stem;
    }
    const io::PlyPointCloud a = io::ReadPly(single / "cloud" / (std::string(stem) + ".ply"));
    const io::PlyPointCloud b = io::ReadPly(sharded / "cloud" / (std::string(stem) + ".ply"));
    EXPECT_EQ(a.points, b.points) << stem;
    EXPECT_EQ(a.colours, b.colours) << stem;
  }
  EXPECT_EQ(io::ReadJson(sharded / "summary.shard-1-of-2.json")["pairs"][0]["result"]["window"]["source"], "range-y");

  // Resume over the shards' directory: a pair whose cloud is missing is redone, the other is
  // reused, and the combined summary has both.
  fs::remove(sharded / "cloud" / "b.ply");
  std::vector<std::string> resume = geometry;
  resume.push_back("--resume");
  ASSERT_EQ(RunTool("stereo-batch", fx.Args(sharded, resume), fx.tmp.path()).exit_code, 0);
  nlohmann::json summary = io::ReadJson(sharded / "summary.json");
  EXPECT_EQ(summary["counts"]["pairs_resumed"], 1);
  EXPECT_EQ(summary["pairs"][1]["status"], "ok");
  EXPECT_EQ(summary["pairs"][0]["result"]["window"], summary["pairs"][1]["result"]["window"]);
  EXPECT_TRUE(fs::exists(sharded / "cloud" / "b.ply"));
  // Another sigma_d changes the geometry options: nothing is reused.
  resume[3] = "--xyz-sigma=2";
  ASSERT_EQ(RunTool("stereo-batch", fx.Args(sharded, resume), fx.tmp.path()).exit_code, 0);
  summary = io::ReadJson(sharded / "summary.json");
  EXPECT_EQ(summary["counts"]["pairs_resumed"], 0);
  EXPECT_EQ(io::ReadExr(sharded / "xyz_sigma" / "a.exr").attributes.at("lunarnav:sigma_d_px").substr(0, 3), "2.0");
}

// A vehicle pitched 15 deg nose up (climbing over a rock) sees the level ground where a level
// vehicle's search does not look for it (below its heights). Rendered with the rig as the pitch
// places it (mast turned about its base; the top rows see the plane's continuation above the
// horizon, at negative disparities that no search holds), matched with the rig as it is: with
// --poses the pair searches the level ground and measures it; without, little of it.
TEST(StereoBatchRig, WithThePosesAPitchedVehicleSearchesTheLevelGround) {
  ScopedTempDir tmp;
  const calib::StereoRig rig = TestRig();
  constexpr double kPitchDeg = 15.0;
  const double p = kPitchDeg * M_PI / 180;
  calib::StereoRig pitched = rig;  // its vehicle frame is the level frame of the pitched vehicle
  pitched.mast.tilt_deg = rig.mast.tilt_deg - kPitchDeg;
  pitched.mast.height_m = rig.mast.height_m * std::cos(p);
  pitched.mast.forward_offset_m = -rig.mast.height_m * std::sin(p);
  const fs::path in = tmp.path() / "pairs", rig_file = tmp.path() / "rig.json", poses = tmp.path() / "poses.csv";
  RenderGroundPair(pitched, in, "a", 3);
  calib::WriteStereoRig(rig_file, rig);
  std::ofstream(poses) << "stem,t_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg\na,0,0,0,0,0," << kPitchDeg << ",0\n";
  auto args = [&](const fs::path& out, std::vector<std::string> extra) {
    std::vector<std::string> a = {in.string(), "-o", out.string(), "-q", "--rig", rig_file.string()};
    a.insert(a.end(), extra.begin(), extra.end());
    return a;
  };
  const fs::path level = tmp.path() / "level", with_poses = tmp.path() / "poses";
  ASSERT_EQ(RunTool("stereo-batch", args(level, {}), tmp.path()).exit_code, 0);
  const auto run = RunTool("stereo-batch", args(with_poses, {"--poses", poses.string()}), tmp.path());
  ASSERT_EQ(run.exit_code, 0) << run.stderr_text;
  const nlohmann::json sidecar = io::ReadJson(with_poses / "disparity" / "a.json");
  EXPECT_NEAR(sidecar["result"]["window"]["vehicle_attitude_deg"]["pitch"].get<double>(), kPitchDeg, 1e-9);
  EXPECT_EQ(io::ReadJson(with_poses / "summary.json")["options"]["window_selection"]["attitudes"], poses.string());
  // Points on the level ground (Z = 0 of the pitched vehicle's level frame), within 5 cm.
  const Eigen::Matrix3d level_from_vehicle = Eigen::AngleAxisd(p, Eigen::Vector3d::UnitX()).toRotationMatrix();
  auto count = [&](const fs::path& out, int* on_ground, int* off_ground) {
    const cv::Mat xyz = io::ReadExr(out / "xyz" / "a.exr").pixels;
    *on_ground = *off_ground = 0;
    for (int y = 0; y < xyz.rows; ++y) {
      for (int x = 0; x < xyz.cols; ++x) {
        const cv::Vec3f v = xyz.at<cv::Vec3f>(y, x);
        if (!std::isfinite(v[2])) continue;
        const double z = (level_from_vehicle * Eigen::Vector3d(v[0], v[1], v[2])).z();
        ++(std::abs(z) < 0.05 ? *on_ground : *off_ground);
      }
    }
  };
  int ground_poses = 0, off_poses = 0, ground_level = 0, off_level = 0;
  count(with_poses, &ground_poses, &off_poses);
  count(level, &ground_level, &off_level);
  EXPECT_GT(ground_poses, 0.2 * 160 * 120);  // the ground up to the far limit (the top rows see the sky)
  EXPECT_LT(off_poses, 0.01 * ground_poses);
  EXPECT_LT(ground_level, 0.1 * ground_poses);  // the level search: none (and 338 points off it)
  // --range-y with the poses: the interval's ground at the pair's attitude (was the level one's:
  // the poses silently ignored).
  const fs::path range_level = tmp.path() / "range-level", range_poses = tmp.path() / "range-poses";
  ASSERT_EQ(RunTool("stereo-batch", args(range_level, {"--range-y", "3:6"}), tmp.path()).exit_code, 0);
  const auto ranged =
      RunTool("stereo-batch", args(range_poses, {"--range-y", "3:6", "--poses", poses.string()}), tmp.path());
  ASSERT_EQ(ranged.exit_code, 0) << ranged.stderr_text;
  const nlohmann::json ranged_sidecar = io::ReadJson(range_poses / "disparity" / "a.json");
  EXPECT_EQ(ranged_sidecar["result"]["window"]["source"], "range-y");
  EXPECT_NEAR(ranged_sidecar["result"]["window"]["vehicle_attitude_deg"]["pitch"].get<double>(), kPitchDeg, 1e-9);
  // The window is the interval's at the pair's attitude (its rows and disparities those of
  // the ground 3-6 m ahead of the pitched vehicle), and finds twice the level window's ground.
  EXPECT_NE(ranged_sidecar["result"]["window"]["rows"],
            io::ReadJson(range_level / "disparity" / "a.json")["result"]["window"]["rows"]);
  int ground_range = 0, off_range = 0, ground_range_level = 0, off_range_level = 0;
  count(range_poses, &ground_range, &off_range);
  count(range_level, &ground_range_level, &off_range_level);
  EXPECT_GT(ground_range, 1.5 * ground_range_level);  // 5059 points of the ground against 2496
  // Every pair needs a pose: bad input naming the stem.
  std::ofstream(poses, std::ios::trunc) << "stem,t_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg\nb,0,0,0,0,0,0,0\n";
  const auto missing = RunTool("stereo-batch", args(tmp.path() / "missing", {"--poses", poses.string()}), tmp.path());
  EXPECT_EQ(missing.exit_code, 3);
  EXPECT_EQ(missing.ErrorLines(), 1);
  EXPECT_NE(missing.stderr_text.find("stem a: no pose"), std::string::npos) << missing.stderr_text;
  EXPECT_EQ(RunTool("stereo-batch", {in.string(), "-o", (tmp.path() / "x").string(), "--poses", poses.string()},
                    tmp.path()).exit_code, 2);  // needs the rig
  std::ofstream(poses, std::ios::trunc) << "stem,t_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg\na,0,0,0,0,0,95,0\n";
  const auto upside = RunTool("stereo-batch", args(tmp.path() / "upside", {"--poses", poses.string()}), tmp.path());
  EXPECT_EQ(upside.exit_code, 3);
  EXPECT_EQ(upside.ErrorLines(), 1);
  EXPECT_NE(upside.stderr_text.find("stem a: pitch 95"), std::string::npos) << upside.stderr_text;
}

TEST(StereoBatchRig, BadRigsAndRequestsHaveTheirExitCodes) {
  Fixture fx;
  const fs::path out = fx.tmp.path() / "out";
  // A rig without rectification, and geometry options without a rig: usage errors.
  calib::StereoRig raw = fx.rig;
  raw.rectified.reset();
  const fs::path raw_file = fx.tmp.path() / "raw.json";
  calib::WriteStereoRig(raw_file, raw);
  const auto unrectified = RunTool("stereo-batch", {fx.in.string(), "-o", out.string(), "--rig", raw_file.string()},
                                   fx.tmp.path());
  EXPECT_EQ(unrectified.exit_code, 2);
  EXPECT_EQ(unrectified.ErrorLines(), 1);
  EXPECT_NE(unrectified.stderr_text.find("rectified"), std::string::npos) << unrectified.stderr_text;
  EXPECT_EQ(RunTool("stereo-batch", {fx.in.string(), "-o", out.string(), "--ply"}, fx.tmp.path()).exit_code, 2);
  EXPECT_EQ(RunTool("stereo-batch", fx.Args(out, {"--range-y", "4:5", "--rows", "0:50"}), fx.tmp.path()).exit_code, 2);
  EXPECT_EQ(RunTool("stereo-batch", fx.Args(out, {"--range-y", "100:200"}), fx.tmp.path()).exit_code, 2);
  EXPECT_EQ(RunTool("stereo-batch", fx.Args(out, {"--xyz-sigma", "0"}), fx.tmp.path()).exit_code, 2);
  // A damaged rig file: bad input.
  std::ofstream(fx.tmp.path() / "broken.json") << "{\"format\": \"lunarnav.rig/1\"";
  EXPECT_EQ(RunTool("stereo-batch", {fx.in.string(), "-o", out.string(), "--rig", (fx.tmp.path() / "broken.json").string()},
                    fx.tmp.path()).exit_code, 3);

  // Bad requests files: bad input, one error line naming the file and line (the reader's
  // other cases: tests/stereo/window_requests_test.cc).
  struct Case {
    std::string text, expected;
  };
  const std::vector<Case> cases = {
      {"stem,y_min_m,y_max_m\na,4,five\n", "requests.csv:2:"},               // not a number
      {"stem,y_min_m,y_max_m\na,4,5\n\nb,100,200\n", "requests.csv:4:"}};    // not seen by the camera
  const fs::path requests = fx.tmp.path() / "requests.csv";
  for (const Case& c : cases) {
    std::ofstream(requests, std::ios::trunc) << c.text;
    const auto run = RunTool("stereo-batch", fx.Args(out, {"--requests", requests.string()}), fx.tmp.path());
    EXPECT_EQ(run.exit_code, 3) << c.text;
    EXPECT_EQ(run.ErrorLines(), 1) << run.stderr_text;
    EXPECT_NE(run.stderr_text.find(c.expected), std::string::npos) << run.stderr_text;
  }
  EXPECT_EQ(RunTool("stereo-batch", fx.Args(out, {"--requests", (fx.tmp.path() / "none.csv").string()}), fx.tmp.path())
                .exit_code, 3);

  // A rig for other images is refused before the work its declared size sets (exit 3), naming
  // the rig, its size and the image's.
  const calib::StereoRig big = calib::testing::IdealRectifiedRig(320, 240, 370);
  const fs::path big_file = fx.tmp.path() / "big.json";
  calib::WriteStereoRig(big_file, big);
  const auto mismatch = RunTool("stereo-batch", {fx.in.string(), "-o", out.string(), "--rig", big_file.string()},
                                fx.tmp.path());
  EXPECT_EQ(mismatch.exit_code, 3);
  EXPECT_EQ(mismatch.ErrorLines(), 1);
  EXPECT_NE(mismatch.stderr_text.find("big.json: declares rectified images of 320x240"), std::string::npos)
      << mismatch.stderr_text;
  EXPECT_NE(mismatch.stderr_text.find("is 160x120"), std::string::npos) << mismatch.stderr_text;
}

}  // namespace
}  // namespace lunarnav
