#include "calib/stereo_rig.h"

#include <gtest/gtest.h>

#include <cmath>

#include "calib/paper_rig.h"
#include "util/errors.h"

namespace lunarnav::calib {
namespace {

constexpr double kDeg = M_PI / 180.0;

TEST(StereoRig, PlacesTheCamerasOnTheMastInTheVehicleFrame) {
  StereoRig rig = testing::PaperRig();
  rig.right_from_left_R.setIdentity();
  rig.right_from_left_t_m = Eigen::Vector3d(-0.9, 0, 0);
  const Eigen::Isometry3d left = rig.VehicleFromLeft(), right = rig.VehicleFromRight();
  // The cameras sit 0.45 m either side of the mast, 1.5 m up.
  EXPECT_TRUE(left.translation().isApprox(Eigen::Vector3d(-0.45, 0, 1.5), 1e-12));
  EXPECT_TRUE(right.translation().isApprox(Eigen::Vector3d(0.45, 0, 1.5), 1e-12));
  // The optical axis points forward and 25 deg down; image rows (y) point down the slope.
  EXPECT_TRUE((left.linear() * Eigen::Vector3d::UnitZ())
                  .isApprox(Eigen::Vector3d(0, std::cos(25 * kDeg), -std::sin(25 * kDeg)), 1e-12));
  EXPECT_NEAR(left.linear().determinant(), 1.0, 1e-12);
  // The optical axis meets the ground 1.5 / tan(25 deg) = 3.22 m ahead.
  const Eigen::Vector3d ground = left * (Eigen::Vector3d::UnitZ() * (1.5 / std::sin(25 * kDeg)));
  EXPECT_NEAR(ground.z(), 0.0, 1e-12);
  EXPECT_NEAR(ground.y(), 1.5 / std::tan(25 * kDeg), 1e-12);
}

TEST(StereoRig, ValidateNamesImpossibleValues) {
  auto expect_invalid = [](const StereoRig& rig, const std::string& words) {
    try {
      rig.Validate("rig.json");
      ADD_FAILURE() << "accepted: " << words;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  EXPECT_NO_THROW(testing::PaperRig().Validate("rig.json"));
  StereoRig rig = testing::PaperRig();
  rig.left.K(0, 0) = -740;
  expect_invalid(rig, "rig.json.left.K: focal lengths must be positive");
  rig = testing::PaperRig();
  rig.right_from_left_R(0, 1) = 0.3;
  expect_invalid(rig, "rig.json.right_from_left.R: not a rotation matrix");
  rig = testing::PaperRig();
  rig.right_from_left_t_m.setZero();
  expect_invalid(rig, "baseline must be positive");
  rig = testing::PaperRig();
  rig.right.distortion = {0.1, 0.2, 0.3};
  expect_invalid(rig, "rig.json.right.distortion");
  rig = testing::PaperRig();
  rig.mast.tilt_deg = 95;
  expect_invalid(rig, "tilt_deg");
  // No lens has a focal length of 1e-6 px, a skew beyond its focal length, or a distortion
  // coefficient of 10^6 (each rectified to garbage, exit 0).
  rig = testing::PaperRig();
  rig.left.K(0, 0) = rig.left.K(1, 1) = 1e-6;
  expect_invalid(rig, "rig.json.left.K: focal lengths must be 1 to 10^6 px");
  rig = testing::PaperRig();
  rig.right.K(0, 1) = 1e6;
  expect_invalid(rig, "rig.json.right.K: a skew of 1e+06 px");
  rig = testing::PaperRig();
  rig.left.distortion = {1e6, 0, 0, 0, 0};
  expect_invalid(rig, "rig.json.left.distortion: coefficients must lie within 10^4, got 1e+06");
  // Silent acceptance, refused now: a baseline in millimetres read as metres (120 m), a vertical
  // rig (the right camera 0.12 m below the left), and one 50 deg off the row direction; a rig
  // toed 30 deg about the vertical, its right camera still beside the left, is a rig.
  rig = testing::PaperRig();
  rig.right_from_left_t_m = Eigen::Vector3d(-120, 0, 0);
  expect_invalid(rig, "a baseline of 120 m, more than the 100 m");
  rig = testing::PaperRig();
  rig.right_from_left_t_m = Eigen::Vector3d(0, -0.12, 0);
  expect_invalid(rig, "rig.json.right_from_left: the right camera sits at (0, 0.12, 0) m");
  rig = testing::PaperRig();
  rig.right_from_left_t_m = Eigen::Vector3d(-std::cos(50 * kDeg), -std::sin(50 * kDeg), 0) * 0.5;
  expect_invalid(rig, "not beside it");
  rig = testing::PaperRig();
  rig.right_from_left_R = Eigen::AngleAxisd(30 * kDeg, Eigen::Vector3d::UnitY()).toRotationMatrix();
  rig.right_from_left_t_m = -rig.right_from_left_R * Eigen::Vector3d(0.5, 0, 0);  // centre at +0.5 m x
  EXPECT_NO_THROW(rig.Validate("rig.json"));
}

}  // namespace
}  // namespace lunarnav::calib
