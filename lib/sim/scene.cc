#include "sim/scene.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "sim/random.h"
#include "util/check.h"

namespace lunarnav::sim {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kBoxTextureFinestM = 0.01;
constexpr int kBoxTextureOctaves = 7;  // 1 cm to 64 cm

// Slab test: the entry t of the ray into the box within [t_min, t_max] and the entry face.
bool IntersectBox(const Box& box, const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min, double t_max,
                  double* t_hit, int* face) {
  double enter = -std::numeric_limits<double>::infinity(), leave = std::numeric_limits<double>::infinity();
  int enter_face = -1;
  for (int k = 0; k < 3; ++k) {
    if (d[k] == 0) {
      if (o[k] < box.min_m[k] || o[k] > box.max_m[k]) return false;
      continue;
    }
    const double ta = (box.min_m[k] - o[k]) / d[k], tb = (box.max_m[k] - o[k]) / d[k];
    const double near = std::min(ta, tb), far = std::max(ta, tb);
    if (near > enter) {
      enter = near;
      enter_face = 2 * k + (d[k] < 0 ? 1 : 0);
    }
    leave = std::min(leave, far);
  }
  if (enter > leave || leave < t_min || enter > t_max) return false;
  *t_hit = std::max(enter, t_min);
  *face = enter_face;
  return true;
}

}  // namespace

nlohmann::json ShadingOptions::ToJson() const {
  return {{"enabled", enabled},
          {"sun_elevation_deg", sun_elevation_deg},
          {"sun_azimuth_deg", sun_azimuth_deg},
          {"ambient", ambient},
          {"sky_radiance", sky_radiance}};
}

void SceneOptions::Validate() const {
  terrain.Validate();
  LN_CHECK_ARG(shading.sun_elevation_deg > 0 && shading.sun_elevation_deg <= 90)
      << "sun elevation: must be in (0, 90] deg";
  LN_CHECK_ARG(std::isfinite(shading.sun_azimuth_deg)) << "sun azimuth: not finite";
  LN_CHECK_ARG(shading.ambient >= 0 && shading.ambient <= 1) << "ambient: must be in [0, 1]";
  LN_CHECK_ARG(shading.sky_radiance >= 0 && shading.sky_radiance <= 1) << "sky radiance: must be in [0, 1]";
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    const Box& b = boxes[i];
    LN_CHECK_ARG(b.min_m.allFinite() && b.max_m.allFinite() && (b.min_m.array() < b.max_m.array()).all())
        << "box " << i << ": need min < max on every axis";
    LN_CHECK_ARG(b.albedo_mean > 0 && b.albedo_mean <= 1 && b.albedo_sigma >= 0 && b.albedo_sigma <= 1)
        << "box " << i << ": albedo mean in (0, 1], sigma in [0, 1]";
  }
}

nlohmann::json SceneOptions::ToJson() const {
  nlohmann::json boxes_json = nlohmann::json::array();
  for (const Box& b : boxes) {
    boxes_json.push_back({{"min_m", {b.min_m.x(), b.min_m.y(), b.min_m.z()}},
                          {"max_m", {b.max_m.x(), b.max_m.y(), b.max_m.z()}},
                          {"texture_seed", b.texture_seed},
                          {"albedo_mean", b.albedo_mean},
                          {"albedo_sigma", b.albedo_sigma}});
  }
  return {{"terrain", terrain.ToJson()}, {"boxes", boxes_json}, {"shading", shading.ToJson()}};
}

Scene::Scene(const SceneOptions& options) : options_(options), terrain_((options.Validate(), options.terrain)) {
  const double el = options_.shading.sun_elevation_deg * kDeg, az = options_.shading.sun_azimuth_deg * kDeg;
  sun_ = Eigen::Vector3d(std::sin(az) * std::cos(el), std::cos(az) * std::cos(el), std::sin(el));
  const double a = options_.shading.ambient;
  shading_norm_ = 1.0 / (a + (1 - a) * sun_.z());
}

SurfaceHit Scene::Trace(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double t_min,
                        double t_max) const {
  SurfaceHit hit;
  double t_best = t_max;
  for (std::size_t i = 0; i < options_.boxes.size(); ++i) {
    double t = 0;
    int face = -1;
    if (IntersectBox(options_.boxes[i], origin, direction, t_min, t_best, &t, &face) && t <= t_best) {
      t_best = t;
      hit.label = SurfaceHit::kFirstBox + static_cast<int>(i);
      hit.face = face;
    }
  }
  if (const std::optional<double> t = terrain_.Intersect(origin, direction, t_min, t_best)) {
    if (hit.label == SurfaceHit::kSky || *t < t_best) {
      t_best = *t;
      hit.label = SurfaceHit::kTerrain;
      hit.face = -1;
    }
  }
  if (hit.label == SurfaceHit::kSky) return hit;
  hit.t = t_best;
  hit.point = origin + t_best * direction;
  if (hit.label == SurfaceHit::kTerrain) {
    hit.normal = terrain_.NormalAt(hit.point.x(), hit.point.y());
  } else {
    hit.normal = Eigen::Vector3d::Zero();
    hit.normal[hit.face / 2] = hit.face % 2 == 1 ? 1.0 : -1.0;
  }
  return hit;
}

