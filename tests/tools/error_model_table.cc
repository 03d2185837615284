// Prints the predicted X, Y, Z error of a one-pixel disparity error against distance
// (Krotkov & Hebert sec. 3.2) as a Markdown table; docs/frames.md shows its output:
//   build/tests/tools/error_model_table [RIG.json] [SIGMA_D_PX]
// Without a rig file: an ideal rectified rig like the paper's (640 x 480, f = 740 px,
// B = 0.9 m, 1.5 m up, 25 deg down). Targets lie on the ground (Z = 0), straight ahead
// (X = 0) and at the right edge of the reference (right) image.
#include <cmath>
#include <cstdio>
#include <exception>
#include <string>

#include "calib/stereo_rig_io.h"
#include "calib/triangulation.h"

using namespace lunarnav;
using calib::ReferenceImage;

namespace {

calib::StereoRig PaperRig() {
  calib::StereoRig rig;
  rig.width_px = 640;
  rig.height_px = 480;
  for (calib::CameraIntrinsics* c : {&rig.left, &rig.right}) c->K << 740, 0, 319.5, 0, 740, 239.5, 0, 0, 1;
  rig.right_from_left_t_m = Eigen::Vector3d(-0.9, 0, 0);
  rig.mast = calib::MastPose{1.5, 25.0, 0.0, 0.0};
  calib::RectifiedGeometry g;
  g.P_left << 740, 0, 319.5, 0, 0, 740, 239.5, 0, 0, 0, 1, 0;
  g.P_right << 740, 0, 319.5, -740 * 0.9, 0, 740, 239.5, 0, 0, 0, 1, 0;
  g.width_px = 640;
  g.height_px = 480;
  rig.rectified = g;
  return rig;
}

// X of the ground point at distance y whose projection is the right edge of the image.
double RightEdgeX(const calib::StereoRig& rig, double y) {
  const double edge = rig.rectified->width_px - 0.5;
  double lo = 0, hi = 10 * y;
  for (int k = 0; k < 100; ++k) {
    const double mid = 0.5 * (lo + hi);
    (calib::ProjectToRectified(rig, {mid, y, 0}, ReferenceImage::kRight).x_px < edge ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace

int main(int argc, char** argv) {
  try {
    if (argc > 3) {
      std::fprintf(stderr, "usage: error_model_table [RIG.json] [SIGMA_D_PX]\n");
      return 2;
    }
    const calib::StereoRig rig = argc >= 2 ? calib::ReadStereoRig(argv[1]) : PaperRig();
    const double sigma_d = argc >= 3 ? std::stod(argv[2]) : 1.0;
    const calib::RectifiedGeometry& g = *rig.rectified;
    std::printf("Predicted error for sigma_d = %.2f px; rig: f = %.1f px, B = %.3f m, %.2f m up, %.1f deg down, "
                "%d x %d.\nGround targets (Z = 0); \"row\" is the right image's row (- = outside the image).\n\n",
                sigma_d, g.P_left(0, 0), -g.P_right(0, 3) / g.P_left(0, 0), rig.mast.height_m, rig.mast.tilt_deg,
                g.width_px, g.height_px);
    std::printf("| Y (m) | row | d (px) | sigma_X (cm) | sigma_Y (cm) | sigma_Z (cm) | edge X (m) | edge sigma_X (cm) | edge sigma_Y (cm) |\n");
    std::printf("|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for (double y : {1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0, 12.0, 15.0, 20.0}) {
      const Eigen::Vector3d centre(0, y, 0);
      const calib::RectifiedProjection p = calib::ProjectToRectified(rig, centre, ReferenceImage::kRight);
      const Eigen::Vector3d s = 100 * calib::PredictPointSigma(rig, centre, ReferenceImage::kRight, sigma_d);
      const double edge_x = RightEdgeX(rig, y);
      const Eigen::Vector3d e = 100 * calib::PredictPointSigma(rig, {edge_x, y, 0}, ReferenceImage::kRight, sigma_d);
      const bool in_image = p.depth_m > 0 && p.y_px > -0.5 && p.y_px < g.height_px - 0.5;
      std::printf("| %.0f | %s | %.1f | %.2f | %.1f | %.2f | %.1f | %.1f | %.1f |\n", y,
                  in_image ? std::to_string(static_cast<int>(std::lround(p.y_px))).c_str() : "-", p.disparity_px,
                  s.x(), s.y(), s.z(), edge_x, e.x(), e.y());
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
