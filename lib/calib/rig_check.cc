#include "calib/rig_check.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <sstream>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "util/check.h"

namespace lunarnav::calib {
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

// One raw camera of the rig at its pose in the vehicle frame.
class PosedCamera {
 public:
  PosedCamera(const CameraIntrinsics& c, const Eigen::Isometry3d& vehicle_from_cam, int width, int height)
      : k_(c.K), cam_from_vehicle_(vehicle_from_cam.inverse()), width_(width), height_(height) {
    for (std::size_t i = 0; i < c.distortion.size() && i < dist_.size(); ++i) dist_[i] = c.distortion[i];
    // The largest normalized radius inside the image, from rays through border pixels: beyond
    // it a distortion polynomial may fold back into the image, so such points are not seen.
    std::vector<cv::Point2d> border, rays;
    for (int i = 0; i <= 64; ++i) {
      const double u = -0.5 + i * width / 64.0, v = -0.5 + i * height / 64.0;
      border.insert(border.end(), {{u, -0.5}, {u, height - 0.5}, {-0.5, v}, {width - 0.5, v}});
    }
    cv::Mat k, d;
    cv::eigen2cv(k_, k);
    if (!c.distortion.empty()) d = cv::Mat(c.distortion, true).reshape(1, 1);
    cv::undistortPoints(border, rays, k, d, cv::noArray(), cv::noArray(),
                        cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-12));
    for (const cv::Point2d& r : rays) max_radius_ = std::max(max_radius_, std::hypot(r.x, r.y));
  }

  // Pixel position of a vehicle-frame point, or nothing when it is not inside the image.
  std::optional<Eigen::Vector2d> Project(const Eigen::Vector3d& point_in_vehicle) const {
    const Eigen::Vector3d p = cam_from_vehicle_ * point_in_vehicle;
    if (p.z() <= 1e-9) return std::nullopt;
    const double x = p.x() / p.z(), y = p.y() / p.z(), r2 = x * x + y * y;
    if (std::sqrt(r2) > max_radius_) return std::nullopt;
    const std::array<double, 8>& d = dist_;
    const double radial =
        (1 + d[0] * r2 + d[1] * r2 * r2 + d[4] * r2 * r2 * r2) / (1 + d[5] * r2 + d[6] * r2 * r2 + d[7] * r2 * r2 * r2);
    const double xd = x * radial + 2 * d[2] * x * y + d[3] * (r2 + 2 * x * x);
    const double yd = y * radial + d[2] * (r2 + 2 * y * y) + 2 * d[3] * x * y;
    const Eigen::Vector2d px(k_(0, 0) * xd + k_(0, 1) * yd + k_(0, 2), k_(1, 1) * yd + k_(1, 2));
    if (px.x() < -0.5 || px.y() < -0.5 || px.x() > width_ - 0.5 || px.y() > height_ - 0.5) return std::nullopt;
    return px;
  }

 private:
  Eigen::Matrix3d k_;
  std::array<double, 8> dist_{};
  Eigen::Isometry3d cam_from_vehicle_;
  int width_, height_;
  double max_radius_ = 0;
};

struct StereoView {
  PosedCamera left, right;
  bool Sees(const Eigen::Vector3d& p) const { return left.Project(p) && right.Project(p); }
};

// Width of the ground line Y = y seen by both cameras: the run of 1 cm steps of X around
// X = 0 (or the longest run when X = 0 is not seen), metres.
double SeenWidthM(const StereoView& view, double y) {
  constexpr double kStep = 0.01, kHalfSpan = 60.0;
  const int n = static_cast<int>(2 * kHalfSpan / kStep) + 1;
  std::vector<char> seen(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) seen[static_cast<std::size_t>(i)] = view.Sees({-kHalfSpan + i * kStep, y, 0.0});
  const int centre = n / 2;
  if (seen[static_cast<std::size_t>(centre)]) {
    int lo = centre, hi = centre;
    while (lo > 0 && seen[static_cast<std::size_t>(lo - 1)]) --lo;
    while (hi < n - 1 && seen[static_cast<std::size_t>(hi + 1)]) ++hi;
    return (hi - lo) * kStep;
  }
  int best = 0, run = 0;
  for (char s : seen) {
    run = s ? run + 1 : 0;
    best = std::max(best, run);
  }
  return best > 0 ? (best - 1) * kStep : 0.0;
}

std::string Number(double value, int precision) {
  if (std::isnan(value)) return "-";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  char text[32];
  std::snprintf(text, sizeof(text), "%.*f", precision, value);
  return text;
}

nlohmann::json JsonNumber(double value) {
  return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(nullptr);
}

}  // namespace

std::string ToString(Gravity gravity) { return gravity == Gravity::kMoon ? "moon" : "earth"; }

