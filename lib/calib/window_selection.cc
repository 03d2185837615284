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

// The reference camera's rectified geometry in the vehicle frame: a point at rectified-frame
// coordinates q (depth q.z) lies at centre + R q (R: vehicle from rectified); its Y and Z are
// centre.y + along_y . q and centre.z + along_z . q; its disparity f B / q.z + (c_left - c_right).
struct ReferenceGeometry {
  double f, c_left, c_right, c_x, c_y, baseline_m;
  Eigen::Vector3d centre, along_y, along_z;
  ReferenceGeometry(const StereoRig& rig, ReferenceImage reference, const WindowSelectionOptions& selection) {
    const RectifiedGeometry& g = *rig.rectified;
    f = g.P_left(0, 0);
    c_left = g.P_left(0, 2);
    c_right = g.P_right(0, 2);
    c_y = g.P_left(1, 2);
    baseline_m = -g.P_right(0, 3) / f;
    c_x = reference == ReferenceImage::kRight ? c_right : c_left;
    // "Vehicle" below is the frame the region is given in: the level frame when the vehicle's
    // attitude is given (rotated about the mast base), else the vehicle's own.
    Eigen::Isometry3d level_from_vehicle = Eigen::Isometry3d::Identity();
    level_from_vehicle.linear() = selection.LevelFromVehicle();
    const Eigen::Isometry3d vehicle_from_left = level_from_vehicle * rig.VehicleFromLeft();
    const Eigen::Matrix3d vehicle_from_rect = vehicle_from_left.linear() * g.rect_from_left.transpose();
    // The right camera sits B along the rectified x axis.
    centre = vehicle_from_left.translation() +
             (reference == ReferenceImage::kRight ? Eigen::Vector3d(vehicle_from_rect.col(0) * baseline_m)
                                                  : Eigen::Vector3d::Zero());
    along_y = vehicle_from_rect.row(1).transpose();
    along_z = vehicle_from_rect.row(2).transpose();
  }
};

}  // namespace

void RegionOfInterest::Validate() const {
  // Within 1000 m (as far as a request reaches): 1e300 m came out as an empty disparity band,
  // reported as the band's, not as the option's.
  constexpr double kFar = 1000.0;
  LN_CHECK_ARG(std::isfinite(y_min_m) && std::isfinite(y_max_m) && y_min_m <= y_max_m)
      << "distance interval: need finite Y_min <= Y_max, got " << y_min_m << ":" << y_max_m << " m";
  LN_CHECK_ARG(std::abs(y_min_m) <= kFar && std::abs(y_max_m) <= kFar)
      << "distance interval: " << y_min_m << ":" << y_max_m << " m reaches beyond " << kFar << " m";
  LN_CHECK_ARG(std::isfinite(z_min_m) && std::isfinite(z_max_m) && z_min_m <= z_max_m)
      << "height range: need finite Z_min <= Z_max, got " << z_min_m << ":" << z_max_m << " m";
  LN_CHECK_ARG(std::abs(z_min_m) <= kFar && std::abs(z_max_m) <= kFar)
      << "height range (--z-range): " << z_min_m << ":" << z_max_m << " m reaches beyond " << kFar << " m";
}

nlohmann::json RegionOfInterest::ToJson() const {
  return {{"y_m", {y_min_m, y_max_m}}, {"z_m", {z_min_m, z_max_m}}};
}

Eigen::Matrix3d WindowSelectionOptions::LevelFromVehicle() const {
  constexpr double kRad = M_PI / 180.0;
  return (Eigen::AngleAxisd(vehicle_pitch_deg * kRad, Eigen::Vector3d::UnitX()) *
          Eigen::AngleAxisd(vehicle_roll_deg * kRad, Eigen::Vector3d::UnitY()))
      .toRotationMatrix();
}