bool Scene::Occluded(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double t_min,
                     double t_max) const {
  for (const Box& box : options_.boxes) {
    double t = 0;
    int face = -1;
    if (IntersectBox(box, origin, direction, t_min, t_max, &t, &face)) return true;
  }
  return terrain_.Intersect(origin, direction, t_min, t_max).has_value();
}

double Scene::Radiance(const SurfaceHit& hit, double footprint_m) const {
  if (hit.label == SurfaceHit::kSky) return options_.shading.sky_radiance;
  double albedo = 0;
  if (hit.label == SurfaceHit::kTerrain) {
    albedo = terrain_.AlbedoAt(hit.point.x(), hit.point.y(), footprint_m);
  } else {
    const Box& box = options_.boxes[hit.label - SurfaceHit::kFirstBox];
    const int axis = hit.face / 2;
    const int a = axis == 0 ? 1 : 0, b = axis == 2 ? 1 : 2;  // the face's own two axes
    const double n = FractalNoise2(hit.point[a], hit.point[b], box.texture_seed * 8 + hit.face, kBoxTextureFinestM,
                                   kBoxTextureOctaves, footprint_m);
    albedo = std::clamp(box.albedo_mean + box.albedo_sigma * n, 0.02, 1.0);
  }
  if (!options_.shading.enabled) return albedo;
  const double a = options_.shading.ambient;
  return albedo * (a + (1 - a) * std::max(0.0, hit.normal.dot(sun_))) * shading_norm_;
}

nlohmann::json BoxTruth::ToJson() const {
  return {{"index", index},     {"front_y_m", front_y_m}, {"x_min_m", x_min_m},
          {"x_max_m", x_max_m}, {"z_min_m", z_min_m},     {"z_max_m", z_max_m}};
}

std::vector<BoxTruth> BoxTruthInVehicle(const Scene& scene, const VehiclePose& pose) {
  const Eigen::Isometry3d vehicle_from_world = pose.WorldFromVehicle().inverse();
  std::vector<BoxTruth> out;
  for (std::size_t i = 0; i < scene.boxes().size(); ++i) {
    const Box& b = scene.boxes()[i];
    BoxTruth t;
    t.index = static_cast<int>(i);
    t.x_min_m = t.z_min_m = std::numeric_limits<double>::infinity();
    t.x_max_m = t.z_max_m = -std::numeric_limits<double>::infinity();
    double y_sum = 0;
    for (const double x : {b.min_m.x(), b.max_m.x()}) {
      for (const double z : {b.min_m.z(), b.max_m.z()}) {
        const Eigen::Vector3d p = vehicle_from_world * Eigen::Vector3d(x, b.min_m.y(), z);
        y_sum += p.y();
        t.x_min_m = std::min(t.x_min_m, p.x());
        t.x_max_m = std::max(t.x_max_m, p.x());
        t.z_min_m = std::min(t.z_min_m, p.z());
        t.z_max_m = std::max(t.z_max_m, p.z());
      }
    }
    t.front_y_m = y_sum / 4;
    out.push_back(t);
  }
  return out;
}

Box BoxOnTerrain(const Terrain& terrain, double centre_x_m, double front_y_m, double width_m, double depth_m,
                 double height_m, std::uint64_t texture_seed) {
  LN_CHECK_ARG(width_m > 0 && depth_m > 0 && height_m > 0) << "box: sizes must be positive";
  double lowest = std::numeric_limits<double>::infinity();
  const double step = terrain.options().cell_m;
  for (double y = front_y_m; y <= front_y_m + depth_m + 0.5 * step; y += step) {
    for (double x = centre_x_m - 0.5 * width_m; x <= centre_x_m + 0.5 * width_m + 0.5 * step; x += step) {
      const double h = terrain.HeightAt(std::min(x, centre_x_m + 0.5 * width_m), std::min(y, front_y_m + depth_m));
      LN_CHECK_ARG(std::isfinite(h)) << "box at x " << centre_x_m << ", y " << front_y_m << ": off the terrain grid";
      lowest = std::min(lowest, h);
    }
  }
  Box box;
  box.min_m = Eigen::Vector3d(centre_x_m - 0.5 * width_m, front_y_m, lowest);
  box.max_m = Eigen::Vector3d(centre_x_m + 0.5 * width_m, front_y_m + depth_m, lowest + height_m);
  box.texture_seed = texture_seed;
  return box;
}

}  // namespace lunarnav::sim