Gravity GravityFromString(const std::string& name) {
  if (name == "earth") return Gravity::kEarth;
  if (name == "moon") return Gravity::kMoon;
  throw std::invalid_argument("--gravity: expected earth or moon, got '" + name + "'");
}

double GravityMps2(Gravity gravity) { return gravity == Gravity::kMoon ? 1.625 : 9.80665; }

double StoppingDistanceM(double stop_time_s, double speed_m_s, double sliding_friction, double gravity_m_s2) {
  LN_CHECK_ARG(stop_time_s >= 0 && speed_m_s > 0 && sliding_friction > 0 && gravity_m_s2 > 0)
      << "stopping distance: need t_stop >= 0, v > 0, mu > 0, g > 0";
  return stop_time_s * speed_m_s + speed_m_s * speed_m_s / (2.0 * sliding_friction * gravity_m_s2);
}

double MinCameraHeightOverWheelM(double camera_y_m, double axle_y_m, double wheel_radius_m, double ground_y_m) {
  LN_CHECK_ARG(wheel_radius_m > 0 && camera_y_m < ground_y_m && axle_y_m + wheel_radius_m < ground_y_m)
      << "camera height over the wheels: need a wheel and a camera behind the ground point";
  if (camera_y_m >= axle_y_m + wheel_radius_m) return 0.0;  // the camera is ahead of the wheel
  // Line of sight from (camera_y, h) to (ground_y, 0); the wheel centre (axle_y, r) must lie
  // at least r below it. The clearance grows monotonically with h: bisect.
  const double a = ground_y_m - camera_y_m, b = ground_y_m - axle_y_m, r = wheel_radius_m;
  auto clearance = [&](double h) { return (h * b - a * r) / std::hypot(h, a) - r; };
  double lo = 0.0, hi = 1.0;
  while (clearance(hi) < 0) hi *= 2;
  for (int i = 0; i < 200 && hi - lo > 1e-12; ++i) {
    const double mid = 0.5 * (lo + hi);
    (clearance(mid) < 0 ? lo : hi) = mid;
  }
  return hi;
}

bool RigCheckResult::AllPass() const {
  return std::all_of(items.begin(), items.end(), [](const RigCheckItem& i) { return i.pass; });
}

std::string RigCheckResult::Table() const {
  std::ostringstream s;
  char line[512];
  std::snprintf(line, sizeof(line), "%-58s %9s %4s %8s %-4s %-6s %s\n", "requirement (Krotkov & Hebert sec. 3.1)",
                "value", "", "limit", "unit", "result", "note");
  s << line;
  for (const RigCheckItem& i : items) {
    std::snprintf(line, sizeof(line), "%-58s %9s %4s %8s %-4s %-6s %s\n", i.requirement.c_str(),
                  Number(i.value, 3).c_str(), i.comparison.c_str(), Number(i.limit, 3).c_str(), i.unit.c_str(),
                  i.pass ? "pass" : "FAIL", i.note.c_str());
    s << line;
  }
  s << "stopping distance d_stop = t_stop v + v^2/(2 mu g) = " << Number(stopping_distance_m, 3) << " m (g = "
    << Number(gravity_m_s2, 3) << " m/s^2); lookahead point Y = " << Number(lookahead_y_m, 3) << " m\n";
  s << "ground seen by both cameras on the centre line: Y = " << Number(nearest_seen_y_m, 2) << " to "
    << Number(farthest_seen_y_m, 2) << " m\n";
  s << (AllPass() ? "all requirements pass\n" : "some requirements FAIL\n");
  return s.str();
}

nlohmann::json RigCheckResult::ToJson() const {
  nlohmann::json checks = nlohmann::json::array();
  for (const RigCheckItem& i : items) {
    checks.push_back({{"key", i.key},
                      {"requirement", i.requirement},
                      {"value", JsonNumber(i.value)},
                      {"comparison", i.comparison},
                      {"limit", JsonNumber(i.limit)},
                      {"unit", i.unit},
                      {"pass", i.pass},
                      {"note", i.note}});
  }
  return {{"gravity_m_s2", gravity_m_s2},
          {"stopping_distance_m", stopping_distance_m},
          {"lookahead_y_m", lookahead_y_m},
          {"nearest_seen_y_m", JsonNumber(nearest_seen_y_m)},
          {"farthest_seen_y_m", std::isinf(farthest_seen_y_m) ? nlohmann::json("inf") : JsonNumber(farthest_seen_y_m)},
          {"all_pass", AllPass()},
          {"checks", checks}};
}

