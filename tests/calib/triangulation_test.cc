#include "calib/triangulation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <algorithm>
#include <limits>
#include <utility>
#include <vector>

#include "calib/paper_rig.h"
#include "calib/rectified_rig.h"

namespace lunarnav::calib {
namespace {

// The paper's rig, ideally aligned and already rectified (identity rectifying rotations).
StereoRig RectifiedPaperRig() {
  StereoRig rig = testing::PaperRig();
  rig.right_from_left_R.setIdentity();
  rig.right_from_left_t_m = Eigen::Vector3d(-0.9, 0, 0);
  RectifiedGeometry g;
  g.P_left << 740, 0, 319.5, 0, 0, 740, 239.5, 0, 0, 0, 1, 0;
  g.P_right << 740, 0, 319.5, -740 * 0.9, 0, 740, 239.5, 0, 0, 0, 1, 0;
  g.width_px = 640;
  g.height_px = 480;
  rig.rectified = g;
  return rig;
}

// Where the right camera's ray through pixel (x, y) meets the ground (vehicle Z = 0), found
// by intersecting the ray with the plane, not through any disparity formula.
Eigen::Vector3d GroundPointSeenAt(const StereoRig& rig, double x, double y) {
  const Eigen::Isometry3d vehicle_from_right = rig.VehicleFromRight();
  const Eigen::Vector3d direction =
      vehicle_from_right.linear() * Eigen::Vector3d((x - 319.5) / 740, (y - 239.5) / 740, 1.0);
  const Eigen::Vector3d origin = vehicle_from_right.translation();
  return origin + direction * (-origin.z() / direction.z());
}

// Column of the left image where a vehicle point projects (through P_left).
double LeftColumn(const StereoRig& rig, const Eigen::Vector3d& point_in_vehicle) {
  const Eigen::Vector3d p = rig.VehicleFromLeft().inverse() * point_in_vehicle;
  const Eigen::Vector3d h = rig.rectified->P_left * p.homogeneous();
  return h.x() / h.z();
}

TEST(TriangulateDisparity, ReproducesGroundTruthXyzOfTheGround) {
  const StereoRig rig = RectifiedPaperRig();
  cv::Mat disparity(480, 640, CV_32FC1, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  for (int y = 240; y < 480; y += 40) {
    for (int x = 0; x < 640; x += 80) {
      disparity.at<float>(y, x) = static_cast<float>(LeftColumn(rig, GroundPointSeenAt(rig, x, y)) - x);
    }
  }
  const cv::Mat xyz = TriangulateDisparity(rig, disparity, ReferenceImage::kRight);
  int checked = 0;
  for (int y = 240; y < 480; y += 40) {
    for (int x = 0; x < 640; x += 80) {
      const cv::Vec3f p = xyz.at<cv::Vec3f>(y, x);
      const Eigen::Vector3d truth = GroundPointSeenAt(rig, x, y);
      // float32 disparity: 1e-7 relative of ~100 px gives ~1e-5 px, well under a millimetre.
      EXPECT_NEAR(p[0], truth.x(), 1e-3) << x << "," << y;
      EXPECT_NEAR(p[1], truth.y(), 1e-3) << x << "," << y;
      EXPECT_NEAR(p[2], 0.0, 1e-3) << x << "," << y;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 48);
  EXPECT_TRUE(std::isnan(xyz.at<cv::Vec3f>(0, 0)[0]));  // no disparity, no point
}

TEST(TriangulateDisparity, PixelToXyzToPixelIsTheIdentityForBothReferences) {
  StereoRig rig = RectifiedPaperRig();
  rig.rectified->P_right(0, 2) = 311.0;  // principal points differ after rectification
  for (ReferenceImage reference : {ReferenceImage::kRight, ReferenceImage::kLeft}) {
    cv::Mat disparity(480, 640, CV_32FC1, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
    disparity.at<float>(300, 200) = 57.25f;
    disparity.at<float>(100, 600) = 12.5f;
    const cv::Mat xyz = TriangulateDisparity(rig, disparity, reference);
    for (const cv::Point px : {cv::Point(200, 300), cv::Point(600, 100)}) {
      const cv::Vec3f v = xyz.at<cv::Vec3f>(px);
      const Eigen::Vector3d in_left = rig.VehicleFromLeft().inverse() * Eigen::Vector3d(v[0], v[1], v[2]);
      const Eigen::Vector3d l = rig.rectified->P_left * in_left.homogeneous();
      const Eigen::Vector3d r = rig.rectified->P_right * in_left.homogeneous();
      const double x_left = l.x() / l.z(), x_right = r.x() / r.z(), row = l.y() / l.z();
      const double d = disparity.at<float>(px);
      EXPECT_NEAR(reference == ReferenceImage::kRight ? x_right : x_left, px.x, 1e-3);
      EXPECT_NEAR(x_left - x_right, d, 1e-3);
      EXPECT_NEAR(row, px.y, 1e-3);
      EXPECT_NEAR(r.y() / r.z(), px.y, 1e-3);
    }
  }
}

// Ground truth for any reference and grid: known 3-D points (a ground plane with bumps, seen
// by a rig whose rectified frame is rolled and yawed against the cameras and whose rectified
// principal points differ) projected through P_left and P_right; the disparity of each grid
// pixel of the reference image is the difference of the projected columns.
struct SyntheticScene {
  cv::Mat disparity;  // CV_32FC1, reference-image pixels, NaN off the grid
  std::vector<std::pair<cv::Point, Eigen::Vector3d>> truth;
};

SyntheticScene ProjectKnownPoints(const StereoRig& rig, ReferenceImage reference, int step_x, int step_y) {
  const RectifiedGeometry& g = *rig.rectified;
  const Eigen::Isometry3d vehicle_from_left = rig.VehicleFromLeft();
  // The rectified reference camera's centre and axes in the vehicle frame.
  const Eigen::Matrix3d vehicle_from_rect = vehicle_from_left.linear() * g.rect_from_left.transpose();
  const double f = g.P_left(0, 0), baseline = -g.P_right(0, 3) / f;
  const Eigen::Vector3d centre =
      vehicle_from_left * Eigen::Vector3d(g.rect_from_left.transpose() *
                                          Eigen::Vector3d(reference == ReferenceImage::kRight ? baseline : 0, 0, 0));
  const double c_x = reference == ReferenceImage::kRight ? g.P_right(0, 2) : g.P_left(0, 2);
  SyntheticScene scene;
  scene.disparity = cv::Mat(g.height_px, g.width_px, CV_32FC1, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  for (int y = 0; y < g.height_px; y += step_y) {
    for (int x = 0; x < g.width_px; x += step_x) {
      // The reference ray through (x, y) meets the terrain Z = 0.2 sin(X) cos(0.5 Y): found by
      // bisection along the ray, so the point is known without any disparity formula.
      const Eigen::Vector3d ray =
          vehicle_from_rect * Eigen::Vector3d((x - c_x) / f, (y - g.P_left(1, 2)) / f, 1.0);
      auto height_above = [&](double t) {
        const Eigen::Vector3d p = centre + t * ray;
        return p.z() - 0.2 * std::sin(p.x()) * std::cos(0.5 * p.y());
      };
      double lo = 0.1, hi = 60.0;
      if (height_above(hi) > 0) continue;  // sky: no point
      for (int k = 0; k < 80; ++k) (height_above(0.5 * (lo + hi)) > 0 ? lo : hi) = 0.5 * (lo + hi);
      const Eigen::Vector3d point = centre + 0.5 * (lo + hi) * ray;
      // P_left and P_right project points of the rectified (left) frame.
      const Eigen::Vector3d in_rect = g.rect_from_left * (vehicle_from_left.inverse() * point);
      const Eigen::Vector3d l = g.P_left * in_rect.homogeneous(), r = g.P_right * in_rect.homogeneous();
      scene.disparity.at<float>(y, x) = static_cast<float>(l.x() / l.z() - r.x() / r.z());
      scene.truth.emplace_back(cv::Point(x, y), point);
    }
  }
  return scene;
}

TEST(TriangulateDisparity, ReproducesGroundTruthForBothReferencesAndSubsampledMaps) {
  const StereoRig rig = testing::IdealRectifiedRig(160, 120, 185, 0.9, testing::RollYaw(2.0, -3.0), -4.0);
  for (ReferenceImage reference : {ReferenceImage::kRight, ReferenceImage::kLeft}) {
    for (const cv::Size step : {cv::Size(1, 1), cv::Size(4, 3)}) {
      const SyntheticScene scene = ProjectKnownPoints(rig, reference, step.width, step.height);
      ASSERT_GT(scene.truth.size(), 100u);
      const cv::Mat xyz = TriangulateDisparity(rig, scene.disparity, reference);
      double worst_m = 0;
      for (const auto& [px, truth] : scene.truth) {
        const cv::Vec3f p = xyz.at<cv::Vec3f>(px);
        worst_m = std::max(worst_m, (Eigen::Vector3d(p[0], p[1], p[2]) - truth).norm() / truth.y());
      }
      // float32 disparities and coordinates: relative error ~1e-6 of the distance.
      EXPECT_LT(worst_m, 1e-4) << ToString(reference) << " step " << step;
      // Off the grid and in the sky: NaN in all three channels.
      int nan_pixels = 0;
      for (int y = 0; y < xyz.rows; ++y) {
        for (int x = 0; x < xyz.cols; ++x) {
          const bool has_disparity = std::isfinite(scene.disparity.at<float>(y, x));
          const cv::Vec3f p = xyz.at<cv::Vec3f>(y, x);
          EXPECT_EQ(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]), has_disparity);
          nan_pixels += std::isnan(p[0]) && std::isnan(p[1]) && std::isnan(p[2]);
        }
      }
      EXPECT_EQ(nan_pixels, xyz.rows * xyz.cols - static_cast<int>(scene.truth.size()));
    }
  }
}

TEST(PredictXyzSigma, ReproducesThePapersErrorModelShape) {
  // Sec. 3.2: for a one-pixel disparity error, "the Y error increases quadratically to almost
  // 60 cm at 20 m, while the errors in X and Z do not exceed 6 cm". Targets straight ahead at
  // 5, 10 and 20 m, on the right camera's ray through the top row (the farthest this rig,
  // tilted 25 deg with a +-18 deg field, sees: 7 deg below horizontal).
  const StereoRig rig = RectifiedPaperRig();
  const Eigen::Isometry3d vehicle_from_right = rig.VehicleFromRight();
  const Eigen::Vector3d origin = vehicle_from_right.translation();
  const Eigen::Vector3d ray = vehicle_from_right.linear() * Eigen::Vector3d(0.5 / 740, -239.5 / 740, 1.0);
  std::vector<double> sigma_y, sigma_z;
  for (double distance : {5.0, 10.0, 20.0}) {
    const Eigen::Vector3d target = origin + ray * ((distance - origin.y()) / ray.y());
    cv::Mat map(480, 640, CV_32FC1, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
    map.at<float>(0, 320) = static_cast<float>(LeftColumn(rig, target) - 320.0);
    const cv::Vec3f s = PredictXyzSigma(rig, map, ReferenceImage::kRight, 1.0).at<cv::Vec3f>(0, 320);
    const cv::Vec3f p = TriangulateDisparity(rig, map, ReferenceImage::kRight).at<cv::Vec3f>(0, 320);
    EXPECT_NEAR(p[1], distance, 1e-3);
    sigma_y.push_back(s[1]);
    sigma_z.push_back(s[2]);
    EXPECT_LT(s[0], 0.06) << distance;  // X: straight ahead, tiny
  }
  EXPECT_NEAR(sigma_y[2], 0.6, 0.06);              // ~60 cm at 20 m
  EXPECT_NEAR(sigma_y[1] / sigma_y[0], 4.0, 0.1);  // quadratic: twice the distance, 4x
  EXPECT_NEAR(sigma_y[2] / sigma_y[1], 4.0, 0.1);
  // Z: the error runs along the ray, 7 deg below horizontal here: 0.6 m x sin(7 deg) = 7.4 cm
  // at 20 m, and a quarter of that at 10 m (the paper's rig: under 6 cm).
  EXPECT_LT(sigma_z[2], 0.08);
  EXPECT_LT(sigma_z[1], 0.02);
}

TEST(PredictPointSigma, EqualsTheMapsValueAtThePointsPixel) {
  const StereoRig rig = testing::IdealRectifiedRig(160, 120, 185, 0.9, testing::RollYaw(2.0, -3.0), -4.0);
  for (ReferenceImage reference : {ReferenceImage::kRight, ReferenceImage::kLeft}) {
    for (const Eigen::Vector3d& point : {Eigen::Vector3d(0.3, 4.0, 0.0), Eigen::Vector3d(-1.2, 7.0, 0.1)}) {
      const RectifiedProjection p = ProjectToRectified(rig, point, reference);
      // Put the point's disparity at its (rounded) pixel, and move the point onto that pixel's
      // ray at the same depth, where the map's value applies.
      const int x = static_cast<int>(std::lround(p.x_px)), y = static_cast<int>(std::lround(p.y_px));
      ASSERT_TRUE(x >= 0 && x < 160 && y >= 0 && y < 120) << x << "," << y;
      cv::Mat map(120, 160, CV_32FC1, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
      map.at<float>(y, x) = static_cast<float>(p.disparity_px);
      const cv::Vec3f on_ray = TriangulateDisparity(rig, map, reference).at<cv::Vec3f>(y, x);
      const cv::Vec3f expected = PredictXyzSigma(rig, map, reference, 2.0).at<cv::Vec3f>(y, x);
      const Eigen::Vector3d got =
          PredictPointSigma(rig, Eigen::Vector3d(on_ray[0], on_ray[1], on_ray[2]), reference, 2.0);
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(got[k], expected[k], 1e-4 * (1 + expected[k])) << k;
      EXPECT_NEAR(ProjectToRectified(rig, Eigen::Vector3d(on_ray[0], on_ray[1], on_ray[2]), reference).x_px, x, 1e-3);
    }
  }
}

TEST(PredictPointSigma, PapersRigOnGroundTargetsStraightAhead) {
  // Sec. 3.2: "for targets from 0 to 20 meters, the Y error increases quadratically to almost
  // 60 cm at 20 m, while the errors in X and Z do not exceed 6 cm"; sec. 3.4: "the theoretical
  // error at 8 m is 10 cm". Ground targets (Z = 0) at X = 0, one-pixel disparity error (the
  // table of docs/frames.md, printed by tests/tools/error_model_table).
  const StereoRig rig = RectifiedPaperRig();
  auto sigma = [&](double y) { return PredictPointSigma(rig, Eigen::Vector3d(0, y, 0), ReferenceImage::kRight, 1.0); };
  for (double y = 1; y <= 20; y += 1) {
    EXPECT_LT(sigma(y).x(), 0.06) << y;
    EXPECT_LT(sigma(y).z(), 0.06) << y;
    if (y >= 2) {
      EXPECT_GT(sigma(y).y(), sigma(y).z()) << y;  // Y dominates beyond the nearest metre
    }
  }
  EXPECT_NEAR(sigma(20).y(), 0.6, 0.06);
  EXPECT_NEAR(sigma(8).y(), 0.10, 0.01);
  // Quadratic: doubling the distance multiplies the error by about 4 (a little less, as the
  // depth along the tilted axis grows slightly slower than Y).
  for (double y : {5.0, 10.0}) {
    EXPECT_GT(sigma(2 * y).y() / sigma(y).y(), 3.6) << y;
    EXPECT_LT(sigma(2 * y).y() / sigma(y).y(), 4.0) << y;
  }
}

TEST(GroundDisparityByRow, LevelRigIsTheBaselineOverTheHeightPerRowBelowTheHorizon) {
  // Cameras level at height h: the ground seen on row y lies at depth f h / (y - c_y), so its
  // disparity is (y - c_y) B / h, and rows at or above the horizon (c_y) see no ground.
  StereoRig rig = testing::IdealRectifiedRig(160, 120, 185, 0.5);
  rig.mast = MastPose{1.65, 0.0, 0.0, 0.0};
  const double cy = 0.5 * (120 - 1);
  for (const ReferenceImage reference : {ReferenceImage::kRight, ReferenceImage::kLeft}) {
    const std::vector<float> d = GroundDisparityByRow(rig, reference);
    ASSERT_EQ(d.size(), 120u);
    for (int y = 0; y < 120; ++y) {
      if (y <= cy) {
        EXPECT_TRUE(std::isnan(d[y])) << y;
      } else {
        EXPECT_NEAR(d[y], (y - cy) * 0.5 / 1.65, 1e-4) << y;
      }
    }
  }
}

TEST(GroundDisparityByRow, EachRowsValueProjectsBackOntoTheGroundOnThatRow) {
  // The paper's tilted rig and one rolled and yawed: the ground point of each row's value, on
  // the image's centre column, lies on Z = 0 and projects to that row with that disparity.
  for (const StereoRig& rig :
       {RectifiedPaperRig(), testing::IdealRectifiedRig(160, 120, 185, 0.9, testing::RollYaw(2.0, -3.0), -4.0)}) {
    for (const ReferenceImage reference : {ReferenceImage::kRight, ReferenceImage::kLeft}) {
      const std::vector<float> d = GroundDisparityByRow(rig, reference);
      int rows = 0;
      for (int y = 0; y < rig.rectified->height_px; ++y) {
        if (std::isnan(d[y])) continue;
        ++rows;
        cv::Mat disparity(rig.rectified->height_px, rig.rectified->width_px, CV_32FC1,
                          cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
        const int x = (rig.rectified->width_px - 1) / 2;
        disparity.at<float>(y, x) = d[y];
        const cv::Mat xyz = TriangulateDisparity(rig, disparity, reference);
        const cv::Vec3f p = xyz.at<cv::Vec3f>(y, x);
        EXPECT_NEAR(p[2], 0.0, 2e-3 * std::max(1.0, static_cast<double>(p[1]))) << y;
        const RectifiedProjection back =
            ProjectToRectified(rig, Eigen::Vector3d(p[0], p[1], p[2]), reference);
        EXPECT_NEAR(back.y_px, y, 1e-2) << y;
      }
      EXPECT_GT(rows, rig.rectified->height_px / 3);
    }
  }
}

TEST(TriangulateDisparity, NeedsARectifiedRigOfTheMapsSize) {
  const cv::Mat disparity(480, 640, CV_32FC1, cv::Scalar(10));
  EXPECT_THROW(TriangulateDisparity(testing::PaperRig(), disparity, ReferenceImage::kRight),
               std::invalid_argument);
  EXPECT_THROW(TriangulateDisparity(RectifiedPaperRig(), cv::Mat(100, 100, CV_32FC1), ReferenceImage::kRight),
               std::invalid_argument);
}

}  // namespace
}  // namespace lunarnav::calib
