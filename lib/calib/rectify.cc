#include "calib/rectify.h"

#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>

#include "util/check.h"

namespace lunarnav::calib {
namespace {

cv::Mat ToCv(const Eigen::MatrixXd& m) {
  cv::Mat out;
  cv::eigen2cv(m, out);
  return out;
}

cv::Mat Distortion(const CameraIntrinsics& c) {
  return c.distortion.empty() ? cv::Mat() : cv::Mat(c.distortion, true).reshape(1, 1);
}

}  // namespace

StereoRig RectifyRig(const StereoRig& rig, double alpha) {
  rig.Validate("rig");
  LN_CHECK_ARG(std::isfinite(alpha) && alpha >= 0 && alpha <= 1) << "alpha: must be in [0, 1]";
  const cv::Size size(rig.width_px, rig.height_px);
  cv::Mat r1, r2, p1, p2, q;
  cv::stereoRectify(ToCv(rig.left.K), Distortion(rig.left), ToCv(rig.right.K), Distortion(rig.right), size,
                    ToCv(rig.right_from_left_R), ToCv(rig.right_from_left_t_m), r1, r2, p1, p2, q,
                    cv::CALIB_ZERO_DISPARITY, alpha, size);
  StereoRig out = rig;
  RectifiedGeometry g;
  cv::cv2eigen(r1, g.rect_from_left);
  cv::cv2eigen(r2, g.rect_from_right);
  cv::cv2eigen(p1, g.P_left);
  cv::cv2eigen(p2, g.P_right);
  g.width_px = size.width;
  g.height_px = size.height;
  out.rectified = g;
  out.Validate("rectified rig");
  return out;
}

Rectifier::Rectifier(const StereoRig& rig) : rig_(rig) {
  LN_CHECK_ARG(rig.rectified.has_value()) << "rig: not rectified";
  const RectifiedGeometry& g = *rig.rectified;
  const cv::Size size(g.width_px, g.height_px);
  cv::initUndistortRectifyMap(ToCv(rig.left.K), Distortion(rig.left), ToCv(g.rect_from_left), ToCv(g.P_left),
                              size, CV_16SC2, left_map1_, left_map2_);
  cv::initUndistortRectifyMap(ToCv(rig.right.K), Distortion(rig.right), ToCv(g.rect_from_right),
                              ToCv(g.P_right), size, CV_16SC2, right_map1_, right_map2_);
}

void Rectifier::Rectify(const cv::Mat& left, const cv::Mat& right, cv::Mat* left_out, cv::Mat* right_out) const {
  LN_CHECK(left_out != nullptr && right_out != nullptr);
  for (const cv::Mat* image : {&left, &right}) {
    LN_CHECK_INPUT(image->cols == rig_.width_px && image->rows == rig_.height_px)
        << "image size " << image->cols << "x" << image->rows << " differs from the rig's "
        << rig_.width_px << "x" << rig_.height_px;
  }
  cv::remap(left, *left_out, left_map1_, left_map2_, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar());
  cv::remap(right, *right_out, right_map1_, right_map2_, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar());
}

std::vector<cv::Point2d> Rectifier::RectifyPoints(const std::vector<cv::Point2d>& raw, bool left) const {
  const CameraIntrinsics& c = left ? rig_.left : rig_.right;
  const RectifiedGeometry& g = *rig_.rectified;
  std::vector<cv::Point2d> out;
  if (raw.empty()) return out;
  // Iterate the inverse distortion to convergence, not OpenCV's default 5 fixed-point
  // iterations, so that strongly distorted lenses are inverted too.
  const cv::TermCriteria converged(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-12);
  cv::undistortPoints(raw, out, ToCv(c.K), Distortion(c), ToCv(left ? g.rect_from_left : g.rect_from_right),
                      ToCv(left ? g.P_left : g.P_right), converged);
  return out;
}

}  // namespace lunarnav::calib
