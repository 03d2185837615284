#include "calib/triangulation.h"

#include <cmath>
#include <limits>
#include <stdexcept>

#include "util/check.h"

namespace lunarnav::calib {
namespace {

struct RectifiedCamera {
  double f, c_left, c_right, c_y, baseline_m;
  Eigen::Matrix3d vehicle_from_rect;
  Eigen::Vector3d vehicle_origin;  // the rectified left camera's centre in the vehicle frame
};

RectifiedCamera Unpack(const StereoRig& rig, const cv::Mat& disparity) {
  LN_CHECK_ARG(rig.rectified.has_value()) << "rig: not rectified (rectify the pair first)";
  LN_CHECK_ARG(disparity.type() == CV_32FC1) << "disparity: expected a float32 single-channel map";
  const RectifiedGeometry& g = *rig.rectified;
  LN_CHECK_ARG(disparity.cols == g.width_px && disparity.rows == g.height_px)
      << "disparity: " << disparity.cols << "x" << disparity.rows << " does not match the rectified size "
      << g.width_px << "x" << g.height_px;
  RectifiedCamera c;
  c.f = g.P_left(0, 0);
  c.c_left = g.P_left(0, 2);
  c.c_right = g.P_right(0, 2);
  c.c_y = g.P_left(1, 2);
  c.baseline_m = -g.P_right(0, 3) / c.f;
  const Eigen::Isometry3d vehicle_from_left = rig.VehicleFromLeft();
  c.vehicle_from_rect = vehicle_from_left.linear() * g.rect_from_left.transpose();
  c.vehicle_origin = vehicle_from_left.translation();
  return c;
}

}  // namespace

std::string ToString(ReferenceImage reference) {
  return reference == ReferenceImage::kRight ? "right" : "left";
}

ReferenceImage ReferenceImageFromString(const std::string& name) {
  if (name == "right") return ReferenceImage::kRight;
  if (name == "left") return ReferenceImage::kLeft;
  throw std::invalid_argument("reference: expected 'right' or 'left', got '" + name + "'");
}

cv::Mat TriangulateDisparity(const StereoRig& rig, const cv::Mat& disparity_px, ReferenceImage reference) {
  const RectifiedCamera c = Unpack(rig, disparity_px);
  const bool right = reference == ReferenceImage::kRight;
  const double c_x = right ? c.c_right : c.c_left;
  const double x_offset = right ? c.baseline_m : 0.0;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cv::Mat xyz(disparity_px.size(), CV_32FC3);
  for (int y = 0; y < disparity_px.rows; ++y) {
    const float* d = disparity_px.ptr<float>(y);
    cv::Vec3f* out = xyz.ptr<cv::Vec3f>(y);
    for (int x = 0; x < disparity_px.cols; ++x) {
      const double effective = d[x] - (c.c_left - c.c_right);
      if (!std::isfinite(d[x]) || !(effective > 0)) {
        out[x] = cv::Vec3f(nan, nan, nan);
        continue;
      }
      const double z = c.f * c.baseline_m / effective;
      const Eigen::Vector3d rect((x - c_x) * z / c.f + x_offset, (y - c.c_y) * z / c.f, z);
      const Eigen::Vector3d v = c.vehicle_from_rect * rect + c.vehicle_origin;
      out[x] = cv::Vec3f(static_cast<float>(v.x()), static_cast<float>(v.y()), static_cast<float>(v.z()));
    }
  }
  return xyz;
}

cv::Mat PredictXyzSigma(const StereoRig& rig, const cv::Mat& disparity_px, ReferenceImage reference,
                        double sigma_d_px) {
  LN_CHECK_ARG(std::isfinite(sigma_d_px) && sigma_d_px > 0) << "sigma_d: must be > 0 px";
  const RectifiedCamera c = Unpack(rig, disparity_px);
  const bool right = reference == ReferenceImage::kRight;
  const double c_x = right ? c.c_right : c.c_left;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cv::Mat sigma(disparity_px.size(), CV_32FC3);
  for (int y = 0; y < disparity_px.rows; ++y) {
    const float* d = disparity_px.ptr<float>(y);
    cv::Vec3f* out = sigma.ptr<cv::Vec3f>(y);
    for (int x = 0; x < disparity_px.cols; ++x) {
      const double effective = d[x] - (c.c_left - c.c_right);
      if (!std::isfinite(d[x]) || !(effective > 0)) {
        out[x] = cv::Vec3f(nan, nan, nan);
        continue;
      }
      const double z = c.f * c.baseline_m / effective;
      // P - C_ref in the rectified frame is z (u, v, 1); dP/dd = -(z / (f B)) (P - C_ref).
      const Eigen::Vector3d ray((x - c_x) / c.f, (y - c.c_y) / c.f, 1.0);
      const Eigen::Vector3d derivative = -(z * z / (c.f * c.baseline_m)) * ray;
      const Eigen::Vector3d v = (c.vehicle_from_rect * derivative).cwiseAbs() * sigma_d_px;
      out[x] = cv::Vec3f(static_cast<float>(v.x()), static_cast<float>(v.y()), static_cast<float>(v.z()));
    }
  }
  return sigma;
}

}  // namespace lunarnav::calib
