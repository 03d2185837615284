#include "calib/stereo_rig.h"

#include <cmath>
#include <cstdio>
#include <string>

#include <Eigen/SVD>

#include "util/check.h"

namespace lunarnav::calib {
namespace {

constexpr double kDeg = M_PI / 180.0;

void CheckRotation(const Eigen::Matrix3d& r, const std::string& where) {
  LN_CHECK_INPUT(r.allFinite()) << where << ": not finite";
  LN_CHECK_INPUT((r.transpose() * r - Eigen::Matrix3d::Identity()).norm() < 1e-6 &&
                 std::abs(r.determinant() - 1.0) < 1e-6)
      << where << ": not a rotation matrix (R^T R = I and det R = 1 within 1e-6)";
}

}  // namespace

void CameraIntrinsics::Validate(int width, int height, const std::string& where) const {
  const Eigen::Matrix3d& k = K;
  LN_CHECK_INPUT(k.allFinite()) << where << ".K: not finite";
  LN_CHECK_INPUT(k(0, 0) > 0 && k(1, 1) > 0) << where << ".K: focal lengths must be positive, got fx "
                                              << k(0, 0) << ", fy " << k(1, 1);
  // A lens of a pixel's focal length sees 127 degrees across 2 px; one of 10^6 px, a 6-arc-
  // minute field across 10,000 px: beyond either, a mistake (1e-6 px rectified to garbage).
  LN_CHECK_INPUT(k(0, 0) >= 1 && k(1, 1) >= 1 && k(0, 0) <= 1e6 && k(1, 1) <= 1e6)
      << where << ".K: focal lengths must be 1 to 10^6 px, got fx " << k(0, 0) << ", fy " << k(1, 1);
  LN_CHECK_INPUT(std::abs(k(0, 1)) <= k(0, 0)) << where << ".K: a skew of " << k(0, 1)
                                               << " px, beyond the focal length " << k(0, 0) << " px";
  LN_CHECK_INPUT(k(1, 0) == 0 && k(2, 0) == 0 && k(2, 1) == 0 && k(2, 2) == 1)
      << where << ".K: expected [[fx, s, cx], [0, fy, cy], [0, 0, 1]]";
  LN_CHECK_INPUT(k(0, 2) > -width && k(0, 2) < 2.0 * width && k(1, 2) > -height && k(1, 2) < 2.0 * height)
      << where << ".K: principal point (" << k(0, 2) << ", " << k(1, 2) << ") far outside the "
      << width << "x" << height << " image";
  const std::size_t n = distortion.size();
  LN_CHECK_INPUT(n == 0 || n == 4 || n == 5 || n == 8)
      << where << ".distortion: expected 0, 4, 5 or 8 coefficients (OpenCV order), got " << n;
  // OpenCV's coefficients act on normalised coordinates (about 1 at a wide lens's edge): the
  // strongest real lenses stay within tens; 10^4 is a mistake (10^6 rectified to garbage).
  for (double d : distortion) {
    LN_CHECK_INPUT(std::isfinite(d) && std::abs(d) <= 1e4)
        << where << ".distortion: coefficients must lie within 10^4, got " << d;
  }
}

Eigen::Matrix3d NearestRotation(const Eigen::Matrix3d& m) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  return svd.matrixU() * d * svd.matrixV().transpose();
}

namespace {

std::string Scientific(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.1e", value);
  return text;
}

}  // namespace

void RepairPrintedRotation(Eigen::Matrix3d* r, const std::string& where, std::vector<std::string>* notes) {
  LN_CHECK_INPUT(r->allFinite()) << where << ": not finite";
  const double orthogonality = (r->transpose() * *r - Eigen::Matrix3d::Identity()).norm();
  const double det_error = std::abs(r->determinant() - 1.0);
  if (orthogonality <= 1e-12 && det_error <= 1e-12) return;  // exact to double precision
  LN_CHECK_INPUT(orthogonality <= kPrintedRotationTolerance && det_error <= kPrintedRotationTolerance)
      << where << ": not a rotation matrix (||R^T R - I|| = " << Scientific(orthogonality) << ", |det R - 1| = "
      << Scientific(det_error) << "; printed values are accepted within " << Scientific(kPrintedRotationTolerance)
      << ")";
  const Eigen::Matrix3d nearest = NearestRotation(*r);
  const double change = (nearest - *r).cwiseAbs().maxCoeff();
  *r = nearest;
  if (change > 1e-12) {
    notes->push_back(where + ": not exactly a rotation (||R^T R - I|| = " + Scientific(orthogonality) +
                     "), replaced by the nearest rotation (elements changed by at most " + Scientific(change) + ")");
  }
}

