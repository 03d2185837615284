#include "calib/rectify.h"

#include <gtest/gtest.h>

#include <random>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "calib/paper_rig.h"
#include "util/errors.h"

namespace lunarnav::calib {
namespace {

TEST(RectifyRig, PutsCorrespondingPointsOnTheSameRowAndKeepsDepth) {
  // The paper-like rig has distortion and a small rotation between the cameras.
  const StereoRig raw_rig = testing::PaperRig();
  const StereoRig rig = RectifyRig(raw_rig);
  const Rectifier rectifier(rig);
  cv::Mat k1, k2, r;
  cv::eigen2cv(rig.left.K, k1);
  cv::eigen2cv(rig.right.K, k2);
  cv::eigen2cv(rig.right_from_left_R, r);
  cv::Mat rvec;
  cv::Rodrigues(r, rvec);
  const cv::Mat tvec = (cv::Mat_<double>(3, 1) << rig.right_from_left_t_m.x(), rig.right_from_left_t_m.y(),
                        rig.right_from_left_t_m.z());
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> ux(-3, 3), uy(-1, 2), uz(3, 20);
  std::vector<cv::Point3d> points;
  for (int i = 0; i < 200; ++i) points.emplace_back(ux(rng), uy(rng), uz(rng));
  std::vector<cv::Point2d> raw_left, raw_right;
  cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), k1, cv::Mat(rig.left.distortion), raw_left);
  cv::projectPoints(points, rvec, tvec, k2, cv::Mat(rig.right.distortion), raw_right);
  const std::vector<cv::Point2d> left = rectifier.RectifyPoints(raw_left, true);
  const std::vector<cv::Point2d> right = rectifier.RectifyPoints(raw_right, false);
  const RectifiedGeometry& g = *rig.rectified;
  const double f = g.P_left(0, 0), baseline = -g.P_right(0, 3) / f;
  EXPECT_NEAR(baseline, raw_rig.BaselineM(), 1e-9);
  int in_view = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (raw_left[i].x < 0 || raw_left[i].x > 639 || raw_left[i].y < 0 || raw_left[i].y > 479) continue;
    ++in_view;
    EXPECT_NEAR(left[i].y, right[i].y, 0.1) << i;  // the criterion
    const double d = left[i].x - right[i].x;
    const double z = f * baseline / (d - (g.P_left(0, 2) - g.P_right(0, 2)));
    const Eigen::Vector3d in_rect = g.rect_from_left * Eigen::Vector3d(points[i].x, points[i].y, points[i].z);
    EXPECT_NEAR(z, in_rect.z(), 1e-3 * in_rect.z()) << i;
  }
  EXPECT_GT(in_view, 50);
}

TEST(Rectifier, RefusesImagesOfAnotherSize) {
  const Rectifier rectifier(RectifyRig(testing::PaperRig()));
  cv::Mat a(480, 640, CV_8UC1, cv::Scalar(9)), b(240, 320, CV_8UC1), out_a, out_b;
  EXPECT_THROW(rectifier.Rectify(a, b, &out_a, &out_b), InputError);
  rectifier.Rectify(a, a, &out_a, &out_b);
  EXPECT_EQ(out_a.size(), a.size());
  EXPECT_EQ(out_a.at<std::uint8_t>(240, 320), 9);  // the centre stays inside the raw image
  EXPECT_THROW(Rectifier{testing::PaperRig()}, std::invalid_argument);  // not rectified
}

TEST(Rectifier, RectifyPointsInvertsTheRemapTablesEverywhere) {
  // The remap tables send each rectified pixel to a raw position; RectifyPoints must send that
  // raw position back, also in the strongly distorted corners of the image.
  const StereoRig rig = RectifyRig(testing::PaperRig(), 1.0);
  const Rectifier rectifier(rig);
  const RectifiedGeometry& g = *rig.rectified;
  for (const bool left : {true, false}) {
    const CameraIntrinsics& c = left ? rig.left : rig.right;
    cv::Mat map_x, map_y, k, r, p;
    cv::eigen2cv(c.K, k);
    cv::eigen2cv(left ? g.rect_from_left : g.rect_from_right, r);
    cv::eigen2cv(left ? g.P_left : g.P_right, p);
    cv::initUndistortRectifyMap(k, cv::Mat(c.distortion), r, p, cv::Size(g.width_px, g.height_px), CV_32FC1,
                                map_x, map_y);
    std::vector<cv::Point2d> rect, raw;
    for (int y = 0; y < g.height_px; y += 479) {
      for (int x = 0; x < g.width_px; x += 71) {
        rect.emplace_back(x, y);
        raw.emplace_back(map_x.at<float>(y, x), map_y.at<float>(y, x));
      }
    }
    const std::vector<cv::Point2d> back = rectifier.RectifyPoints(raw, left);
    for (std::size_t i = 0; i < rect.size(); ++i) {
      EXPECT_NEAR(back[i].x, rect[i].x, 2e-3) << rect[i] << (left ? " left" : " right");
      EXPECT_NEAR(back[i].y, rect[i].y, 2e-3) << rect[i] << (left ? " left" : " right");
    }
  }
}

}  // namespace
}  // namespace lunarnav::calib
