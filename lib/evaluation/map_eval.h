// A terrain map (terrain-map's elevation.tif) against the true terrain of a simulated run
// (simulate stereo's truth/terrain.tif, truth/rocks.csv, truth/xyz, truth/poses.csv):
// elevation error, coverage of the ground the cameras saw, obstacle detection.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <limits>
#include <vector>

#include <nlohmann/json.hpp>

#include "evaluation/table.h"
#include "io/geotiff_io.h"

namespace lunarnav::evaluation {

struct MapEvalOptions {
  /// Cells with at least this many points enter the elevation error and the obstacle
  /// scores, and a cell counts as seen when at least this many true rays reach it, >= 1.
  int min_points = 3;
  /// Rocks at least this tall (above the relief) make the rock recall, metres (sec. 3.1: 20 cm).
  double rock_height_m = 0.2;
  /// A rock is found when a map obstacle cell's centre lies within this of the rock's centre, m, > 0.
  double rock_near_m = 0.5;
  /// A detection within this many cells of a true obstacle cell (or a rock's footprint) counts, >= 0.
  int tolerance_cells = 1;
  /// Obstacle precision counts a map obstacle as real when a cell within tolerance_cells has
  /// at least this much true relief (truth's relief_m: a rock this tall on it, or a step of
  /// the surface), metres...
  double relief_height_m = 0.15;
  /// ...or a true slope (truth's slope_deg) above this, degrees, in (0, 90).
  double relief_slope_deg = 25;
  /// A compared cell farther than this from the truth is counted as a large error, metres
  /// (a phantom cliff or pit for a planner).
  double large_error_m = 0.30;
  /// The ground scored for coverage, obstacle and rock recall: the true points both cameras
  /// saw (a finite true disparity) this far ahead of the vehicle (vehicle-frame Y), metres.
  double seen_min_y_m = 2.0, seen_max_y_m = 10.0;
  /// The requests the pairs were matched with (a window-selection run, map-loop's
  /// requests.csv), by stem: for EvaluateMap and TrueRayCounts, the ground scored is each listed
  /// pair's true points with Y in its interval (within the seen range), over the listed pairs
  /// whether the map holds them or not (a failed pair's ground counts against coverage), and
  /// the corridor gaps are measured; RunMapEvaluation scores all the ground seen and gives
  /// this as a second view. Empty: every pair of the truth, the whole seen range.
  std::map<std::string, std::pair<double, double>> requested_y_m;
  /// Width of the vehicle's corridor in which gaps are measured, m (the Ratler's 4/3 m).
  double corridor_width_m = 1.3333;
  void Validate() const;
  nlohmann::json ToJson() const;
};

/// A rock of the simulated terrain (truth/rocks.csv): surface height_m (1 - q)^2 above the
/// relief, q the squared elliptical radius about (x_m, y_m) (major axis at angle_deg from x
/// towards y).
struct TrueRock {
  double x_m = 0, y_m = 0, height_m = 0, semi_major_m = 0, semi_minor_m = 0, angle_deg = 0;
  /// The true rays both cameras see that land on the rock's upper half (q <= 1 - 1/sqrt(2),
  /// where the rock stands at least half its height): TrueRayCounts fills it; -1 = not counted
  /// (EvaluateMap then asks only that the rock's centre cell was seen).
  long top_rays = -1;
  /// True when (x, y) lies where the rock stands at least half its height.
  bool InUpperHalf(double x, double y) const;
};
/// Reads truth/rocks.csv. @throws InputError naming file and line.
std::vector<TrueRock> ReadRocksCsv(const std::filesystem::path& path);

struct MapEvalResult {
  long cells_compared = 0;  ///< Mapped with >= min_points and inside the truth.
  double rmse_m = 0, bias_m = 0, mean_abs_m = 0, p90_abs_m = 0, max_abs_m = 0;
  long cells_large_error = 0;  ///< Compared cells more than large_error_m from the truth.
  long cells_seen = 0, cells_seen_mapped = 0;
  double coverage = 0;  ///< cells_seen_mapped (>= min_points) / cells_seen.
  /// obstacle_map: the map's obstacle cells (compared cells); obstacle_true: the true obstacle
  /// cells of the ground seen, mapped or not (an unmapped one is a missed one).
  long obstacle_map = 0, obstacle_true = 0;
  long obstacle_tp = 0, obstacle_fp = 0, obstacle_found = 0;
  double precision = 0, recall = 0;  ///< NaN when undefined.
  /// Rocks of >= rock_height_m whose upper half both cameras saw (TrueRock::top_rays >=
  /// min_points; or, uncounted, whose centre cell was seen).
  long rocks = 0, rocks_found = 0;
  double rock_recall = 0;
  /// Each rock of >= rock_height_m, scored or not (RunMapEvaluation writes them to rocks.csv).
  struct Rock {
    double x_m = 0, y_m = 0, height_m = 0;
    long top_rays = -1;  ///< TrueRock::top_rays.
    bool scored = false, found = false;
  };
  std::vector<Rock> rock_list;
  /// With requests: the longest run, along a requested interval in its pair's true vehicle
  /// frame, of ground the cameras saw but the map left empty across the corridor (NaN without
  /// requests), m; and the pair where it lies.
  double corridor_gap_m = std::numeric_limits<double>::quiet_NaN();
  std::string corridor_gap_stem;
  nlohmann::json ToJson() const;
  Table ToTable() const;
  std::string BriefReport() const;
};

/// Scores `map` (terrain-map's layers) against `truth` (truth/terrain.tif: elevation_m,
/// obstacle, relief_m and slope_deg on the same lattice), `seen` (a count raster of the true rays per cell, the
/// same lattice: TrueRayCounts) and the rocks. The elevation error is over the compared cells
/// (the map's, with >= min_points, inside the truth); coverage, obstacle recall and rock
/// recall are over the ground seen (>= min_points true rays), where a cell the map left empty
/// counts against them; precision is over the map's obstacle cells: the share near real relief
/// (relief_height_m, relief_slope_deg), a looser bar than the obstacle it must find (a cell of
/// 18 cm relief is no false alarm, though not an obstacle the map must report).
/// @throws InputError when the lattices differ (cell size or origin off each other's lattice).
MapEvalResult EvaluateMap(const io::GeoRaster& map, const io::GeoRaster& truth, const io::GeoRaster& seen,
                          const std::vector<TrueRock>& rocks, const MapEvalOptions& options);

/// The cells the cameras saw: the true surface points of the listed frames that both
/// cameras see (sim_dir/truth/disparity/<stem>.pfm finite) between seen_min_y_m and
/// seen_max_y_m ahead (sim_dir/truth/xyz/<stem>.exr, vehicle frame, placed by
/// sim_dir/truth/poses.csv with the simulator's pose convention), counted per world-anchored
/// cell of `cell_m`, as a one-band raster ("count"). Code of its own: not the mapper's binning.
/// With `rocks`, also each rock's top_rays: those points that land on its upper half. With
/// `frame_cells`, each frame's points' cells (floor(x / cell_m), floor(y / cell_m)), one entry
/// a point, in the order of `stems`.
io::GeoRaster TrueRayCounts(const std::filesystem::path& sim_dir, const std::vector<std::string>& stems,
                            double cell_m, const MapEvalOptions& options, int num_threads,
                            std::vector<TrueRock>* rocks = nullptr,
                            std::vector<std::vector<std::pair<std::int64_t, std::int64_t>>>* frame_cells = nullptr);

/// One count of TrueRayCountViews: the range ahead of each frame (`options`' seen range,
/// narrowed by its requested interval when it has one), the frames it counts (null: all), and
/// what it fills as TrueRayCounts does.
struct RayCountView {
  const MapEvalOptions* options = nullptr;
  const std::set<std::string>* stems = nullptr;
  std::vector<TrueRock>* rocks = nullptr;
  std::vector<std::vector<std::pair<std::int64_t, std::int64_t>>>* frame_cells = nullptr;
};

/// TrueRayCounts for several views at once, each frame's truth read once: one raster per view.
/// A view's frames must be among `stems` (InputError naming the stem, as for a missing pose).
std::vector<io::GeoRaster> TrueRayCountViews(const std::filesystem::path& sim_dir,
                                             const std::vector<std::string>& stems, double cell_m,
                                             const std::vector<RayCountView>& views, int num_threads);

/// The longest corridor gap (MapEvalResult::corridor_gap_m) of `map` (terrain-map's layers;
/// a cell is mapped with >= min_points) over the requested intervals: per pair, walking out
/// along its interval (within the seen range) in half-cell steps in its true vehicle frame
/// (sim_dir/truth/poses.csv), a step is a gap when at least half of its cross-section of
/// corridor_width_m (samples half a cell apart) was seen (`seen`, >= min_points true rays) and
/// less than half is mapped; the longest run of gap steps, each half a cell. Steps not seen
/// (occluded) end a run. Sets result->corridor_gap_m and corridor_gap_stem.
void MeasureCorridorGaps(const io::GeoRaster& map, const io::GeoRaster& seen, const std::filesystem::path& sim_dir,
                         const MapEvalOptions& options, MapEvalResult* result);

/// `evaluate map`: reads MAP_DIR/elevation.tif and frames.csv and the simulated run's truth,
/// writes OUT_DIR/map.{csv,json,md} and summary.json. Returns the result: the score over the
/// ground the truth's pairs saw, whatever options.requested_y_m lists; with requests, also
/// the view over the requested ground (requested.{csv,json,md}, summary.json "requested").
MapEvalResult RunMapEvaluation(const std::filesystem::path& map_dir, const std::filesystem::path& sim_dir,
                               const MapEvalOptions& options, const std::filesystem::path& output_dir,
                               int num_threads, const nlohmann::json& invocation);

}  // namespace lunarnav::evaluation
