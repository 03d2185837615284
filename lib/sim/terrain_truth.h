// The simulated terrain as a map: the true DEM on terrain-map's grid and conventions
// (truth/terrain.tif) and the true obstacles (the obstacle layer by terrain-map's rule on the
// true surface, and the rock list truth/rocks.csv), for `evaluate map`.
#pragma once

#include <string>

#include "io/geotiff_io.h"
#include "mapping/terrain_grid.h"
#include "sim/terrain.h"

namespace lunarnav::sim {

/// The true terrain on the world-anchored lattice of `cell_m` cells (terrain-map's) covering
/// the terrain's grid: bands elevation_m (the mean of the surface over the cell), min_m,
/// max_m (its extremes), obstacle (mapping::DetectObstacles on those, every cell judged),
/// each sampled on a 13 x 13 lattice of points per cell (edges included; about 2 cm apart for
/// 25 cm cells, the height field's own spacing). Rows north first, as terrain-map writes.
io::GeoRaster TerrainTruthRaster(const Terrain& terrain, double cell_m, const mapping::ObstacleOptions& obstacles);

/// The rocks as CSV: '#' lines, header x_m,y_m,height_m,semi_major_m,semi_minor_m,angle_deg.
std::string RocksCsv(const Terrain& terrain);

}  // namespace lunarnav::sim
