#include "apps/mapping_cli.h"

#include "mapping/kitti_trajectory.h"

namespace lunarnav::apps {

void AddAlignmentOptions(CLI::App* app, std::string* mode, mapping::GroundAlignmentOptions* options) {
  app->add_option("--align-to-ground", *mode,
                  "bring each pair onto the ground the pairs before it mapped (height, pitch, roll) before fusing "
                  "it; auto: on for posfilter's trajectory.csv (dead reckoning's attitude), off for other poses")
      ->check(CLI::IsMember({"auto", "on", "off"}))
      ->capture_default_str();
  app->add_option("--align-gain", options->gain, "the fraction of each alignment's correction applied, (0, 1]")
      ->capture_default_str();
}

std::optional<mapping::GroundAlignmentOptions> ResolveAlignment(const std::string& mode,
                                                                const mapping::GroundAlignmentOptions& options,
                                                                const std::filesystem::path& trajectory) {
  if (mode == "on") return options;
  if (mode == "auto" && !trajectory.empty() &&
      mapping::DetectTrajectoryFormat(trajectory) == mapping::TrajectoryFormat::kPosfilterCsv) {
    return options;
  }
  return std::nullopt;
}

void AddFusionOptions(CLI::App* app, mapping::TerrainMapOptions* map) {
  app->add_option("--cell", map->cell_m, "cell size, m")->capture_default_str();
  app->add_option("--gate", map->gate_k,
                  "gate: reject points farther than this many combined sigmas from the cell's median in their frame "
                  "(inf: off)")
      ->capture_default_str();
  app->add_option("--gate-floor", map->gate_floor_m, "floor of the gate's sigma, m")->capture_default_str();
  app->add_option("--visibility", map->visibility_k,
                  "visibility: reject a point when a ray of its image column to a farther point passes beneath it, "
                  "by this many sigmas of distance plus --visibility-floor (inf: off)")
      ->capture_default_str();
  app->add_option("--visibility-floor", map->visibility_floor_m, "the visibility rule's margin, m")
      ->capture_default_str();
  app->add_option("--support-rise", map->support_rise_m,
                  "support: reject a point risen more than this above the last point below it in its image column, "
                  "steeper than 30 deg, with no face seen between (inf: off), m")
      ->capture_default_str();
  app->add_option("--carve-tolerance", map->carve_tolerance_m,
                  "free-space carving: leave out a cell's observations more than this above the height two pairs' "
                  "rays passed over it (needs --rig; inf: off), m")
      ->capture_default_str();
  app->add_option("--moved-height", map->moved_height_m,
                  "moved on: leave out a cell's observations whose top stands more than this over the top two later "
                  "pairs saw there, their mean above it too (inf: off), m")
      ->capture_default_str();
  app->add_option("--carve-reach", map->carve_reach_m,
                  "the stretch of each ray, before its point, that carves (horizontal), m")
      ->capture_default_str();
  app->add_option("--hidden-tolerance", map->hidden_tolerance_m,
                  "leave out a pair's observation of a cell when the ray to it passes this far below the ground "
                  "of another cell the pair sees on its way (needs --rig; inf: off), m")
      ->capture_default_str();
  app->add_option("--hidden-ground-quantile", map->hidden_ground_quantile,
                  "the ground --hidden-tolerance tests a ray against: this quantile of the pair's points in the cell "
                  "(0: its lowest point)")
      ->capture_default_str();
  app->add_option("--min-frames", map->min_frames, "cells fewer pairs saw are left out of the layers (kept in the sums)")
      ->capture_default_str();
  app->add_option("--frame-floor", map->frame_floor_m,
                  "least error of one frame's estimate of a cell (its points' errors are correlated), m")
      ->capture_default_str();
  app->add_option("--default-sigma", map->default_sigma_m, "elevation error of points without xyz_sigma, m")
      ->capture_default_str();
  app->add_option("--max-sigma-cells", map->max_horizontal_sigma_cells,
                  "ignore points whose predicted horizontal error (xyz_sigma or --rig) exceeds this many cells")
      ->capture_default_str();
  app->add_option("--ground-sigma-cells", map->ground_sigma_cells,
                  "points whose horizontal error passes --max-sigma-cells but not this count as ground only: kept "
                  "within --ground-gate of their pair's ground plane (<= --max-sigma-cells: off)")
      ->capture_default_str();
  app->add_option("--ground-gate", map->ground_gate_m,
                  "the ground-only points' largest height from their pair's ground plane (a robust fit), m")
      ->capture_default_str();
  app->add_option("--lone-object-height", map->lone_object_height_m,
                  "of the points too uncertain for a cell, keep those standing more than this over their pair's "
                  "ground plane where the pair placed nothing standing that high within two cells: an object seen "
                  "only at the view's far corners (inf: off), m")
      ->capture_default_str();
  app->add_option("--edge-margin", map->edge_margin_px,
                  "leave out a point standing more than --edge-height over its cell's ground when, within this many "
                  "pixels along its row, a point is more than --edge-step nearer: a depth edge, where the point's "
                  "depth mixes the two surfaces (needs --rig; 0: off), px")
      ->capture_default_str();
  app->add_option("--edge-step", map->edge_step_px, "the nearer point's least disparity step at a depth edge, px")
      ->capture_default_str();
  app->add_option("--edge-height", map->edge_height_m,
                  "the least height over its cell's ground (the pair's other points there, else around it) of a point "
                  "the depth-edge rule leaves out, m")
      ->capture_default_str();
  app->add_option("--max-range", map->max_range_m, "ignore points farther from the mast base, m")
      ->capture_default_str();
  app->add_option("--obstacle-min-points", map->obstacles.min_points, "cells with fewer points are not judged")
      ->capture_default_str();
  app->add_option("--step-tolerance", map->obstacles.step_tolerance_m,
                  "flag a step when it exceeds the obstacle height minus this, m")
      ->capture_default_str();
  app->add_option("--obstacle-extremes", map->obstacles.extreme_k,
                  "the step rule's highest point of a cell: within this many roughnesses of its mean (inf: raw)")
      ->capture_default_str();
  app->add_option("--obstacle-low-extremes", map->obstacles.low_extreme_k,
                  "the step rule's lowest point of a cell (the ground's level beside a step): within this many "
                  "roughnesses of its mean (inf: raw)")
      ->capture_default_str();
  app->add_option("--pair-step-support", map->obstacles.pair_step_support,
                  "a step is flagged only where the pairs' own steps pass too: 1 one pair's, 2 the second highest "
                  "(0: off)")
      ->capture_default_str();
  app->add_option("--max-map-cells", map->max_cells,
                  "the largest map (width x height in cells); a pair that would make it larger is refused")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
}

void ApplyVehicleLimits(const calib::VehicleSpec& vehicle, mapping::TerrainMapOptions* map) {
  map->obstacles.step_height_m = vehicle.requirements.obstacle_height_m;
  map->obstacles.max_slope_deg = vehicle.max_slope_deg;
}

void AddPlannerOptions(CLI::App* app, mapping::WindowPlannerOptions* planner, std::string* gravity) {
  app->add_option("--stereo-delay", planner->stereo_delay_s, "time from a pair to its points in the map, s")
      ->capture_default_str();
  app->add_option("--horizon", planner->horizon_m, "map depth kept beyond the nearest distance needed, m")
      ->capture_default_str();
  app->add_option("--overlap", planner->overlap_m, "reach back into the covered ground, m")->capture_default_str();
  app->add_option("--initial-speed", planner->initial_speed_mps,
                  "speed assumed for the first pair, which has no earlier pose (the commanded speed), m/s")
      ->capture_default_str();
  app->add_option("--initial-cycle", planner->initial_cycle_s, "cycle time assumed for the first pair, s")
      ->capture_default_str();
  app->add_option("--gravity", *gravity, "earth or moon (braking distance)")->capture_default_str();
}

}  // namespace lunarnav::apps
