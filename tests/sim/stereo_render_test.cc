#include "sim/stereo_render.h"

#include <gtest/gtest.h>

#include <cmath>

#include <opencv2/calib3d.hpp>

#include "calib/rectify.h"
#include "calib/triangulation.h"

namespace lunarnav::sim {
namespace {

// The paper's rig (sec. 3.1) at a quarter of the resolution: 160 x 120, f = 185 px, with
// lens distortion and a small rotation between the cameras.
calib::StereoRig SmallRawRig() {
  calib::StereoRig rig;
  rig.width_px = 160;
  rig.height_px = 120;
  for (calib::CameraIntrinsics* c : {&rig.left, &rig.right}) {
    c->K << 185, 0, 79.5, 0, 185, 59.5, 0, 0, 1;
    c->distortion = {-0.1, 0.03, 0.0003, -0.0002, 0.0};
  }
  rig.right_from_left_R = Eigen::AngleAxisd(0.003, Eigen::Vector3d(0.2, 1, 0.1).normalized()).toRotationMatrix();
  rig.right_from_left_t_m = Eigen::Vector3d(-0.9, 0.002, 0.001);
  return calib::RectifyRig(rig);
}

SceneOptions SmallScene() {
  SceneOptions o;
  o.terrain.min_x_m = -12;
  o.terrain.max_x_m = 12;
  o.terrain.min_y_m = -2;
  o.terrain.max_y_m = 22;
  o.terrain.cell_m = 0.04;
  o.terrain.seed = 5;
  Box box;
  box.min_m = Eigen::Vector3d(-0.3, 4.0, -0.5);
  box.max_m = Eigen::Vector3d(0.3, 4.5, 0.6);
  o.boxes = {box};
  return o;
}

TEST(StereoRenderer, TruthDisparityIsTheProjectionOfTruthXyzIntoBothCameras) {
  const calib::StereoRig rig = SmallRawRig();
  const Scene scene(SmallScene());
  VehiclePose pose;
  pose.heading_rad = 0.05;
  pose.pitch_rad = 0.02;
  pose.z_m = scene.terrain().HeightAt(0, 0);
  StereoRenderOptions options;
  const StereoFrame frame = RenderStereoFrame(scene, rig, pose, options);
  const calib::RectifiedGeometry& g = *rig.rectified;
  const Eigen::Isometry3d left_from_vehicle = rig.VehicleFromLeft().inverse();
  const Eigen::Isometry3d right_from_vehicle = rig.VehicleFromRight().inverse();
  int checked = 0, box_pixels = 0;
  for (int y = 0; y < g.height_px; ++y) {
    for (int x = 0; x < g.width_px; ++x) {
      const float d = frame.truth_disparity_px.at<float>(y, x);
      const cv::Vec3f p = frame.truth_xyz_m.at<cv::Vec3f>(y, x);
      if (frame.truth_label.at<std::uint16_t>(y, x) == SurfaceHit::kSky) {
        EXPECT_TRUE(std::isnan(d) && std::isnan(p[0]));
        continue;
      }
      ASSERT_TRUE(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]));
      if (!std::isfinite(d)) continue;
      const Eigen::Vector3d pv(p[0], p[1], p[2]);
      const Eigen::Vector3d r = g.rect_from_right * (right_from_vehicle * pv);
      const Eigen::Vector3d l = g.rect_from_left * (left_from_vehicle * pv);
      const double xr = g.P_right(0, 0) * r.x() / r.z() + g.P_right(0, 2);
      const double yr = g.P_right(1, 1) * r.y() / r.z() + g.P_right(1, 2);
      const double xl = g.P_left(0, 0) * l.x() / l.z() + g.P_left(0, 2);
      const double yl = g.P_left(1, 1) * l.y() / l.z() + g.P_left(1, 2);
      ASSERT_NEAR(xr, x, 1e-3);
      ASSERT_NEAR(yr, y, 1e-3);
      ASSERT_NEAR(yl, y, 1e-3);
      ASSERT_NEAR(xl - xr, d, 1e-3);
      ++checked;
      if (frame.truth_label.at<std::uint16_t>(y, x) == SurfaceHit::kFirstBox) ++box_pixels;
    }
  }
  EXPECT_GT(checked, g.width_px * g.height_px / 2);
  EXPECT_GT(box_pixels, 20);
  EXPECT_EQ(frame.stats.disparity, checked);
  // Triangulating the truth disparity with the calib module gives the truth XYZ back.
  const cv::Mat xyz = calib::TriangulateDisparity(rig, frame.truth_disparity_px, calib::ReferenceImage::kRight);
  double worst = 0;
  for (int y = 0; y < g.height_px; ++y) {
    for (int x = 0; x < g.width_px; ++x) {
      if (!std::isfinite(frame.truth_disparity_px.at<float>(y, x))) continue;
      worst = std::max(worst, cv::norm(xyz.at<cv::Vec3f>(y, x) - frame.truth_xyz_m.at<cv::Vec3f>(y, x)));
    }
  }
  EXPECT_LT(worst, 2e-3);
}

}  // namespace
}  // namespace lunarnav::sim
