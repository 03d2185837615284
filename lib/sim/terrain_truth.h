// The simulated terrain as a map: the true DEM on terrain-map's grid and conventions
// (truth/terrain.tif) and the true obstacles (from the scene itself: the rocks' footprints
// and the true surface's relief and slope, by a rule of the simulator's own, not the
// mapper's), and the rock list truth/rocks.csv, for `evaluate map`.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "io/geotiff_io.h"
#include "sim/terrain.h"

namespace lunarnav::sim {

/// What a true obstacle is (the paper's sec. 3.1 vehicle: 20 cm steps, 30 deg slopes).
struct TrueObstacleOptions {
  double step_height_m = 0.2;  ///< > 0.
  double max_slope_deg = 30;   ///< In (0, 90).
  void Validate() const;
  nlohmann::json ToJson() const;
};

/// The true terrain on the world-anchored lattice of `cell_m` cells (terrain-map's) covering
/// the terrain's grid: bands elevation_m (the mean of the surface over the cell), min_m,
/// max_m (its extremes), each sampled on a 13 x 13 lattice of points per cell (edges
/// included; about 2 cm apart for 25 cm cells, the height field's own spacing), and obstacle:
/// bit 1 (step) where a rock at least step_height_m tall stands on the cell (its elliptical
/// footprint covers one of the cell's samples) or where the cell's highest point stands
/// step_height_m above the lowest point of its 3 x 3 neighbourhood, both measured from the
/// neighbourhood's least-squares plane (so an even slope is no step); bit 2 (slope) where
/// that plane is steeper than max_slope_deg; relief_m: that step measure (the cell's highest sample above the
/// neighbourhood's lowest) or the height of a rock whose footprint covers the cell if more;
/// slope_deg: the plane's slope. Rows north first, as terrain-map writes.
io::GeoRaster TerrainTruthRaster(const Terrain& terrain, double cell_m, const TrueObstacleOptions& obstacles = {});

/// The rocks as CSV: '#' lines, header x_m,y_m,height_m,semi_major_m,semi_minor_m,angle_deg.
std::string RocksCsv(const Terrain& terrain);

}  // namespace lunarnav::sim