namespace {

void RepairShared(double left, double* right, const std::string& where, std::vector<std::string>* notes) {
  if (*right == left) return;
  const double relative = std::abs(*right - left) / std::max(std::abs(left), 1.0);
  if (relative > kPrintedProjectionTolerance) return;  // Validate names it
  notes->push_back(where + ": " + std::to_string(*right) + " differs from the left projection's " +
                   std::to_string(left) + " by round-off (" + Scientific(relative) + "); the left's value is used");
  *right = left;
}

}  // namespace

void RepairPrintedPrecision(StereoRig* rig, const std::string& source) {
  RepairPrintedRotation(&rig->right_from_left_R, source + ".right_from_left.R", &rig->notes);
  if (rig->rectified) {
    RectifiedGeometry& g = *rig->rectified;
    RepairPrintedRotation(&g.rect_from_left, source + ".rectified.rect_from_left", &rig->notes);
    RepairPrintedRotation(&g.rect_from_right, source + ".rectified.rect_from_right", &rig->notes);
    RepairShared(g.P_left(0, 0), &g.P_right(0, 0), source + ".rectified.P_right[0][0]", &rig->notes);
    RepairShared(g.P_left(1, 1), &g.P_right(1, 1), source + ".rectified.P_right[1][1]", &rig->notes);
    RepairShared(g.P_left(1, 2), &g.P_right(1, 2), source + ".rectified.P_right[1][2]", &rig->notes);
  }
}

Eigen::Matrix3d VehicleFromHeadRotation(double tilt_deg) {
  const double t = tilt_deg * kDeg;
  Eigen::Matrix3d r;
  // Columns: the head's x (right), y (down, tilted) and z (optical axis) in vehicle axes.
  r.col(0) = Eigen::Vector3d(1, 0, 0);
  r.col(1) = Eigen::Vector3d(0, -std::sin(t), -std::cos(t));
  r.col(2) = Eigen::Vector3d(0, std::cos(t), -std::sin(t));
  return r;
}

Eigen::Isometry3d StereoRig::VehicleFromLeft() const {
  const Eigen::Matrix3d r = VehicleFromHeadRotation(mast.tilt_deg);
  // The right camera's centre in left coordinates is -R^T t; the head centre is midway.
  const Eigen::Vector3d right_centre_in_left = -right_from_left_R.transpose() * right_from_left_t_m;
  const Eigen::Vector3d head_centre_in_left = 0.5 * right_centre_in_left;
  const Eigen::Vector3d head_in_vehicle(mast.lateral_offset_m, mast.forward_offset_m, mast.height_m);
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = r;
  t.translation() = head_in_vehicle - r * head_centre_in_left;
  return t;
}

Eigen::Isometry3d StereoRig::VehicleFromRight() const {
  Eigen::Isometry3d right_from_left = Eigen::Isometry3d::Identity();
  right_from_left.linear() = right_from_left_R;
  right_from_left.translation() = right_from_left_t_m;
  return VehicleFromLeft() * right_from_left.inverse();
}

namespace {
// The largest raw image side a rig may declare (32768: beyond any camera, within the images'
// limits), and how far the rectified baseline may differ from the cameras' distance.
constexpr int kMaxRigImageSidePx = 32768;
constexpr double kBaselineAgreement = 0.02;
}  // namespace

