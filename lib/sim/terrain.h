// Rocky terrain for the stereo simulator: a height field on a regular grid, with gentle
// slopes, rocks and a procedural albedo anchored to the world.
//
// World frame: x east, y north, z up, metres. The surface is the bilinear interpolation of
// the grid heights (cell size `cell_m`, 2 cm by default), and everything (rendering, truth,
// HeightAt) uses exactly that surface. The relief and the rocks are functions of world
// coordinates and the seed only, so two grids of different extent agree where they overlap.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

namespace lunarnav::sim {

struct TerrainOptions {
  std::uint64_t seed = 1;  ///< Relief, rocks and albedo.
  /// Extent of the height grid in the world frame, metres. Rays that leave it see the sky.
  double min_x_m = -15, max_x_m = 15, min_y_m = -5, max_y_m = 35;
  double cell_m = 0.02;  ///< Grid spacing, metres, in [0.005, 0.5].

  /// A plane through the world origin: z = slope_x x + slope_y y (rise over run).
  double slope_x = 0.0, slope_y = 0.0;
  /// Smooth relief: three octaves of value noise with lattice spacings L, L/2, L/4 and
  /// amplitudes A, A/2, A/4; A in metres (peak values reach about A), L in metres.
  double relief_amplitude_m = 0.3;
  double relief_wavelength_m = 12.0;

  /// Rocks: elliptical bumps h (1 - q)^2, q the squared elliptical radius, on top of the
  /// relief (overlapping rocks take the maximum). Mean number per square metre, >= 0.
  double rock_density_per_m2 = 0.4;
  /// Heights are drawn from a power law N(> h) ~ h^-exponent on [min, max], metres.
  double rock_min_height_m = 0.05, rock_max_height_m = 0.5;
  double rock_size_exponent = 2.0;
  /// Footprint diameter over height (the ellipse's mean axis), drawn in [0.8, 1.25] x this.
  double rock_diameter_to_height = 2.5;
  /// A path kept clear of rocks a vehicle could not drive over (`simulate field-log`: its
  /// route, as a rover's planner would keep it): rocks taller than clear_max_rock_height_m
  /// whose footprint comes within clear_half_width_m of the polyline are not placed. Empty: none.
  std::vector<Eigen::Vector2d> clear_path_m;
  double clear_half_width_m = 0;
  double clear_max_rock_height_m = 0;

  /// Albedo: mean + sigma * FractalNoise2 of world (x, y), clamped to [0.02, 1].
  double albedo_mean = 0.45;
  double albedo_sigma = 0.12;
  double texture_finest_m = 0.01;  ///< Lattice spacing of the finest texture octave, metres.
  int texture_octaves = 8;         ///< Spacings finest, 2 finest, ... (8: 1 cm to 1.28 m).

  /// Throws std::invalid_argument naming the field.
  void Validate() const;
  nlohmann::json ToJson() const;
};

/// One rock of the terrain: an elliptical bump h (1 - q)^2 on the relief, q the squared
/// elliptical radius ((u / a)^2 + (v / b)^2 in axes turned by angle_rad from x towards y).
struct TerrainRock {
  double x_m = 0, y_m = 0;   ///< Centre, world frame.
  double height_m = 0;       ///< Above the relief at its centre.
  double semi_major_m = 0, semi_minor_m = 0, angle_rad = 0;
};

/// The height field with a max-mip hierarchy for ray casting.
class Terrain {
 public:
  /// Builds the grid (relief plus rocks) and its hierarchy. Throws std::invalid_argument for
  /// invalid options or a grid over 200 million cells.
  explicit Terrain(const TerrainOptions& options);

  /// Height of the rendered surface at world (x, y), metres; NaN outside the grid.
  double HeightAt(double x_m, double y_m) const;
  /// The unit normal used for shading at (x, y): bilinearly interpolated central-difference
  /// gradients (smooth across cells). (0, 0, 1) outside the grid.
  Eigen::Vector3d NormalAt(double x_m, double y_m) const;
  /// Albedo at (x, y) in [0.02, 1], texture filtered for a footprint of `footprint_m`.
  double AlbedoAt(double x_m, double y_m, double footprint_m) const;

  /// The first t in [t_min, t_max] at which origin + t direction is on or below the surface
  /// (exact for the bilinear surface), or nothing. A ray starting below the surface hits at
  /// t_min. Parts of the ray outside the grid never hit.
  std::optional<double> Intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                                  double t_min, double t_max) const;

  /// The rocks whose centres lie on the grid, in a fixed order (by 1 m tile, then within it).
  std::vector<TerrainRock> Rocks() const;

  const TerrainOptions& options() const { return options_; }
  int GridWidth() const { return nx_; }   ///< Vertices along x.
  int GridHeight() const { return ny_; }  ///< Vertices along y.
  double MaxHeight() const { return max_height_; }
  double MinHeight() const { return min_height_; }

 private:
  float H(int i, int j) const { return heights_[static_cast<std::size_t>(j) * nx_ + i]; }
  Eigen::Vector2d VertexGradient(int i, int j) const;

  TerrainOptions options_;
  // The albedo's octaves, hoisted out of the per-sample loop: lattice seed and 1 / spacing.
  std::vector<std::uint32_t> octave_seeds_;
  std::vector<double> octave_inv_spacing_, octave_spacing_;
  double inv_cell_ = 0;
  int nx_ = 0, ny_ = 0;             // vertices
  std::vector<float> heights_;      // ny_ x nx_, row-major; vertex (i, j) at (x0 + i c, y0 + j c)
  // levels_[L]: maxima of blocks of 4^L x 4^L cells; dims level_nx_[L] x level_ny_[L].
  std::vector<std::vector<float>> levels_;
  std::vector<int> level_nx_, level_ny_;
  double min_height_ = 0, max_height_ = 0;
};

}  // namespace lunarnav::sim