RigCheckResult CheckRig(const StereoRig& rig, const VehicleSpec& vehicle, Gravity gravity) {
  rig.Validate("rig");
  vehicle.Validate("vehicle");
  const ImagingRequirements& req = vehicle.requirements;
  const StereoView view{PosedCamera(rig.left, rig.VehicleFromLeft(), rig.width_px, rig.height_px),
                        PosedCamera(rig.right, rig.VehicleFromRight(), rig.width_px, rig.height_px)};
  RigCheckResult result;
  result.gravity_m_s2 = GravityMps2(gravity);
  result.stopping_distance_m =
      StoppingDistanceM(vehicle.stop_time_s, vehicle.max_speed_m_s, vehicle.sliding_friction, result.gravity_m_s2);
  result.lookahead_y_m = vehicle.FrontOfWheelsY() + result.stopping_distance_m;

  // The ground seen on the centre line, in 1 cm steps out to 200 m.
  constexpr double kStep = 0.01, kMaxRange = 200.0;
  for (int i = 0; i * kStep <= kMaxRange; ++i) {
    const double y = i * kStep;
    const bool seen = view.Sees({0.0, y, 0.0});
    if (seen && std::isnan(result.nearest_seen_y_m)) result.nearest_seen_y_m = y;
    if (!seen && !std::isnan(result.nearest_seen_y_m)) {
      result.farthest_seen_y_m = y - kStep;
      break;
    }
  }
  if (!std::isnan(result.nearest_seen_y_m) && std::isnan(result.farthest_seen_y_m)) {
    result.farthest_seen_y_m = kInfinity;  // the view reaches the horizon
  }

  // 1) Lookahead.
  {
    RigCheckItem item;
    item.key = "lookahead";
    item.requirement = "lookahead: ground d_stop ahead of the front wheels seen";
    item.value = result.nearest_seen_y_m;
    item.comparison = "<=";
    item.limit = result.lookahead_y_m;
    item.unit = "m";
    item.pass = view.Sees({0.0, result.lookahead_y_m, 0.0});
    item.note = item.pass ? "nearest ground seen by both cameras (Y)"
                          : "the ground at Y = " + Number(result.lookahead_y_m, 2) + " m is outside an image";
    result.items.push_back(item);
  }
  // 2) Camera height over the front wheels.
  {
    RigCheckItem item;
    item.key = "camera_height";
    item.requirement = "camera height: line of sight clears the wheels";
    item.value = rig.mast.height_m;
    item.comparison = ">=";
    item.limit = MinCameraHeightOverWheelM(rig.mast.forward_offset_m, vehicle.front_axle_y_m,
                                           0.5 * vehicle.wheel_diameter_m, result.lookahead_y_m);
    item.unit = "m";
    item.pass = item.value >= item.limit;
    item.note = "lowest height whose sight line to the lookahead point grazes the wheel";
    result.items.push_back(item);
  }
  // 3) Width of the field of view beyond the lookahead distance (least over the band).
  {
    RigCheckItem item;
    item.key = "fov_width";
    item.requirement = "field of view: width beyond the lookahead distance";
    item.comparison = ">=";
    item.limit = req.fov_vehicle_widths * vehicle.width_m;
    item.unit = "m";
    const double far = std::max(req.far_range_m, result.lookahead_y_m);
    constexpr int kSamples = 24;
    double least = kInfinity, least_y = result.lookahead_y_m;
    for (int i = 0; i <= kSamples; ++i) {
      const double y = result.lookahead_y_m + (far - result.lookahead_y_m) * i / kSamples;
      const double width = SeenWidthM(view, y);
      if (width < least) {
        least = width;
        least_y = y;
      }
    }
    item.value = least;
    item.pass = item.value >= item.limit;
    item.note = "least width seen by both cameras over Y = " + Number(result.lookahead_y_m, 2) + " to " +
                Number(far, 2) + " m, at Y = " + Number(least_y, 2) + " m";
    result.items.push_back(item);
  }
  // 4) Resolution at the far end of the band.
  {
    char text[128];
    std::snprintf(text, sizeof(text), "resolution: %.0f cm obstacle at Y = %.2f m", 100 * req.obstacle_height_m,
                  req.far_range_m);
    RigCheckItem item;
    item.key = "resolution";
    item.requirement = text;
    item.comparison = ">=";
    item.limit = req.obstacle_min_px;
    item.unit = "px";
    double least = kInfinity;
    for (const PosedCamera* cam : {&view.left, &view.right}) {
      const auto foot = cam->Project({0.0, req.far_range_m, 0.0});
      const auto top = cam->Project({0.0, req.far_range_m, req.obstacle_height_m});
      least = foot && top ? std::min(least, (*top - *foot).norm()) : NAN;
      if (std::isnan(least)) break;
    }
    item.value = least;
    item.pass = std::isfinite(least) && least >= item.limit;
    item.note = std::isfinite(least) ? "pixels subtended in the image where it is smaller"
                                     : "the obstacle is not inside both images";
    result.items.push_back(item);
  }
  return result;
}

}  // namespace lunarnav::calib
