#include "calib/triangulation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "calib/paper_rig.h"

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

TEST(TriangulateDisparity, NeedsARectifiedRigOfTheMapsSize) {
  const cv::Mat disparity(480, 640, CV_32FC1, cv::Scalar(10));
  EXPECT_THROW(TriangulateDisparity(testing::PaperRig(), disparity, ReferenceImage::kRight),
               std::invalid_argument);
  EXPECT_THROW(TriangulateDisparity(RectifiedPaperRig(), cv::Mat(100, 100, CV_32FC1), ReferenceImage::kRight),
               std::invalid_argument);
}

}  // namespace
}  // namespace lunarnav::calib
