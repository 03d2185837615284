// The closed loop of Krotkov & Hebert sec. 3.3 over a recorded run, pair by pair: the planner
// asks for the interval I_Y it needs, from the past poses and the map so far; stereo matches
// the pair in that window only; the map takes its points; the next request follows what the
// map now holds. docs/terrain-map.md, "The loop".
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calib/vehicle.h"
#include "mapping/terrain_map_run.h"
#include "mapping/window_planner.h"
#include "stereo/batch.h"

namespace lunarnav::mapping {

struct MapLoopOptions {
  /// The matcher and its window selection. Needs the rectified rig; requests_region gives the
  /// heights searched; `ground` (the rig's default search, calib::SelectGroundWindow) gives the
  /// requested windows their per-row bands and guards (the quality preset). Its requests,
  /// region, shard and resume are the loop's own.
  stereo::BatchOptions stereo;
  /// The map's fusion and inputs: poses (or a trajectory with frame times) and the rig for the
  /// points' errors. Its stereo directory, requests, stems and resume are the loop's own.
  TerrainMapRunOptions map;
  WindowPlannerOptions planner;
  calib::VehicleSpec vehicle;
  /// Continue the loop in OUT_DIR: the pairs its requests.csv lists keep their requests (they
  /// were planned from the map as it then was), complete stereo outputs and fused frames are
  /// kept, and the loop goes on from the first pair not planned.
  bool resume = false;
  /// Plan from the past poses only, not from the map (the previous request's far edge is the
  /// covered ground, as plan-windows without --map): the open loop, for comparison.
  bool open_loop = false;
  bool show_progress = true;
  void Validate() const;  ///< std::invalid_argument for missing or conflicting options.
};

/// One pair of the loop.
struct MapLoopPair {
  PlannedWindow plan;          ///< The request and how it came about.
  bool replanned = true;       ///< False when a resumed loop took the request from requests.csv.
  std::string status;          ///< "ok", "resumed" (stereo outputs kept) or "failed".
  std::string error;           ///< For a failed pair.
  long pixels_evaluated = 0, pixels_accepted = 0;
  long points_fused = 0;       ///< Into the map (0 for a failed pair).
  double stereo_seconds = 0;   ///< Reading, matching and writing the pair (0 when resumed).
  double match_seconds = 0;    ///< Of which matching.
  double map_seconds = 0;      ///< Fusing it and committing the map.
};

struct MapLoopSummary {
  std::vector<MapLoopPair> pairs;  ///< In time order.
  int pairs_ok = 0, pairs_resumed = 0, pairs_failed = 0;
  double seconds = 0, plan_seconds = 0, stereo_seconds = 0, match_seconds = 0, map_seconds = 0;
  TerrainMapRunSummary map;        ///< The last commit of the map.
  std::string BriefReport() const;
};

/// Runs the loop over the rectified pairs of `rect_dir` (left/, right/) in time order:
///   1. plans pair k from poses 0..k and OUT_DIR/map (the map of the pairs before it:
///      PlanWindows with the map, so a failed or blank pair's ground is asked for again);
///   2. records the request in OUT_DIR/requests.csv and plan.csv (before matching: a killed
///      loop resumes with the same requests);
///   3. matches the pair in its window into OUT_DIR/stereo (stereo-batch's outputs);
///   4. fuses it into OUT_DIR/map (terrain-map --resume with the requests: points outside the
///      interval left out);
/// then writes OUT_DIR/loop.csv (every pair: plan, status, counts, times) and summary.json.
/// A pair that fails (blank, unreadable) is logged and the loop goes on.
/// @throws InputError for a pair without a pose, non-finite poses or unusable inputs (before
///         anything is written); std::invalid_argument for bad options.
MapLoopSummary RunMapLoop(const MapLoopOptions& options, const std::filesystem::path& rect_dir,
                          const std::filesystem::path& output_dir, const nlohmann::json& invocation = nullptr);

/// The loop's per-pair table (header stem,t_s,speed_mps,...,status,...).
std::string MapLoopCsv(const std::vector<MapLoopPair>& pairs);

}  // namespace lunarnav::mapping
