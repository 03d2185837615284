#include "mapping/elevation_error.h"

#include <gtest/gtest.h>

#include <cmath>

#include "calib/rectify.h"
#include "calib/paper_rig.h"
#include "calib/triangulation.h"

namespace lunarnav::mapping {
namespace {

TEST(ElevationErrorModel, EqualsTheTriangulationErrorModelAtAnyPoint) {
  // The paper's rig, rectified (its rectified frame turned against the cameras).
  const calib::StereoRig rig = calib::RectifyRig(calib::testing::PaperRig(), 0.0);
  for (const auto reference : {calib::ReferenceImage::kRight, calib::ReferenceImage::kLeft}) {
    const ElevationErrorModel model(rig, reference, 1.5);
    for (const Eigen::Vector3d& p : {Eigen::Vector3d(0, 4, 0), Eigen::Vector3d(-2, 8, 0.3), Eigen::Vector3d(3, 12, -0.4)}) {
      const Eigen::Vector3d sigma = calib::PredictPointSigma(rig, p, reference, 1.5);
      EXPECT_NEAR(model.SigmaZ(p.x(), p.y(), p.z()), sigma.z(), 1e-9 * sigma.z()) << p.transpose();
      const double horizontal = std::hypot(sigma.x(), sigma.y());
      EXPECT_NEAR(model.SigmaHorizontal(p.x(), p.y(), p.z()), horizontal, 1e-9 * horizontal) << p.transpose();
    }
  }
  // Behind the cameras: none.
  EXPECT_TRUE(std::isnan(ElevationErrorModel(rig, calib::ReferenceImage::kRight, 1).SigmaZ(0, -5, 0)));
}

TEST(ElevationErrorModel, GivesThePointsDisparityAsTheRigProjectsIt) {
  const calib::StereoRig rig = calib::RectifyRig(calib::testing::PaperRig(), 0.0);
  for (const auto reference : {calib::ReferenceImage::kRight, calib::ReferenceImage::kLeft}) {
    const ElevationErrorModel model(rig, reference, 1.5);  // the disparity error does not enter it
    for (const Eigen::Vector3d& p : {Eigen::Vector3d(0, 4, 0), Eigen::Vector3d(-2, 8, 0.3), Eigen::Vector3d(3, 12, -0.4)}) {
      const calib::RectifiedProjection at = calib::ProjectToRectified(rig, p, reference);
      EXPECT_NEAR(model.DisparityPx(p.x(), p.y(), p.z()), at.disparity_px, 1e-9 * at.disparity_px) << p.transpose();
    }
  }
  EXPECT_TRUE(std::isnan(ElevationErrorModel(rig, calib::ReferenceImage::kRight, 1).DisparityPx(0, -5, 0)));
}

}  // namespace
}  // namespace lunarnav::mapping
