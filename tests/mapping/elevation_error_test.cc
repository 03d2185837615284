#include "mapping/elevation_error.h"

#include <gtest/gtest.h>

#include "calib/rectify.h"
#include "calib/paper_rig.h"

namespace lunarnav::mapping {
namespace {

TEST(ElevationErrorModel, EqualsTheTriangulationErrorModelAtAnyPoint) {
  // The paper's rig, rectified (its rectified frame turned against the cameras).
  const calib::StereoRig rig = calib::RectifyRig(calib::testing::PaperRig(), 0.0);
  for (const auto reference : {calib::ReferenceImage::kRight, calib::ReferenceImage::kLeft}) {
    const ElevationErrorModel model(rig, reference, 1.5);
    for (const Eigen::Vector3d& p : {Eigen::Vector3d(0, 4, 0), Eigen::Vector3d(-2, 8, 0.3), Eigen::Vector3d(3, 12, -0.4)}) {
      const double expected = calib::PredictPointSigma(rig, p, reference, 1.5).z();
      EXPECT_NEAR(model.SigmaZ(p.x(), p.y(), p.z()), expected, 1e-9 * expected) << p.transpose();
    }
  }
  // Behind the cameras: none.
  EXPECT_TRUE(std::isnan(ElevationErrorModel(rig, calib::ReferenceImage::kRight, 1).SigmaZ(0, -5, 0)));
}

}  // namespace
}  // namespace lunarnav::mapping