void WindowSelectionOptions::Validate() const {
  LN_CHECK_ARG(disparity_margin_px >= 0 && disparity_margin_px <= 100)
      << "disparity margin: must be in [0, 100] px, got " << disparity_margin_px;
  LN_CHECK_ARG(std::abs(vehicle_pitch_deg) < 90 && std::abs(vehicle_roll_deg) < 90)
      << "vehicle attitude: pitch and roll must be in (-90, 90) deg, got " << vehicle_pitch_deg << ", "
      << vehicle_roll_deg;
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
  const ReferenceGeometry geo(rig, reference, options);
  const double f = geo.f, c_left = geo.c_left, c_right = geo.c_right, c_x = geo.c_x, c_y = geo.c_y;
  const double baseline_m = geo.baseline_m;
  const Eigen::Vector3d &centre = geo.centre, &along_y = geo.along_y, &along_z = geo.along_z;
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

void GroundWindowOptions::Validate() const {
  LN_CHECK_ARG(std::isfinite(z_min_m) && std::isfinite(z_max_m) && z_min_m <= z_max_m)
      << "z-range: need finite ZMIN <= ZMAX, got " << z_min_m << ":" << z_max_m << " m";
  LN_CHECK_ARG(std::isfinite(max_range_error_m) && max_range_error_m > 0)
      << "far limit: the range error bound must be > 0 m, got " << max_range_error_m;
  LN_CHECK_ARG(std::isfinite(sigma_d_px) && sigma_d_px > 0) << "far limit: sigma_d must be > 0 px";
  LN_CHECK_ARG(std::isfinite(guard_distance_factor) && guard_distance_factor >= 1)
      << "far guard: the distance factor must be >= 1, got " << guard_distance_factor;
  LN_CHECK_ARG(guard_tilt_deg >= 0 && guard_tilt_deg < 45) << "far guard: the tilt must be in [0, 45) deg, got "
                                                           << guard_tilt_deg;
  LN_CHECK_ARG(tall_guard_m >= 0 && tall_guard_m <= 100) << "tall guard: must be in [0, 100] m, got " << tall_guard_m;
}

nlohmann::json GroundWindow::ToJson() const {
  int rows = 0, widest = 0;
  long searched = 0;
  for (const auto& [lo, hi] : row_disparity_px) {
    if (hi < lo) continue;
    ++rows;
    widest = std::max(widest, hi - lo + 1);
    searched += hi - lo + 1;
  }
  return {{"region", region.ToJson()},
          {"far_limit_depth_m", far_limit_depth_m},
          {"guard_y_max_m", guard_y_max_m},
          {"guard_tilt_deg", guard_tilt_deg},
          {"guard_min_disparity_px", guard_min_disparity_px},
          {"tall_guard_m", options.tall_guard_m},
          {"guard_max_disparity_px", guard_max_disparity_px},
          {"window", window.ToJson()},
          {"rows_with_points", rows},
          {"row_band_widest_px", widest},
          {"row_band_mean_px", rows > 0 ? static_cast<double>(searched) / rows : 0.0}};
}

RowBands SelectRowBands(const StereoRig& rig, ReferenceImage reference, const RegionOfInterest& region,
                        const ImageWindow& window, double guard_distance_factor, double guard_tilt_deg,
                        double near_guard_factor, const WindowSelectionOptions& selection, double tall_guard_m) {
  LN_CHECK_ARG(rig.rectified.has_value()) << "rig: not rectified (rectify the pair first)";
  LN_CHECK_ARG(std::isfinite(guard_distance_factor) && guard_distance_factor >= 1)
      << "far guard: the distance factor must be >= 1, got " << guard_distance_factor;
  LN_CHECK_ARG(guard_tilt_deg >= 0 && guard_tilt_deg < 45) << "far guard: the tilt must be in [0, 45) deg, got "
                                                           << guard_tilt_deg;
  LN_CHECK_ARG(std::isfinite(near_guard_factor) && near_guard_factor >= 1)
      << "near guard: the distance factor must be >= 1, got " << near_guard_factor;
  LN_CHECK_ARG(tall_guard_m >= 0 && tall_guard_m <= 100) << "tall guard: must be in [0, 100] m, got " << tall_guard_m;
  selection.Validate();
  const RectifiedGeometry& g = *rig.rectified;
  const ReferenceGeometry geo(rig, reference, selection);
  const double f = geo.f, c_x = geo.c_x, c_y = geo.c_y;
  const Eigen::Vector3d &centre = geo.centre, &along_y = geo.along_y, &along_z = geo.along_z;
  const double fb = f * geo.baseline_m, dc = geo.c_left - geo.c_right;
  const double width = g.width_px;
  auto ray = [&](double x, double y) { return Eigen::Vector3d((x - c_x) / f, (y - c_y) / f, 1.0); };
  RowBands out;
  // Per row: each column's ray crosses the slab (Y and Z within the region, depth > 0) along
  // a segment of depths [t0, t1]; disparity falls with depth. The guard: the same slab out
  // to guard_y_max_m.
  out.guard_y_max_m = centre.y() + (region.y_max_m - centre.y()) * guard_distance_factor;
  const double tan_tilt = std::tan(guard_tilt_deg * M_PI / 180.0);
  out.row_disparity_px.assign(g.height_px, {0, -1});
  out.row_accept_min_px.assign(g.height_px, 0);
  out.row_accept_max_px.assign(g.height_px, 0);
  // The near guard: the same heights from y_min_m / near_guard_factor.
  const double y_near = centre.y() + (region.y_min_m - centre.y()) / near_guard_factor;
  const double d_limit = width - 1;
  constexpr double kHair = 1e-9;
  auto floor_px = [&](double d) {
    return static_cast<int>(std::floor(std::max(d, -d_limit) - kHair)) - selection.disparity_margin_px;
  };
  int guard_min = window.min_disparity_px, guard_max = window.max_disparity_px;
  for (int y = 0; y < g.height_px; ++y) {
    double d_lo = std::numeric_limits<double>::infinity(), d_hi = -d_lo, d_guard = d_lo, d_near = d_hi;
    double d_tall = d_hi;
    for (int x = 0; x < g.width_px; ++x) {
      const Eigen::Vector3d u = ray(x, y);
      // The depths along the ray within [lo, hi] of base + t rate, intersected into [t0, t1].
      auto clip = [](double base, double rate, double lo, double hi, double* t0, double* t1) {
        if (std::abs(rate) < 1e-15) {
          if (base < lo || base > hi) *t1 = -1;
          return;
        }
        double a = (lo - base) / rate, b = (hi - base) / rate;
        if (a > b) std::swap(a, b);
        *t0 = std::max(*t0, a);
        *t1 = std::min(*t1, b);
      };
      double t0 = 1e-3, t1 = 1e5, g0 = 1e-3, g1 = 1e5, n0 = 1e-3, n1 = 1e5;
      clip(centre.y(), along_y.dot(u), region.y_min_m, region.y_max_m, &t0, &t1);
      clip(centre.z(), along_z.dot(u), region.z_min_m, region.z_max_m, &t0, &t1);
      if (!(t0 <= t1)) continue;
      d_lo = std::min(d_lo, fb / t1 + dc);
      d_hi = std::max(d_hi, fb / t0 + dc);
      clip(centre.y(), along_y.dot(u), region.y_min_m, out.guard_y_max_m, &g0, &g1);
      clip(centre.z(), along_z.dot(u), -std::numeric_limits<double>::infinity(), region.z_max_m, &g0, &g1);
      // The guard's floor sinks below the region's by tan(guard_tilt) per metre of Y: Z +
      // tan_tilt Y >= z_min, linear along the ray.
      clip(centre.z() + tan_tilt * centre.y(), along_z.dot(u) + tan_tilt * along_y.dot(u), region.z_min_m,
           std::numeric_limits<double>::infinity(), &g0, &g1);
      d_guard = std::min(d_guard, fb / g1 + dc);
      clip(centre.y(), along_y.dot(u), y_near, region.y_max_m, &n0, &n1);
      clip(centre.z(), along_z.dot(u), region.z_min_m, region.z_max_m, &n0, &n1);
      if (n0 <= n1) d_near = std::max(d_near, fb / n0 + dc);
      if (tall_guard_m > 0) {  // the tall guard: the heights above the region at its distances
        double a0 = 1e-3, a1 = 1e5;
        clip(centre.y(), along_y.dot(u), region.y_min_m, region.y_max_m, &a0, &a1);
        clip(centre.z(), along_z.dot(u), region.z_max_m, region.z_max_m + tall_guard_m, &a0, &a1);
        if (a0 <= a1) d_tall = std::max(d_tall, fb / a0 + dc);
      }
    }
    if (!(d_lo <= d_hi)) continue;
    const int lo = std::max(floor_px(d_lo), window.min_disparity_px);
    const int hi = static_cast<int>(std::ceil(std::min(d_hi, d_limit) + kHair)) + selection.disparity_margin_px;
    const int guard = std::min(lo, std::max(floor_px(d_guard), static_cast<int>(-d_limit)));
    const int accept_max = std::min(hi, window.max_disparity_px);
    const int near =
        near_guard_factor > 1
            ? std::max(accept_max, static_cast<int>(std::ceil(std::min(d_near, d_limit) + kHair)) +
                                       selection.disparity_margin_px)
            : accept_max;
    const int tall = std::isfinite(d_tall) ? static_cast<int>(std::ceil(std::min(d_tall, d_limit) + kHair)) +
                                                 selection.disparity_margin_px
                                           : near;
    out.row_disparity_px[y] = {guard, std::max(near, tall)};
    guard_max = std::max(guard_max, tall);
    out.row_accept_min_px[y] = lo;
    out.row_accept_max_px[y] = accept_max;
    guard_max = std::max(guard_max, near);
    guard_min = std::min(guard_min, guard);
  }
  out.guard_min_disparity_px = guard_min;
  out.guard_max_disparity_px = guard_max;
  // A row of the window whose pixel centres' rays miss the region (the window's rows are
  // rounded outward) takes the band of the nearest row that has one.
  for (int pass = 0; pass < 2; ++pass) {
    const int step = pass == 0 ? 1 : -1;
    const int begin = pass == 0 ? window.min_row : window.max_row;
    const int end = pass == 0 ? window.max_row + 1 : window.min_row - 1;
    std::pair<int, int> last{0, -1};
    int last_accept = 0, last_accept_max = 0;
    for (int y = begin; window.visible && y != end; y += step) {
      auto& band = out.row_disparity_px[y];
      if (band.first <= band.second) {
        last = band;
        last_accept = out.row_accept_min_px[y];
        last_accept_max = out.row_accept_max_px[y];
      } else if (last.first <= last.second) {
        band = last;
        out.row_accept_min_px[y] = last_accept;
        out.row_accept_max_px[y] = last_accept_max;
      }
    }
  }
  return out;
}

GroundWindow SelectGroundWindow(const StereoRig& rig, ReferenceImage reference, const GroundWindowOptions& options,
                                const WindowSelectionOptions& selection) {
  LN_CHECK_ARG(rig.rectified.has_value()) << "rig: not rectified (rectify the pair first)";
  options.Validate();
  selection.Validate();
  const RectifiedGeometry& g = *rig.rectified;
  const ReferenceGeometry geo(rig, reference, selection);
  const double f = geo.f, c_left = geo.c_left, c_right = geo.c_right, c_x = geo.c_x, c_y = geo.c_y;
  const double baseline_m = geo.baseline_m;
  const Eigen::Vector3d &centre = geo.centre, &along_y = geo.along_y, &along_z = geo.along_z;
  const double fb = f * baseline_m, dc = c_left - c_right;
  LN_CHECK_ARG(fb > 0) << "rig: the rectified baseline must be positive";
  const double width = g.width_px;
  // Farther than this depth, a disparity error of sigma_d moves a point by more than the bound.
  const double far_depth = std::sqrt(options.max_range_error_m * fb / options.sigma_d_px);

  GroundWindow out;
  out.options = options;
  out.far_limit_depth_m = far_depth;
  // The ground Z = 0 on each pixel's ray: the nearest point both images hold, and the farthest
  // within the far limit.
  double y_near = std::numeric_limits<double>::infinity(), y_far = -y_near;
  auto ray = [&](double x, double y) {
    return Eigen::Vector3d((x - c_x) / f, (y - c_y) / f, 1.0);
  };
  for (int y = 0; y < g.height_px; ++y) {
    for (int x = 0; x < g.width_px; ++x) {
      const Eigen::Vector3d u = ray(x, y);
      const double dz = along_z.dot(u);  // Z = centre.z + depth dz
      if (!(dz < 0)) continue;           // the ray does not come down to the ground
      const double depth = -centre.z() / dz;
      if (!(depth > 0) || depth > far_depth) continue;
      const double d = fb / depth + dc;
      const double other = reference == ReferenceImage::kRight ? x + d : x - d;
      if (other < 0 || other > width - 1) continue;
      const double ground_y = centre.y() + depth * along_y.dot(u);
      y_near = std::min(y_near, ground_y);
      y_far = std::max(y_far, ground_y);
    }
  }
  LN_CHECK_ARG(y_near <= y_far) << "rig: neither camera sees the ground (Z = 0 in the vehicle frame) within "
                                << far_depth << " m of depth; give --disparity or --range-y";
  out.region.y_min_m = y_near;
  out.region.y_max_m = y_far;
  out.region.z_min_m = options.z_min_m;
  out.region.z_max_m = options.z_max_m;
  out.window = SelectWindow(rig, out.region, reference, selection);

  const RowBands bands = SelectRowBands(rig, reference, out.region, out.window, options.guard_distance_factor,
                                        options.guard_tilt_deg, 1.0, selection, options.tall_guard_m);
  out.guard_y_max_m = bands.guard_y_max_m;
  out.guard_distance_factor = options.guard_distance_factor;
  out.guard_tilt_deg = options.guard_tilt_deg;
  out.row_disparity_px = bands.row_disparity_px;
  out.row_accept_min_px = bands.row_accept_min_px;
  if (options.tall_guard_m > 0) out.row_accept_max_px = bands.row_accept_max_px;
  out.guard_min_disparity_px = bands.guard_min_disparity_px;
  out.guard_max_disparity_px = bands.guard_max_disparity_px;
  return out;
}

}  // namespace lunarnav::calib
