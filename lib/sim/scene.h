// The stereo simulator's world: rocky terrain, textured boxes, sky, and their radiance.
//
// World frame: x east, y north, z up, metres (sim/vehicle_pose.h). Radiance is
// view-independent (Lambertian surfaces under a distant sun plus ambient light, no cast
// shadows), so both cameras of a pair see the same value at a surface point.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "sim/terrain.h"
#include "sim/vehicle_pose.h"

namespace lunarnav::sim {

/// A box, axis-aligned in the world frame. Its "front" face is the one at y = min_m.y(),
/// which faces a vehicle at heading 0 (looking north) south of it.
struct Box {
  Eigen::Vector3d min_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d max_m = Eigen::Vector3d::Ones();
  std::uint64_t texture_seed = 1;
  double albedo_mean = 0.6;   ///< In (0, 1].
  double albedo_sigma = 0.15;  ///< Standard deviation of the face texture's albedo.
};

/// Lighting. With shading off every surface shows its albedo.
struct ShadingOptions {
  bool enabled = true;
  double sun_elevation_deg = 40.0;  ///< Above the horizon, (0, 90].
  double sun_azimuth_deg = 135.0;   ///< Compass direction the light comes from (clockwise from north).
  /// Fraction of the light that is ambient (unshadowed, direction-free), [0, 1].
  double ambient = 0.3;
  double sky_radiance = 0.8;  ///< Radiance of rays that hit nothing, [0, 1].
  nlohmann::json ToJson() const;
};

struct SceneOptions {
  TerrainOptions terrain;
  std::vector<Box> boxes;
  ShadingOptions shading;
  void Validate() const;
  nlohmann::json ToJson() const;
};

/// What a ray hit. Labels: kSky, kTerrain, or kFirstBox + index into the scene's boxes.
struct SurfaceHit {
  static constexpr int kSky = 0;
  static constexpr int kTerrain = 1;
  static constexpr int kFirstBox = 2;
  int label = kSky;
  double t = 0;                                        ///< Ray parameter of the hit.
  Eigen::Vector3d point = Eigen::Vector3d::Zero();     ///< World frame.
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();   ///< Unit, world frame (smooth for terrain).
  int face = -1;  ///< For boxes: 2 axis + (1 if the max side); 2 = front (y min).
};

class Scene {
 public:
  /// Builds the terrain (see Terrain) and keeps the boxes. Throws std::invalid_argument.
  explicit Scene(const SceneOptions& options);

  /// The nearest surface along origin + t direction for t in [t_min, t_max] (direction
  /// need not be unit; t is in its units). label kSky when nothing is hit.
  SurfaceHit Trace(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double t_min,
                   double t_max) const;
  /// Whether any surface lies on the segment t in [t_min, t_max] (a shadow-ray test).
  bool Occluded(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double t_min,
                double t_max) const;
  /// Radiance of a hit in [0, ~1.5]: albedo times the Lambertian shading normalised so that
  /// level ground has shading 1; the sky's constant for kSky. The texture is filtered for a
  /// footprint of `footprint_m` metres.
  double Radiance(const SurfaceHit& hit, double footprint_m) const;

  const Terrain& terrain() const { return terrain_; }
  const std::vector<Box>& boxes() const { return options_.boxes; }
  const SceneOptions& options() const { return options_; }

 private:
  SceneOptions options_;
  Terrain terrain_;
  Eigen::Vector3d sun_ = Eigen::Vector3d::UnitZ();  // unit, towards the sun
  double shading_norm_ = 1;
};

/// A box as a tape measure gives it, in the vehicle frame of a pose: the front face's Y and
/// its X and Z extents (metres). Exact when the pose's axes are the world's (heading 0,
/// level), as in the boxes preset; otherwise the mean Y and the extents of the front face's
/// four corners.
struct BoxTruth {
  int index = 0;  ///< Index in the scene's boxes; the truth label is SurfaceHit::kFirstBox + index.
  double front_y_m = 0;
  double x_min_m = 0, x_max_m = 0, z_min_m = 0, z_max_m = 0;
  nlohmann::json ToJson() const;
};

/// The boxes of `scene` in the vehicle frame of `pose`.
std::vector<BoxTruth> BoxTruthInVehicle(const Scene& scene, const VehiclePose& pose);

/// A box resting on `terrain`: front face at world y = front_y_m, centred at x = centre_x_m,
/// its bottom at the lowest terrain height under its footprint (the terrain hides no gap
/// below it), its top `height_m` above its bottom. Throws std::invalid_argument off the grid.
Box BoxOnTerrain(const Terrain& terrain, double centre_x_m, double front_y_m, double width_m, double depth_m,
                 double height_m, std::uint64_t texture_seed);

}  // namespace lunarnav::sim