void StereoRig::Validate(const std::string& source) const {
  LN_CHECK_INPUT(width_px > 0 && height_px > 0 && width_px <= kMaxRigImageSidePx && height_px <= kMaxRigImageSidePx)
      << source << ".image_size_px: " << width_px << " x " << height_px << " px; each side must be 1 to "
      << kMaxRigImageSidePx << " px";
  left.Validate(width_px, height_px, source + ".left");
  right.Validate(width_px, height_px, source + ".right");
  CheckRotation(right_from_left_R, source + ".right_from_left.R");
  LN_CHECK_INPUT(right_from_left_t_m.allFinite() && BaselineM() > 1e-6)
      << source << ".right_from_left.t_m: the baseline must be positive";
  LN_CHECK_INPUT(BaselineM() <= kMaxBaselineM)
      << source << ".right_from_left.t_m: a baseline of " << BaselineM() << " m, more than the " << kMaxBaselineM
      << " m of any stereo rig (units: metres?)";
  // Side by side: lunarnav matches along rows (horizontal stereo). The right camera's centre
  // in the left camera's frame must lie more along x than along y and z.
  const Eigen::Vector3d right_centre = -right_from_left_R.transpose() * right_from_left_t_m;
  LN_CHECK_INPUT(std::abs(right_centre.x()) >= std::sqrt(0.5) * right_centre.norm())
      << source << ".right_from_left: the right camera sits at (" << right_centre.x() << ", " << right_centre.y()
      << ", " << right_centre.z() << ") m from the left one, not beside it: lunarnav matches along image rows "
      << "(a vertical rig's images are turned 90 degrees and calibrated so)";
  LN_CHECK_INPUT(std::isfinite(mast.height_m) && std::isfinite(mast.lateral_offset_m) &&
                 std::isfinite(mast.forward_offset_m))
      << source << ".mast: not finite";
  LN_CHECK_INPUT(std::isfinite(mast.tilt_deg) && mast.tilt_deg > -90 && mast.tilt_deg < 90)
      << source << ".mast.tilt_deg: must be in (-90, 90), got " << mast.tilt_deg;
  LN_CHECK_INPUT(mast.height_m >= 0)
      << source << ".mast.height_m: " << mast.height_m << " m; the cameras stand at or above the ground (>= 0)";
  if (rectified) {
    const RectifiedGeometry& g = *rectified;
    CheckRotation(g.rect_from_left, source + ".rectified.rect_from_left");
    CheckRotation(g.rect_from_right, source + ".rectified.rect_from_right");
    // Declared sizes bound the work done before any image is read (a rig of 100000 x 100000
    // rectified pixels kept stereo-batch busy for ever): the rectified images are at most
    // twice the raw ones each way (rectify's alpha and scaling never ask for more).
    LN_CHECK_INPUT(g.width_px > 0 && g.height_px > 0 && g.width_px <= 2 * width_px && g.height_px <= 2 * height_px)
        << source << ".rectified.size_px: " << g.width_px << " x " << g.height_px << " px for raw images of "
        << width_px << " x " << height_px << "; each side must be 1 to twice the raw one";
    LN_CHECK_INPUT(g.P_left.allFinite() && g.P_right.allFinite() && g.P_left(0, 0) > 0 &&
                   g.P_left(0, 0) == g.P_right(0, 0) && g.P_left(1, 2) == g.P_right(1, 2) &&
                   g.P_left(0, 3) == 0 && g.P_right(0, 3) != 0)
        << source << ".rectified: P_left and P_right must share focal length and principal row, "
        << "with the baseline term in P_right[0][3] only";
    // The rectified baseline is the cameras' distance: a P_right that says otherwise would
    // scale every point's range (150 m against a 0.9 m pose gave XYZ 166 times too far).
    const double rectified_baseline = -g.P_right(0, 3) / g.P_right(0, 0);
    LN_CHECK_INPUT(std::abs(rectified_baseline - BaselineM()) <= kBaselineAgreement * BaselineM())
        << source << ".rectified.P_right: a baseline of " << rectified_baseline << " m, but right_from_left puts the "
        << "cameras " << BaselineM() << " m apart (more than " << 100 * kBaselineAgreement << " % off)";
  }
}

}  // namespace lunarnav::calib
