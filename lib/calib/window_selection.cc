#include "calib/window_selection.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include <Eigen/LU>

#include "util/check.h"

namespace lunarnav::calib {
namespace {

// Depth bounds of the polytope (see SelectWindow): 1 mm in front of the camera, 10^5 m away.
constexpr double kNearDepthM = 1e-3;
constexpr double kFarDepthM = 1e5;

// A half-space a . q + b >= 0 in the rectified reference camera's frame, a of unit length.
struct HalfSpace {
  Eigen::Vector3d a;
  double b;
};

HalfSpace Normalized(const Eigen::Vector3d& a, double b) {
  const double n = a.norm();
  return {a / n, b / n};
}

}  // namespace

void RegionOfInterest::Validate() const {
  LN_CHECK_ARG(std::isfinite(y_min_m) && std::isfinite(y_max_m) && y_min_m <= y_max_m)
      << "distance interval: need finite Y_min <= Y_max, got " << y_min_m << ":" << y_max_m << " m";
  LN_CHECK_ARG(std::isfinite(z_min_m) && std::isfinite(z_max_m) && z_min_m <= z_max_m)
      << "height range: need finite Z_min <= Z_max, got " << z_min_m << ":" << z_max_m << " m";
}

nlohmann::json RegionOfInterest::ToJson() const {
  return {{"y_m", {y_min_m, y_max_m}}, {"z_m", {z_min_m, z_max_m}}};
}

void WindowSelectionOptions::Validate() const {
  LN_CHECK_ARG(disparity_margin_px >= 0 && disparity_margin_px <= 100)
      << "disparity margin: must be in [0, 100] px, got " << disparity_margin_px;
}

double ImageWindow::RowFraction() const {
  return image_height_px > 0 ? static_cast<double>(Rows()) / image_height_px : 0.0;
}

double ImageWindow::DisparityFraction(int full_min_px, int full_max_px) const {
  const int full = full_max_px - full_min_px + 1;
  return full > 0 ? static_cast<double>(Disparities()) / full : 0.0;
}

nlohmann::json ImageWindow::ToJson() const {
  nlohmann::json j;
  j["visible"] = visible;
  if (!visible) return j;
  j["rows"] = {min_row, max_row};
  j["disparity_px"] = {min_disparity_px, max_disparity_px};
  j["row_extent"] = {row_extent[0], row_extent[1]};
  j["disparity_extent_px"] = {disparity_extent_px[0], disparity_extent_px[1]};
  j["disparity_clipped"] = disparity_clipped;
  j["rows_fraction"] = RowFraction();
  return j;
}

ImageWindow SelectWindow(const StereoRig& rig, const RegionOfInterest& region, ReferenceImage reference,
                         const WindowSelectionOptions& options) {
  LN_CHECK_ARG(rig.rectified.has_value()) << "rig: not rectified (rectify the pair first)";
  region.Validate();
  options.Validate();
  const RectifiedGeometry& g = *rig.rectified;
  const double f = g.P_left(0, 0);
  const double c_left = g.P_left(0, 2), c_right = g.P_right(0, 2), c_y = g.P_left(1, 2);
  const double baseline_m = -g.P_right(0, 3) / f;
  const double c_x = reference == ReferenceImage::kRight ? c_right : c_left;
  const Eigen::Isometry3d vehicle_from_left = rig.VehicleFromLeft();
  const Eigen::Matrix3d vehicle_from_rect = vehicle_from_left.linear() * g.rect_from_left.transpose();
  // The reference camera's centre; the right one sits B along the rectified x axis.
  const Eigen::Vector3d centre =
      vehicle_from_left.translation() +
      (reference == ReferenceImage::kRight ? Eigen::Vector3d(vehicle_from_rect.col(0) * baseline_m)
                                           : Eigen::Vector3d::Zero());
  const Eigen::Vector3d along_y = vehicle_from_rect.row(1).transpose();  // Y = centre.y + along_y . q
  const Eigen::Vector3d along_z = vehicle_from_rect.row(2).transpose();
  const double x_lo = -0.5, x_hi = g.width_px - 0.5, y_lo = -0.5, y_hi = g.height_px - 0.5;

  const std::array<HalfSpace, 10> planes = {
      Normalized(along_y, centre.y() - region.y_min_m),
      Normalized(-along_y, region.y_max_m - centre.y()),
      Normalized(along_z, centre.z() - region.z_min_m),
      Normalized(-along_z, region.z_max_m - centre.z()),
      Normalized(Eigen::Vector3d(f, 0, c_x - x_lo), 0),   // x >= x_lo (with depth > 0)
      Normalized(Eigen::Vector3d(-f, 0, x_hi - c_x), 0),  // x <= x_hi
      Normalized(Eigen::Vector3d(0, f, c_y - y_lo), 0),   // y >= y_lo
      Normalized(Eigen::Vector3d(0, -f, y_hi - c_y), 0),  // y <= y_hi
      Normalized(Eigen::Vector3d(0, 0, 1), -kNearDepthM),
      Normalized(Eigen::Vector3d(0, 0, -1), kFarDepthM)};

  ImageWindow window;
  window.image_width_px = g.width_px;
  window.image_height_px = g.height_px;
  double row_lo = std::numeric_limits<double>::infinity(), row_hi = -row_lo;
  double d_lo = row_lo, d_hi = -row_lo;
  for (std::size_t i = 0; i < planes.size(); ++i) {
    for (std::size_t j = i + 1; j < planes.size(); ++j) {
      for (std::size_t k = j + 1; k < planes.size(); ++k) {
        Eigen::Matrix3d a;
        a << planes[i].a.transpose(), planes[j].a.transpose(), planes[k].a.transpose();
        if (std::abs(a.determinant()) < 1e-12) continue;  // two of the planes are parallel
        const Eigen::Vector3d q = a.partialPivLu().solve(-Eigen::Vector3d(planes[i].b, planes[j].b, planes[k].b));
        const double tolerance = 1e-9 * std::max(1.0, q.norm());
        const bool inside = std::all_of(planes.begin(), planes.end(), [&](const HalfSpace& h) {
          return h.a.dot(q) + h.b >= -tolerance;
        });
        if (!inside) continue;
        const double row = f * q.y() / q.z() + c_y;
        const double d = f * baseline_m / q.z() + (c_left - c_right);
        row_lo = std::min(row_lo, row);
        row_hi = std::max(row_hi, row);
        d_lo = std::min(d_lo, d);
        d_hi = std::max(d_hi, d);
      }
    }
  }
  if (!(row_lo <= row_hi)) return window;  // no vertex: the region is out of sight

  window.visible = true;
  window.row_extent[0] = row_lo;
  window.row_extent[1] = row_hi;
  window.disparity_extent_px[0] = d_lo;
  window.disparity_extent_px[1] = d_hi;
  // Rows: the pixel a point falls in is round(y); outward by a hair against rounding noise.
  constexpr double kHair = 1e-9;
  window.min_row = std::clamp(static_cast<int>(std::ceil(row_lo - 0.5 - kHair)), 0, g.height_px - 1);
  window.max_row = std::clamp(static_cast<int>(std::floor(row_hi + 0.5 + kHair)), 0, g.height_px - 1);
  // Disparities: both integers around each extreme, then the margin; a pixel can only match
  // inside the other image, so |d| <= width - 1.
  const double d_limit = g.width_px - 1;
  window.disparity_clipped = d_hi > d_limit || d_lo < -d_limit;
  const double lo = std::floor(std::max(d_lo, -d_limit) - kHair) - options.disparity_margin_px;
  const double hi = std::ceil(std::min(d_hi, d_limit) + kHair) + options.disparity_margin_px;
  window.min_disparity_px = static_cast<int>(std::max(lo, -d_limit));
  window.max_disparity_px = static_cast<int>(std::min(hi, d_limit));
  return window;
}

}  // namespace lunarnav::calib
