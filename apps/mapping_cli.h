// The map's fusion options and the planner's options, shared by the tools that map or plan:
// terrain-map, plan-windows and map-loop. docs/terrain-map.md describes each.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>

#include "calib/vehicle.h"
#include "mapping/ground_alignment.h"
#include "mapping/terrain_grid.h"
#include "mapping/window_planner.h"

namespace lunarnav::apps {

/// Adds the fusion and obstacle options (cell, gate, visibility, support, min frames, frame
/// floor, default sigma, max sigma cells, max range, obstacle rules) bound to `map`.
void AddFusionOptions(CLI::App* app, mapping::TerrainMapOptions* map);

/// Adds --align-to-ground (auto, on, off) and --align-gain, bound to `mode` and `options`.
void AddAlignmentOptions(CLI::App* app, std::string* mode, mapping::GroundAlignmentOptions* options);

/// The alignment a run uses: on, off, or with "auto" on when the poses are dead reckoning's
/// (`trajectory` is posfilter's trajectory.csv), whose attitude comes from inclinometers.
std::optional<mapping::GroundAlignmentOptions> ResolveAlignment(const std::string& mode,
                                                                const mapping::GroundAlignmentOptions& options,
                                                                const std::filesystem::path& trajectory);

/// The vehicle's limits in the map's obstacle rules (obstacle height, slope limit).
void ApplyVehicleLimits(const calib::VehicleSpec& vehicle, mapping::TerrainMapOptions* map);

/// Adds the planner's options (stereo delay, horizon, overlap, initial speed and cycle, gravity)
/// bound to `planner` and `gravity` (read it with calib::GravityFromString after parsing).
void AddPlannerOptions(CLI::App* app, mapping::WindowPlannerOptions* planner, std::string* gravity);

}  // namespace lunarnav::apps
