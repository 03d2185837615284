#include "sim/stereo_sim.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/rectify.h"
#include "calib/stereo_rig_io.h"
#include "io/image_io.h"
#include "io/json_io.h"
#include "io/float_array_io.h"
#include "util/errors.h"
#include "util/testing.h"

namespace lunarnav::sim {
namespace {
namespace fs = std::filesystem;

// The paper's rig at a quarter (or half) of its resolution, on a coarser terrain grid.
StereoSimOptions SmallRun(int scale_down = 4) {
  StereoSimOptions o;
  o.width_px = 640 / scale_down;
  o.height_px = 480 / scale_down;
  o.focal_px = 740.0 / scale_down;
  o.terrain_cell_m = 0.04;
  o.show_progress = false;
  o.num_threads = 2;
  return o;
}

std::string ReadBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(RunStereoSimulation, StoredDisparityIsTheProjectionOfStoredXyzIntoBothCameras) {
  util::ScopedTempDir dir;
  StereoSimOptions o = SmallRun();
  o.frames = 2;
  o.turn_radius_m = 10;
  o.interval_s = 10;  // 1.5 m between the frames
  RunStereoSimulation(o, dir.path());
  const calib::StereoRig rig = calib::ReadStereoRig(dir.path() / "rig.json");
  ASSERT_TRUE(rig.rectified.has_value());
  EXPECT_FALSE(rig.left.distortion.empty());
  const calib::RectifiedGeometry& g = *rig.rectified;
  const Eigen::Isometry3d left_from_vehicle = rig.VehicleFromLeft().inverse();
  const Eigen::Isometry3d right_from_vehicle = rig.VehicleFromRight().inverse();
  for (const std::string stem : {"000000", "000001"}) {
    const cv::Mat d = io::ReadPfm(dir.path() / "truth" / "disparity" / (stem + ".pfm"));
    const cv::Mat xyz = io::ReadExr(dir.path() / "truth" / "xyz" / (stem + ".exr")).pixels;
    ASSERT_EQ(d.size(), cv::Size(g.width_px, g.height_px));
    ASSERT_EQ(xyz.size(), d.size());
    ASSERT_EQ(xyz.type(), CV_32FC3);
    int checked = 0, invalid = 0;
    for (int y = 0; y < d.rows; ++y) {
      for (int x = 0; x < d.cols; ++x) {
        const float disparity = d.at<float>(y, x);
        if (std::isinf(disparity)) {  // the PFM convention for "no disparity"
          ++invalid;
          continue;
        }
        ASSERT_TRUE(std::isfinite(disparity));
        const cv::Vec3f p = xyz.at<cv::Vec3f>(y, x);
        const Eigen::Vector3d pv(p[0], p[1], p[2]);
        const Eigen::Vector3d r = g.rect_from_right * (right_from_vehicle * pv);
        const Eigen::Vector3d l = g.rect_from_left * (left_from_vehicle * pv);
        const double xr = g.P_right(0, 0) * r.x() / r.z() + g.P_right(0, 2);
        const double yr = g.P_right(1, 1) * r.y() / r.z() + g.P_right(1, 2);
        const double xl = g.P_left(0, 0) * l.x() / l.z() + g.P_left(0, 2);
        const double yl = g.P_left(1, 1) * l.y() / l.z() + g.P_left(1, 2);
        ASSERT_NEAR(xr, x, 2e-3) << stem << " at " << x << "," << y;
        ASSERT_NEAR(yr, y, 2e-3);
        ASSERT_NEAR(yl, y, 2e-3);
        ASSERT_NEAR(xl - xr, disparity, 2e-3) << stem << " at " << x << "," << y;
        ++checked;
      }
    }
    EXPECT_GT(checked, d.rows * d.cols / 2) << stem;
    EXPECT_GT(invalid, 0) << stem;  // the right edge sees ground the left camera does not
  }
}

// SGBM matches left-referenced; flipping both images and swapping them gives the
// right-referenced map: x_l = x_r + d.
cv::Mat SgbmRightReferenced(const cv::Mat& left, const cv::Mat& right, int num_disparities) {
  cv::Mat lf, rf;
  cv::flip(right, rf, 1);
  cv::flip(left, lf, 1);
  const auto sgbm = cv::StereoSGBM::create(0, num_disparities, 5, 8 * 25, 32 * 25, 1, 0, 10, 0, 0,
                                           cv::StereoSGBM::MODE_HH);
  cv::Mat raw;
  sgbm->compute(rf, lf, raw);
  cv::Mat flipped, out;
  cv::flip(raw, flipped, 1);
  flipped.convertTo(out, CV_32F, 1.0 / 16);
  return out;
}

TEST(RunStereoSimulation, OpenCvSgbmOnARectifiedPairAgreesWithTheTruth) {
  // An independent check that images and truth agree: a matcher that knows nothing of the
  // simulator finds the truth disparity (within 1 px) at most textured pixels.
  util::ScopedTempDir dir;
  StereoSimOptions o = SmallRun(2);  // 320 x 240, f = 370 px: disparities up to ~150 px
  o.rectified = true;
  RunStereoSimulation(o, dir.path());
  const cv::Mat left = io::ReadGreyImage(dir.path() / "left" / "000000.png");
  const cv::Mat right = io::ReadGreyImage(dir.path() / "right" / "000000.png");
  const cv::Mat truth = io::ReadPfm(dir.path() / "truth" / "disparity" / "000000.pfm");
  // 320 x 240 with f = 370 px: the nearest ground (bottom row) has a disparity of ~160 px.
  const int num_disparities = 176;
  const cv::Mat sgbm = SgbmRightReferenced(left, right, num_disparities);
  // Textured: local standard deviation of the right image over 5 x 5 above 4 grey levels.
  cv::Mat mean, sq_mean, f;
  right.convertTo(f, CV_32F);
  cv::blur(f, mean, cv::Size(5, 5));
  cv::blur(f.mul(f), sq_mean, cv::Size(5, 5));
  int textured = 0, matched = 0, good = 0;
  // SGBM searches [0, num_disparities) only where the whole range lies inside the image:
  // right-image columns x < W - num_disparities.
  for (int y = 8; y < truth.rows - 8; ++y) {
    for (int x = 8; x < truth.cols - num_disparities - 4; ++x) {
      const float t = truth.at<float>(y, x);
      if (!std::isfinite(t) || t > num_disparities - 8) continue;
      if (std::sqrt(std::max(0.f, sq_mean.at<float>(y, x) - mean.at<float>(y, x) * mean.at<float>(y, x))) < 4)
        continue;
      ++textured;
      const float d = sgbm.at<float>(y, x);
      if (d < 0) continue;  // SGBM rejected the pixel
      ++matched;
      good += std::abs(d - t) < 1.0f;
    }
  }
  ASSERT_GT(textured, truth.rows * (truth.cols - num_disparities) / 2);
  EXPECT_GT(static_cast<double>(matched) / textured, 0.9) << matched << " of " << textured;
  EXPECT_GT(static_cast<double>(good) / matched, 0.95) << good << " of " << matched;
}

TEST(RunStereoSimulation, RectifyingTheRawPairGivesTheRenderedRectifiedPair) {
  // Raw mode (distortion, rotation) rectified with the written rig is the ideal rectified
  // pair: the truth of both modes is one geometry.
  util::ScopedTempDir raw_dir, rect_dir;
  StereoSimOptions o = SmallRun(2);
  o.noise_sigma = 0;
  o.exposure_difference = false;
  RunStereoSimulation(o, raw_dir.path());
  o.rectified = true;
  RunStereoSimulation(o, rect_dir.path());
  const calib::StereoRig rig = calib::ReadStereoRig(raw_dir.path() / "rig.json");
  const calib::Rectifier rectifier(rig);
  cv::Mat left, right;
  rectifier.Rectify(io::ReadGreyImage(raw_dir.path() / "left" / "000000.png"),
                    io::ReadGreyImage(raw_dir.path() / "right" / "000000.png"), &left, &right);
  for (const auto& [mine, ideal_name] : {std::pair{left, "left"}, std::pair{right, "right"}}) {
    const cv::Mat ideal = io::ReadGreyImage(rect_dir.path() / ideal_name / "000000.png");
    const cv::Rect inner(10, 10, ideal.cols - 20, ideal.rows - 20);
    cv::Mat diff;
    cv::absdiff(mine(inner), ideal(inner), diff);
    // Bilinear resampling blurs a little; a misplaced image would differ by the texture's
    // contrast (tens of grey levels).
    EXPECT_LT(cv::mean(diff)[0], 4.0) << ideal_name;
    cv::Mat shifted;
    cv::absdiff(mine(inner), ideal(inner + cv::Point(1, 0)), shifted);
    EXPECT_GT(cv::mean(shifted)[0], 1.5 * cv::mean(diff)[0]) << ideal_name;
  }
}

TEST(RunStereoSimulation, SameSeedGivesTheSameBytesWhateverTheThreads) {
  util::ScopedTempDir a, b, c;
  StereoSimOptions o = SmallRun();
  o.frames = 2;
  o.num_threads = 1;
  RunStereoSimulation(o, a.path());
  o.num_threads = 2;
  RunStereoSimulation(o, b.path());
  int files = 0;
  for (const auto& entry : fs::recursive_directory_iterator(a.path())) {
    if (!entry.is_regular_file() || entry.path().filename() == "summary.json") continue;
    const fs::path rel = fs::relative(entry.path(), a.path());
    ASSERT_TRUE(fs::exists(b.path() / rel)) << rel;
    EXPECT_TRUE(ReadBytes(entry.path()) == ReadBytes(b.path() / rel)) << rel;
    ++files;
  }
  EXPECT_EQ(files, 5 + 2 * 5);  // rig, poses, boxes, terrain DEM, rocks; per frame 2 images and 3 truth maps
  o.seed = 2;
  RunStereoSimulation(o, c.path());
  EXPECT_TRUE(ReadBytes(a.path() / "left" / "000000.png") != ReadBytes(c.path() / "left" / "000000.png"));
}

TEST(RunStereoSimulation, BoxesJsonFacesAreWhereTheTruthXyzSaysTheyAre) {
  util::ScopedTempDir dir;
  StereoSimOptions o = SmallRun(2);
  o.preset = "boxes";
  o.rectified = true;
  RunStereoSimulation(o, dir.path());
  const nlohmann::json boxes = io::ReadJson(dir.path() / "truth" / "boxes.json");
  const cv::Mat xyz = io::ReadExr(dir.path() / "truth" / "xyz" / "000000.exr").pixels;
  const cv::Mat labels = cv::imread((dir.path() / "truth" / "labels" / "000000.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(labels.type(), CV_16UC1);
  ASSERT_EQ(boxes["boxes"].size(), 7u);
  for (int k = 0; k < 7; ++k) {
    const nlohmann::json& b = boxes["boxes"][k];
    const double front = b["front_y_m"];
    EXPECT_NEAR(front, 2.0 + k, 1e-9);  // the experiment of sec. 3.4
    int on_front = 0;
    for (int y = 0; y < labels.rows; ++y) {
      for (int x = 0; x < labels.cols; ++x) {
        if (labels.at<std::uint16_t>(y, x) != SurfaceHit::kFirstBox + k) continue;
        const cv::Vec3f p = xyz.at<cv::Vec3f>(y, x);
        ASSERT_GE(p[1], front - 1e-4) << "box " << k << " seen in front of its front face";
        ASSERT_GE(p[0], b["x_min_m"].get<double>() - 1e-4);
        ASSERT_LE(p[0], b["x_max_m"].get<double>() + 1e-4);
        ASSERT_GE(p[2], b["z_min_m"].get<double>() - 1e-4);
        ASSERT_LE(p[2], b["z_max_m"].get<double>() + 1e-4);
        on_front += p[1] < front + 1e-4;
      }
    }
    // A 0.5 m face at 8 m and f = 370 px spans ~23 px: hundreds of pixels.
    EXPECT_GT(on_front, 200) << "box " << k;
  }
}

TEST(RunStereoSimulation, FaultsAppearExactlyWhereRequested) {
  util::ScopedTempDir dir;
  StereoSimOptions o = SmallRun();
  o.frames = 4;
  o.faults = {ParseFrameFaultSpec("1:blank"), ParseFrameFaultSpec("2:saturated"), ParseFrameFaultSpec("3:truncated")};
  RunStereoSimulation(o, dir.path());
  auto image = [&](const char* side, int k) { return io::ReadGreyImage(dir.path() / side / (FrameStem(k) + ".png")); };
  for (const char* side : {"left", "right"}) {
    EXPECT_GT(cv::mean(image(side, 0))[0], 60);
    EXPECT_LT(cv::mean(image(side, 0))[0], 200);
    EXPECT_EQ(cv::countNonZero(image(side, 1)), 0);
    cv::Mat saturated;
    cv::compare(image(side, 2), 255, saturated, cv::CMP_EQ);
    EXPECT_GT(cv::countNonZero(saturated), saturated.total() / 2);
  }
  EXPECT_THROW(image("left", 3), InputError);
  EXPECT_GT(cv::mean(image("right", 3))[0], 60);
  const std::string poses = ReadBytes(dir.path() / "truth" / "poses.csv");
  EXPECT_NE(poses.find("000000,0.000,"), std::string::npos);
  EXPECT_NE(poses.find(",blank\n"), std::string::npos);
  EXPECT_NE(poses.find("000002,6.400,0.000000,0.960000,"), std::string::npos);  // 0.15 m/s x 3.2 s x 2
  EXPECT_NE(poses.find(",saturated\n000003"), std::string::npos);
  EXPECT_THROW(ParseFrameFaultSpec("2:smoke"), std::invalid_argument);
  o.faults = {ParseFrameFaultSpec("4:blank")};
  EXPECT_THROW(RunStereoSimulation(o, dir.path()), std::invalid_argument);
}

}  // namespace
}  // namespace lunarnav::sim
