// A terrain map made with estimated poses, scored where a rover uses it: in each pair's own
// frame. A rover plans from where it believes it is: the ground 2-10 m ahead of each pair's
// estimated pose, as the map holds it, is compared with the true ground seen from the true
// pose (a drift common to the pairs cancels; what differs between the pairs that built a
// cell and the pair that reads it does not). Beside it, the trajectory's own error at the
// frames. Code of the evaluation's own, not the mapper's (docs/evaluate.md).
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "evaluation/map_eval.h"
#include "evaluation/table.h"
#include "io/geotiff_io.h"
#include "mapping/frame_poses.h"

namespace lunarnav::evaluation {

/// The trajectory a map was made with (its frames.csv) against the true poses at the frames.
struct FramePoseErrors {
  long frames = 0;                ///< In both.
  double path_m = 0;              ///< The true path's length through the frames (horizontal), m.
  double final_horizontal_m = 0;  ///< At the last frame, m.
  double max_horizontal_m = 0, max_vertical_m = 0;
  double drift_pct = 0;           ///< final_horizontal_m / path_m, % (NaN for no path).
  double heading_rms_deg = 0, pitch_rms_deg = 0, roll_rms_deg = 0;
  double heading_max_deg = 0, pitch_max_deg = 0, roll_max_deg = 0;
  nlohmann::json ToJson() const;
};

/// `estimated` against `truth` by stem (stems missing from either are left out).
FramePoseErrors CompareFramePoses(const std::vector<mapping::FramePose>& estimated,
                                  const std::vector<mapping::FramePose>& truth);

/// The map in the pairs' frames: pooled over (pair, cell) samples.
struct VehicleFrameMapScore {
  long pairs = 0;
  /// Elevation: per pair, each true cell it saw (>= min_points of its true points 2-10 m
  /// ahead) taken to where the pair believes it is (estimated world = E T^-1 true world, E and T
  /// the pair's estimated and true poses); the map's cell there, taken back to the true world
  /// (T E^-1), against the true surface there (the truth's cell heights, bilinear).
  long samples = 0;
  double rmse_m = 0, bias_m = 0, p90_abs_m = 0, max_abs_m = 0;
  long large_error = 0;  ///< Samples off by more than options.large_error_m.
  long seen = 0, seen_mapped = 0;
  double coverage = 0;   ///< seen_mapped / seen: (pair, seen cell) whose believed place is mapped.
  /// The map's obstacle cells the pairs' seen cells reach, each taken to the true world: near
  /// true relief (options.relief_height_m, relief_slope_deg within tolerance_cells) or not.
  long obstacle_samples = 0, obstacle_tp = 0;
  double precision = 0;
  /// Rocks of >= rock_height_m (scored as the global score does) in each pair that saw their
  /// centre: found when a map obstacle lies within rock_near_m of where the pair believes the
  /// rock is. rocks_every_view: rocks found in every pair that saw them.
  long rock_views = 0, rock_views_found = 0, rocks = 0, rocks_every_view = 0;
  double rock_view_recall = 0;
  std::string worst_stem;  ///< The pair with the largest error.
  nlohmann::json ToJson() const;
};

/// Scores `map` in the frames of the pairs in `estimated` (the poses the map was made with)
/// that `truth` also holds. `frame_cells`: each truth stem's true points' cells (TrueRayCounts,
/// the same order as `truth_stems`); `rocks` with their top_rays counted.
/// @throws InputError when the map or the truth lacks a band.
VehicleFrameMapScore EvaluateMapInVehicleFrames(
    const io::GeoRaster& map, const io::GeoRaster& truth, const std::vector<mapping::FramePose>& estimated,
    const std::vector<mapping::FramePose>& truth_poses, const std::vector<std::string>& truth_stems,
    const std::vector<std::vector<std::pair<std::int64_t, std::int64_t>>>& frame_cells,
    const std::vector<TrueRock>& rocks, const MapEvalOptions& options, int num_threads);

/// The two scores side by side: the global row (EvaluateMap's) and the vehicle-frame row, with
/// the trajectory's drift.
Table MapScoresTable(const MapEvalResult& global, const VehicleFrameMapScore& local, const FramePoseErrors& poses);

}  // namespace lunarnav::evaluation
