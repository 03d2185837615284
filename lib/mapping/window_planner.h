// The planner's side of window selection (Krotkov & Hebert sec. 3.3): for each stereo pair,
// the interval of forward distances I_Y = [Y_min, Y_max] in which the navigation map needs
// new data, "computed from the speed of the vehicle and from the anticipated delay in
// getting the result from stereo", and the part of the map already covered.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calib/rig_check.h"
#include "calib/vehicle.h"
#include "mapping/frame_poses.h"
#include "mapping/terrain_grid.h"

namespace lunarnav::mapping {

/// The farthest a request may reach ahead of the vehicle, metres: far beyond any stereo rig's
/// useful range; the planner's horizon and overlap are bounded by it too.
inline constexpr double kMaxRequestDistanceM = 1000.0;
/// The largest stereo delay and initial cycle, seconds (an hour), and initial speed, m/s.
inline constexpr double kMaxPlannerTimeS = 3600.0;
inline constexpr double kMaxPlannerSpeedMps = 100.0;

struct WindowPlannerOptions {
  /// Time from taking a pair to its points being in the map, s, >= 0 (the paper: 0.7 s of
  /// matching per pair with the Figure 3 windows, sec. 3.4).
  double stereo_delay_s = 0.7;
  /// Depth of map the planner keeps beyond the nearest distance it needs, metres, > 0 (room
  /// to choose a path around an obstacle once it is seen).
  double horizon_m = 5.0;
  /// Each request reaches back this far into the ground the previous one covered, metres,
  /// >= 0 (tolerates errors in the speed and the pose).
  double overlap_m = 1.0;
  /// The speed assumed for the first pair, which has no past pose to take it from (the
  /// commanded speed), m/s, >= 0.
  double initial_speed_mps = 0.0;
  /// The cycle time assumed for the first pair (no previous pair), s, >= 0.
  double initial_cycle_s = 0.0;
  calib::Gravity gravity = calib::Gravity::kEarth;
  void Validate() const;
  nlohmann::json ToJson() const;
};

/// The far edge of the mapped ground ahead of `pose` in `map` (its elevation layer, NaN =
/// unmapped), in the corridor of `width_m` centred on the pose's forward axis: walking out
/// from from_y_m (vehicle frame) in half-cell steps, the distance of the first step whose
/// cross-section (samples half a cell apart) is less than half mapped; to_y_m when every step
/// up to it is mapped. The closed loop of sec. 3.3: the next request follows what the map
/// actually holds, so ground a failed or blank pair left unmapped is asked for again. Only the
/// cells the map had before `before_t_s` count: with map.last_t_exact_s, a cell a pair at or
/// after that time added points to is unmapped (the ground a later pair saw is not yet known).
double MappedReachAhead(const MapLayers& map, const FramePose& pose, double from_y_m, double to_y_m, double width_m,
                        double before_t_s = std::numeric_limits<double>::infinity());
/// The elevation layer (and its lattice) of a terrain-map output, DIR/elevation.tif, and with
/// `exact_times` each cell's exact last time from DIR/state.tif (last_t_exact_s; empty without
/// one). @throws InputError.
MapLayers ReadMapElevation(const std::filesystem::path& map_dir, bool exact_times = true);

/// One pair's request and how it came about (vehicle frame at the pair's time, metres).
struct PlannedWindow {
  std::string stem;
  double t_s = 0;
  double speed_mps = 0;      ///< From this pose and the previous one (initial_speed_mps for the first).
  double cycle_s = 0;        ///< Time since the previous pair (initial_cycle_s for the first).
  double d_stop_m = 0;       ///< Stopping distance at that speed (sec. 3.1).
  double y_need_m = 0;       ///< Front of the wheels + d_stop + speed x stereo delay.
  /// Far edge of the ground already covered: the previous request's, moved into this frame
  /// (NaN for the first pair); with a map, the far edge of what the map holds ahead.
  double covered_to_m = 0;
  double y_min_m = 0, y_max_m = 0;  ///< The request I_Y.
};

/// Plans the requests of `poses` (in time order, at least one), causally: pair k's request uses
/// only poses 0..k, as a rover's planner would (v from poses k-1 and k, T the last cycle):
///   y_need = front of the wheels + d_stop(v) + v stereo_delay,
///   y_max  = y_need + horizon + v T (T: the time since the previous pair, the next cycle's
///            expected length),
///   y_min  = clamp(covered_to - overlap, y_need, y_max - overlap), covered_to = the previous
///            y_max less the distance driven since (forward component), or y_need for the first.
/// In steady state at speed v the request is [y_need + horizon - overlap, y_need + horizon + v T]:
/// the ground driven over in one cycle plus the overlap; it moves out with v as d_stop does.
/// With `map` (the map so far, for the pair to plan next), covered_to is the far edge of what
/// the map holds in the vehicle's corridor ahead (MappedReachAhead from y_need), for every
/// pair: ground a failed or blank pair left unmapped is requested again. A map that holds
/// later pairs too is read causally: for pair k only the cells no pair at or after its time
/// added to (map->last_t_exact_s).
/// @throws InputError naming the stem for a non-finite pose or time stamps that do not increase.
std::vector<PlannedWindow> PlanWindows(const std::vector<FramePose>& poses, const calib::VehicleSpec& vehicle,
                                       const WindowPlannerOptions& options, const MapLayers* map = nullptr);

/// The requests as `stereo-batch --requests` reads them (docs/formats.md, "Window requests").
std::string RequestsCsv(const std::vector<PlannedWindow>& plan);
/// Every field of the plan, one row per pair (header stem,t_s,speed_mps,d_stop_m,...).
std::string PlanCsv(const std::vector<PlannedWindow>& plan);

}  // namespace lunarnav::mapping
