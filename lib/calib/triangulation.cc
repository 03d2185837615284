#include "calib/triangulation.h"

#include <algorithm>
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

RectifiedCamera Unpack(const StereoRig& rig) {
  LN_CHECK_ARG(rig.rectified.has_value()) << "rig: not rectified (rectify the pair first)";
  const RectifiedGeometry& g = *rig.rectified;
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

RectifiedCamera Unpack(const StereoRig& rig, const cv::Mat& disparity) {
  const RectifiedCamera c = Unpack(rig);
  LN_CHECK_ARG(disparity.type() == CV_32FC1) << "disparity: expected a float32 single-channel map";
  const RectifiedGeometry& g = *rig.rectified;
  LN_CHECK_ARG(disparity.cols == g.width_px && disparity.rows == g.height_px)
      << "disparity: " << disparity.cols << "x" << disparity.rows << " does not match the rectified size "
      << g.width_px << "x" << g.height_px;
  return c;
}

// Where the reference camera's rays start, in the vehicle frame: a right-referenced ray starts
// at the right camera, B along the rectified x axis.
Eigen::Vector3d RayStart(const RectifiedCamera& c, ReferenceImage reference) {
  return c.vehicle_from_rect * Eigen::Vector3d(reference == ReferenceImage::kRight ? c.baseline_m : 0.0, 0, 0) +
         c.vehicle_origin;
}

// For each pixel with a finite disparity in front of the rig, the depth z and the reference
// camera's rectified ray (u, v, 1) turned into the vehicle frame go to `per_point`, whose
// result fills the CV_32FC3 map; elsewhere NaN. The ray's turn is a row's constant plus the
// column's share (the fusion reads every pixel of every pair through here).
template <typename PerPoint>
cv::Mat MapPoints(const RectifiedCamera& c, const cv::Mat& disparity_px, ReferenceImage reference,
                  const PerPoint& per_point) {
  const double c_x = reference == ReferenceImage::kRight ? c.c_right : c.c_left;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const double offset = c.c_left - c.c_right, fb = c.f * c.baseline_m;
  const Eigen::Vector3d per_column = c.vehicle_from_rect.col(0) / c.f;
  cv::Mat out(disparity_px.size(), CV_32FC3);
  for (int y = 0; y < disparity_px.rows; ++y) {
    const float* d = disparity_px.ptr<float>(y);
    cv::Vec3f* row = out.ptr<cv::Vec3f>(y);
    if (std::none_of(d, d + disparity_px.cols, [](float v) { return std::isfinite(v); })) {
      std::fill(row, row + disparity_px.cols, cv::Vec3f(nan, nan, nan));  // a row outside the search
      continue;
    }
    const Eigen::Vector3d row_ray =
        c.vehicle_from_rect.col(1) * ((y - c.c_y) / c.f) + c.vehicle_from_rect.col(2) - c_x * per_column;
    for (int x = 0; x < disparity_px.cols; ++x) {
      const double effective = d[x] - offset;
      if (!(effective > 0) || !std::isfinite(d[x])) {
        row[x] = cv::Vec3f(nan, nan, nan);
        continue;
      }
      const Eigen::Vector3d v = per_point(fb / effective, row_ray + x * per_column);
      row[x] = cv::Vec3f(static_cast<float>(v.x()), static_cast<float>(v.y()), static_cast<float>(v.z()));
    }
  }
  return out;
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
  const Eigen::Vector3d start = RayStart(c, reference);
  return MapPoints(c, disparity_px, reference,
                   [&](double z, const Eigen::Vector3d& ray) -> Eigen::Vector3d { return start + z * ray; });
}

cv::Mat PredictXyzSigma(const StereoRig& rig, const cv::Mat& disparity_px, ReferenceImage reference,
                        double sigma_d_px) {
  LN_CHECK_ARG(std::isfinite(sigma_d_px) && sigma_d_px > 0) << "sigma_d: must be > 0 px";
  const RectifiedCamera c = Unpack(rig, disparity_px);
  // P - C_ref = z (u, v, 1) in the rectified frame, so dP/dd = -(z^2 / (f B)) (u, v, 1).
  return MapPoints(c, disparity_px, reference, [&](double z, const Eigen::Vector3d& ray) -> Eigen::Vector3d {
    return ray.cwiseAbs() * (z * z / (c.f * c.baseline_m) * sigma_d_px);
  });
}

RectifiedProjection ProjectToRectified(const StereoRig& rig, const Eigen::Vector3d& point_vehicle,
                                       ReferenceImage reference) {
  LN_CHECK_ARG(rig.rectified.has_value()) << "rig: not rectified (rectify the pair first)";
  const RectifiedGeometry& g = *rig.rectified;
  const Eigen::Vector3d in_rect = g.rect_from_left * (rig.VehicleFromLeft().inverse() * point_vehicle);
  const Eigen::Vector3d l = g.P_left * in_rect.homogeneous(), r = g.P_right * in_rect.homogeneous();
  RectifiedProjection p;
  p.depth_m = in_rect.z();
  p.x_px = reference == ReferenceImage::kRight ? r.x() / r.z() : l.x() / l.z();
  p.y_px = l.y() / l.z();
  p.disparity_px = l.x() / l.z() - r.x() / r.z();
  return p;
}

Eigen::Vector3d PredictPointSigma(const StereoRig& rig, const Eigen::Vector3d& point_vehicle,
                                  ReferenceImage reference, double sigma_d_px) {
  LN_CHECK_ARG(std::isfinite(sigma_d_px) && sigma_d_px > 0) << "sigma_d: must be > 0 px";
  const RectifiedProjection p = ProjectToRectified(rig, point_vehicle, reference);
  LN_CHECK_ARG(p.depth_m > 0) << "point: behind the cameras";
  const RectifiedCamera c = Unpack(rig);
  // dP/dd = -(z / (f B)) (P - C_ref), C_ref the reference camera's centre.
  return ((p.depth_m / (c.f * c.baseline_m)) * (point_vehicle - RayStart(c, reference))).cwiseAbs() * sigma_d_px;
}

std::vector<float> GroundDisparityByRow(const StereoRig& rig, ReferenceImage reference) {
  const RectifiedCamera c = Unpack(rig);
  const double c_ref = reference == ReferenceImage::kRight ? c.c_right : c.c_left;
  const double start_z = RayStart(c, reference).z();
  const double x0 = 0.5 * (rig.rectified->width_px - 1);
  std::vector<float> out(rig.rectified->height_px, std::numeric_limits<float>::quiet_NaN());
  for (int y = 0; y < rig.rectified->height_px; ++y) {
    // The ray (u, v, 1) of depth 1 in the rectified frame, in the vehicle frame.
    const Eigen::Vector3d dir = c.vehicle_from_rect * Eigen::Vector3d((x0 - c_ref) / c.f, (y - c.c_y) / c.f, 1.0);
    if (!(dir.z() < 0)) continue;           // at or above the horizon
    const double depth = -start_z / dir.z();  // where it meets Z = 0
    if (!(depth > 0)) continue;             // a head below the ground
    out[y] = static_cast<float>(c.f * c.baseline_m / depth + (c.c_left - c.c_right));
  }
  return out;
}

}  // namespace lunarnav::calib
