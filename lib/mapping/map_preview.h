// The terrain map as a picture: colour relief over hillshade, obstacles, the vehicle's path,
// a colour legend and a scale bar.
#pragma once

#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "mapping/terrain_grid.h"

namespace lunarnav::mapping {

/// Renders `layers` (north up, x east to the right) as an 8-bit BGR picture: elevation in a
/// colour scale (legend with its range in metres on the right) shaded by a hillshade (sun
/// from the north-west, 45 deg up), unmapped cells light grey, obstacle cells red, the path
/// (world x, y of each frame) as a white line with a black edge, and a scale bar. Each cell
/// is drawn as a square of an integer number of pixels chosen so that the map is about
/// `target_px` wide or tall. An empty map gives a small picture saying so.
cv::Mat RenderMapPreview(const MapLayers& layers, const std::vector<Eigen::Vector2d>& path_xy_m, int target_px = 1000);

}  // namespace lunarnav::mapping
