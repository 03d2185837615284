// The terrain map of Krotkov & Hebert sec. 3 and 3.4: "the sets of points measured by stereo
// are accumulated over time into a terrain map centered at the vehicle", on a grid of about
// 25 cm ("a 25cm grid is typically sufficient for evaluating navigability").
//
// The grid is a lattice of square cells anchored at the world origin (cell (i, j) spans
// x in [i c, (i + 1) c), y in [j c, (j + 1) c); world frame x east, y north, z up, metres), so
// that maps built from different frames share their cells. Cells live in tiles of 64 x 64
// allocated as points arrive: memory follows the mapped area, not the number of frames.
//
// Fusion (docs/terrain-map.md): each frame's points are binned by cell; within a frame, a
// point is rejected when it floats (a ray of the same image column to a farther point passes
// beneath it: elevation_mapping's visibility clean-up, within the frame) or when it is
// inconsistent with that frame's estimate of the cell (farther from the cell's median than
// gate_k times the combination of its predicted error, the cell's robust spread and a floor).
// The accepted points of a frame in a cell make one observation (their inverse-variance
// weighted mean), because they share the frame's errors (one pose, overlapping correlation
// windows): its weight is 1 / (sigma^2 + frame_floor_m^2), sigma^2 the points' mean variance,
// so that a frame seeing a cell with a thousand near points does not outvote every other
// frame by its count. The cell's elevation is the weighted mean of its frames' observations;
// the map is a sum of per-frame terms, so fusing frames in any order, or in parts that are then merged,
// gives the same map.
//
// Free-space carving across pairs: a ray from the camera to a point passes through empty air,
// so in a 2.5-D world every cell it crosses on its way holds nothing above the ray. Each frame
// records, per cell its rays cross in the last metres before their points, the ray's lowest
// height over the cell (the kCeilingSupport-th lowest of its rays, so that a stray match does
// not count); a cell keeps the two lowest of its frames' records. The frames' observations of
// a cell are kept apart by height (bins on a fixed lattice of heights, coarsened when a cell
// holds more than kMaxHeightBins), and when the layers are computed, the bins whose mean
// stands more than carve_tolerance_m above the second frame's ceiling are left out: the
// reflections seen behind glossy bodies, the cyclist that has moved on, the wrong matches
// beside an object's edge. Both are sums and minima, so the exactness above holds. So are the
// two rules that read time and the pairs one at a time: a bin that two later pairs saw lower
// moved on (moved_height_m; each bin keeps its two last times), and a step is flagged only
// where the pairs' own steps, each from its own points, agree (ObstacleOptions).
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "io/geotiff_io.h"
#include "mapping/elevation_error.h"

namespace lunarnav::mapping {

/// The vehicle's limits that make a cell an obstacle (sec. 3.1: "an obstacle 20 cm tall").
struct ObstacleOptions {
  /// A cell whose highest point is this much above the lowest point of its 3 x 3
  /// neighbourhood (each neighbour's carried to the cell along the local ground slope, so an
  /// even slope is no step) is a step obstacle, metres, > 0 (the vehicle file's
  /// requirements.obstacle_height_m; the paper's 20 cm).
  double step_height_m = 0.2;
  /// A cell whose ground slope (from the neighbours' elevations, the smaller one-sided
  /// difference along each axis, so that a step does not make its flat neighbours steep) is
  /// above this is a slope obstacle, degrees, in (0, 90) (the vehicle file's max_slope_deg).
  double max_slope_deg = 30.0;
  /// Cells with fewer points are not judged (no-data in the obstacle layer), >= 1.
  int min_points = 3;
  /// The step rule's highest point of a cell: no higher than the mean plus this many
  /// roughnesses (one stray point of forty frames is no step); > 0, infinity: the raw highest.
  double extreme_k = 2.0;
  /// The step rule's lowest point of a cell, which it takes as the ground's level beside a
  /// cell: no lower than the mean minus this many roughnesses; > 0, infinity: the raw lowest.
  /// Below extreme_k: a top is an obstacle's evidence, a low only the ground's level, and with
  /// 2 on both sides flat ground of 4.5 cm roughness (a rough road, a rail groove's wrong
  /// matches) made 18 cm steps of its noise.
  double low_extreme_k = 1.5;
  /// A step is flagged when the measured step exceeds step_height_m minus this, metres, in
  /// [0, step_height_m): the measure falls short of a rock's height (a cell's highest points are
  /// seldom the rock's very top, and the extremes are trimmed), and a planner would rather
  /// avoid a 19 cm step than drive into a 21 cm one.
  double step_tolerance_m = 0.02;
  /// Steps within a pair: a step is flagged only where the pairs that measured one themselves
  /// (CellStats::step1, step2: each pair's own top of the cell over its own lows around it)
  /// agree it passes the threshold: 1: one pair's step does; 2: the second highest pair's
  /// (the highest where one pair measured it); 0: off, the fused extremes alone. The fused
  /// extremes compare a cell's top from one pair with a neighbour's low from another, and two
  /// pairs' heights differ by their poses' errors: a GPS/INS pose 3-5 cm off in height made flat
  /// road 5-6 cm rough and a third of a city drive's obstacle cells phantoms.
  int pair_step_support = 1;
  void Validate() const;
  nlohmann::json ToJson() const;
};

struct TerrainMapOptions {
  double cell_m = 0.25;  ///< Cell size, metres, in [0.01, 10] (sec. 3.4: "a 25cm grid").
  /// Gate: a point is rejected when |z - median| > gate_k sqrt(sigma_z^2 + spread^2 +
  /// gate_floor_m^2), median and spread (1.4826 x the median absolute deviation) over the
  /// frame's points in the cell. > 0; infinity turns the gate off.
  double gate_k = 3.0;
  double gate_floor_m = 0.02;  ///< Metres, >= 0.
  int gate_min_points = 3;     ///< Cells with fewer of the frame's points are not gated, >= 1.
  /// Visibility: walking up an image column (rays rising, each farther ray above the nearer
  /// ones), a point is rejected as floating when r + k s + floor < L, r its horizontal distance
  /// from the camera, s that distance's predicted error, L the largest r - k s of the rays below
  /// it (each the least of three consecutive rays, so that one stray far match does not veto
  /// the column): a ray below it reached farther, so in a 2.5-D world the ground under the
  /// point is lower than that ray and the point hangs in the air. > 0; infinity turns it off.
  double visibility_k = 3.0;
  double visibility_floor_m = 0.1;  ///< Metres, >= 0.
  /// Support: in the same walk, a point that stands more than this above the last point kept
  /// below it in its column, and less than sqrt(3) times as much farther from the camera (a
  /// rise steeper than 30 deg), is rejected as unsupported: the face between them would have been
  /// seen by the rows between, and was not (adjacent pixels of a real face differ by far less),
  /// metres, > 0; infinity turns it off.
  double support_rise_m = 0.2;
  /// Carving (see above): a cell's observations more than this above the ceiling that two
  /// frames' rays set over it are left out of the layers, metres, >= 0; infinity turns it off.
  /// Needs the rays' origin (the rig's error model); without it nothing is carved.
  double carve_tolerance_m = 0.2;
  /// The stretch of each ray that carves: the last this many metres (horizontally) before its
  /// point, less the point's own uncertainty (twice its horizontal error and half a cell),
  /// metres, > 0. Near its point a ray runs close over the ground, where it says most.
  double carve_reach_m = 2.0;
  /// Moved on: a cell's observations of one height bin are left out of the layers when two
  /// pairs after the last of them saw the cell lower, their top (the highest that a second pair
  /// or three points of one pair reach) below those observations' mean and more than this below
  /// their top: what stood there moved on (the cyclist who rode off, the van that drove away),
  /// as later pairs saw. Carving needs rays that pass over the cell; a pair that sees the
  /// cell's own ground says the same. Metres, > 0; infinity turns it off. The default is the
  /// paper's obstacle height less the step rule's tolerance: what would make an obstacle.
  double moved_height_m = 0.18;
  /// Hidden observations: a frame's observation of a cell is left out when the ray to it
  /// passes, within the carving stretch, through another cell of the same frame more than this
  /// below that cell's lowest point (the ray would have met the ground the frame sees there:
  /// a wrong match, typically behind an object's edge where one camera sees what the other
  /// cannot), metres, >= 0; infinity turns it off. Needs the rig's error model.
  double hidden_tolerance_m = 0.1;
  /// The ground a hidden ray is tested against: this quantile of the frame's points in the
  /// cell, in [0, 0.5]; 0: its lowest point. A flat cell's lowest point is its noise's tail
  /// (12 cm under a road 4 cm rough), the 10th percentile stays near the ground, while a cell
  /// holding an object's foot keeps the foot when a tenth of its points lie there.
  double hidden_ground_quantile = 0.1;
  /// The least error of one frame's estimate of a cell, whatever its points' count and
  /// precision (their errors are correlated: one pose, one rig, overlapping windows), metres,
  /// > 0. A frame's observation of a cell weighs 1 / (mean point variance + this^2).
  double frame_floor_m = 0.02;
  /// Predicted elevation error of points without an xyz_sigma map, metres, > 0.
  double default_sigma_m = 0.05;
  /// Points farther than this from the mast base (horizontally, vehicle frame) are ignored,
  /// metres, > 0; infinity keeps them all.
  double max_range_m = std::numeric_limits<double>::infinity();
  /// Points whose predicted horizontal error (xyz_sigma's X and Y, or the rig's error model)
  /// exceeds this many cells are ignored: such a point may fall in any of the cells around its
  /// own, and the map's resolution is worth more than its reach (for the paper's rig, beyond
  /// about 13 m with a 1 px disparity error). > 0; infinity keeps them. Points with no predicted
  /// error (default_sigma_m) are kept at any range.
  double max_horizontal_sigma_cells = 1.0;
  /// Points whose predicted horizontal error passes max_horizontal_sigma_cells but not this
  /// many cells count as ground only: kept where they lie within ground_gate_m of the pair's
  /// ground plane (a robust fit to its other points), left out elsewhere. On even ground a
  /// point's height hardly depends on the cell it falls in, while a walker's or a car's points
  /// a cell or two off make a phantom. So the band's far corners (there the error along the
  /// rays passes a cell before the distance ahead reaches the band's far edge: the rig's
  /// default search bounds the distance ahead, not the distance to the side) are mapped where
  /// they are ground, and left empty where something stands. <= max_horizontal_sigma_cells: off.
  double ground_sigma_cells = 1.5;
  /// The ground-only points' gate: their largest height from the pair's ground plane, metres, > 0.
  double ground_gate_m = 0.1;
  /// Lone objects: of the points too uncertain for a cell (above), those standing more than
  /// this over the pair's ground plane are kept where the pair placed nothing standing that
  /// high within kLoneObjectReachCells cells of them: an object the pair sees only at its
  /// view's far corners (a bush at the band's far end, beside the road) is mapped, a cell or so
  /// off at worst, while the spill of an object the pair placed well (a walker's or a car's
  /// points a cell or two off, beside its well-placed points) stays out. Metres, > 0; infinity:
  /// off (the points are left out, as before 2026-12-06). The default, twice the paper's
  /// obstacle height, lies above the far corners' noise (0.2 made a 45 cm cell on odometry 04).
  double lone_object_height_m = 0.4;
  /// Depth edges: a point that has, within edge_margin_px along its image row, a point more
  /// than edge_step_px of disparity nearer than the point's own surface carried there (along
  /// its slope where it is locally linear: a plane's disparity is linear along a rectified
  /// row) is left out where it stands more than edge_height_m over the ground of the cell it
  /// falls in (the 10th percentile of the pair's other points there, at least gate_min_points
  /// of them; else the lowest such ground of the cells within two cells around it; where the
  /// pair sees none there, inside a bush or a hedge, the point stays: nothing judges it).
  /// There the matching window straddled the nearer surface's silhouette and the
  /// point's depth mixes the two surfaces: a pedestrian's edge matched between him and what
  /// lies behind him stands half a metre behind him. On the ground such a point stays (a
  /// mixed depth moves it along the ground). Needs the rig's error model (the points'
  /// disparities). edge_margin_px in 0..64 (0: off), edge_step_px > 0, edge_height_m >= 0.
  int edge_margin_px = 6;
  double edge_step_px = 1.0;
  double edge_height_m = 0.25;
  /// Cells that fewer pairs saw are left out of the map's layers (kept in its sums, so that a
  /// later pair, a resumed run or a merged map confirms them), >= 1. 1 (every cell): the ground
  /// at the common view's edges is often seen by one pair only (a rock 3 m to the side, seen
  /// once before it leaves the view); 2 was the default while wrong matches of one pair made
  /// fringe cells 30-50 cm off, which the border rule and the far guard now remove.
  int min_frames = 1;
  /// Side of the square window centred at the vehicle that the map keeps (the navigation
  /// map of sec. 3), metres; nothing = the whole traverse.
  std::optional<double> window_m;
  /// The largest map, in cells of its bounding box (its rasters' width x height): 2^22, about
  /// 512 m x 512 m of 25 cm cells and 1 GB of layers, state and preview at most (some 240
  /// bytes a cell: 7.9 million cells took 1.9 GB). A pair whose
  /// points would make the map larger (a pose or points far from the others) is refused,
  /// named; a longer traverse keeps a window (window_m). >= 1.
  std::int64_t max_cells = std::int64_t{1} << 22;
  ObstacleOptions obstacles;
  void Validate() const;  ///< std::invalid_argument naming the field.
  nlohmann::json ToJson() const;
};

/// Points of one pair that must reach a cell's top for the obstacle rule to trust it without
/// a second pair (CellStats::z_max2).
inline constexpr int kTopSupport = 3;

/// The height bins that keep a cell's observations apart for carving: kHeightBinM at first,
/// doubled (neighbouring bins merged) whenever a cell would hold more than kMaxHeightBins.
inline constexpr double kHeightBinM = 0.1;
inline constexpr int kMaxHeightBins = 4;
/// Rays of one frame that must pass below a height over a cell for the frame to set it.
inline constexpr int kCeilingSupport = 3;

/// What one cell has accumulated: over the frames that saw it, weighted sums of each frame's
/// observation (weight W = 1 / (sigma^2 + frame_floor^2), value m its points' weighted mean;
/// sum_wzz adds W (m^2 + v), v the points' weighted variance about m, so that the spread holds
/// both the points' scatter and the frames' disagreement), the accepted points' extremes,
/// counts and the time of the last frame that saw it.
struct CellStats {
  double sum_w = 0, sum_wz = 0, sum_wzz = 0;
  float z_min = std::numeric_limits<float>::infinity();
  float z_max = -std::numeric_limits<float>::infinity();
  /// The confirmed extremes, which one pair's stray points cannot set. z_min2: the second
  /// lowest of the pairs' lowest points (a second pair confirms it). z_max2: the highest top
  /// that a second pair or three points of one pair reach: the greater of the second highest
  /// of the pairs' highest points and each pair's own third highest point (kTopSupport). A
  /// rock near the edge of the view is often seen whole by one pair and only its foot by the
  /// next; a lone stray point, or two, reaches neither.
  float z_min2 = std::numeric_limits<float>::infinity();
  float z_max2 = -std::numeric_limits<float>::infinity();
  /// The pairs' own steps at the cell (BinFrame: a pair's top of the cell over the lowest of
  /// its lows around it, all of that pair's points, so that two pairs' pose errors make no
  /// step): the highest and the second highest, metres (-infinity: none), and how many pairs
  /// measured one (step_pairs: those that judged the cell and a neighbour).
  float step1 = -std::numeric_limits<float>::infinity();
  float step2 = -std::numeric_limits<float>::infinity();
  std::uint32_t step_pairs = 0;
  std::uint32_t count = 0;     ///< Accepted points.
  std::uint32_t rejected = 0;  ///< Points the gate rejected.
  std::uint32_t frames = 0;    ///< Pairs that added points.
  double last_t_s = -std::numeric_limits<double>::infinity();  ///< Time of the last frame that added points.
  /// Time of the second last frame that added points (-infinity: one frame at most).
  double last_t2_s = -std::numeric_limits<double>::infinity();
  /// Free space over the cell: the lowest and second lowest of the frames' ceilings (a frame's
  /// ceiling: the kCeilingSupport-th lowest height at which its rays crossed the cell), metres;
  /// infinity: none.
  float ceiling = std::numeric_limits<float>::infinity();
  float ceiling2 = std::numeric_limits<float>::infinity();
  /// Accepted points and frames' observations that carving left out (TerrainGrid::Find only;
  /// they are not in the sums above).
  std::uint32_t carved_points = 0, carved_frames = 0;
  /// Accepted points and frames' observations left out as moved on (TerrainGrid::Find only).
  std::uint32_t moved_points = 0, moved_frames = 0;

  void Merge(const CellStats& other);
  double Mean() const { return sum_wz / sum_w; }
  /// Standard deviation of the accepted points about the mean (roughness): each frame's
  /// points' spread and its offset from the mean, weighted by the frames' weights.
  double StdDev() const;
  /// Predicted error of the mean, 1 / sqrt(sum of the frames' weights).
  double Sigma() const;
};

/// A cell index of the world-anchored lattice.
struct CellIndex {
  std::int64_t i = 0, j = 0;
};

/// One frame's contribution: the cells it touched with what it adds to each.
struct FrameContribution {
  std::vector<std::pair<CellIndex, CellStats>> cells;
  long points_in = 0;        ///< Valid points (finite XYZ) in the frame.
  long points_fused = 0;     ///< Accepted.
  long points_rejected = 0;  ///< Rejected by the gate.
  long points_floating = 0;  ///< Rejected by the visibility rule (a farther ray passes beneath).
  long points_unsupported = 0;  ///< Rejected by the support rule (a rise with no face seen below).
  long points_out_of_range = 0;
  long points_ground_only = 0;  ///< Kept as ground only (TerrainMapOptions::ground_sigma_cells).
  long points_off_ground = 0;   ///< Too uncertain for a cell and off the pair's ground plane: left out.
  long points_lone_object = 0;  ///< Too uncertain for a cell, kept as a lone object (lone_object_height_m).
  long points_edge = 0;         ///< Standing at a depth edge, behind a nearer surface (edge_margin_px).
  long rays_cast = 0;      ///< Rays that set ceilings (carving).
  long points_hidden = 0;  ///< Points of observations the ray to them shows hidden (left out).
};

/// Bins one frame's points into cells and gates them (the fusion described above).
/// @param xyz_vehicle  CV_32FC3, the vehicle-frame points (NaN = none), stereo-batch's xyz map.
/// @param sigma_vehicle  CV_32FC3 of the same size (the predicted error per axis; channel 2,
///        the Z error, weights the point) or empty: then `error_model`'s sigma_Z of each point,
///        or without a model options.default_sigma_m for all.
/// @param world_from_vehicle  the vehicle's pose.
/// @param t_s  the frame's time (recorded as the cells' last time).
/// @param y_min_m, y_max_m  points with vehicle Y outside this interval are left out (counted
///        out of range): the distance interval I_Y the pair was requested for (sec. 3.3), whose
///        disparity range makes matches outside it unreliable.
/// The rays that carve start at `error_model`'s reference camera: without a model, the frame
/// sets no ceiling.
FrameContribution BinFrame(const cv::Mat& xyz_vehicle, const cv::Mat& sigma_vehicle,
                           const Eigen::Isometry3d& world_from_vehicle, double t_s, const TerrainMapOptions& options,
                           const ElevationErrorModel* error_model = nullptr,
                           double y_min_m = -std::numeric_limits<double>::infinity(),
                           double y_max_m = std::numeric_limits<double>::infinity());

/// The map: cells in tiles allocated on demand.
class TerrainGrid {
 public:
  explicit TerrainGrid(double cell_m);
  TerrainGrid(TerrainGrid&&) noexcept;
  TerrainGrid& operator=(TerrainGrid&&) noexcept;
  ~TerrainGrid();

  double cell_m() const { return cell_m_; }
  void Add(const FrameContribution& frame);
  /// Adds another map's cells (same cell size; std::invalid_argument otherwise).
  void Merge(const TerrainGrid& other);
  /// Drops every tile that lies wholly outside the square of side `side_m` centred at
  /// (x, y): the vehicle-centred window.
  void KeepWindow(double x_m, double y_m, double side_m);
  /// The cell's accumulation, its observations more than `carve_tolerance_m` above its
  /// ceiling2 left out (counted in carved_points and carved_frames; infinity: none) and those
  /// that moved on by `moved_height_m` (TerrainMapOptions; counted in moved_points and
  /// moved_frames; infinity: none), or nothing when no point ever reached it.
  std::optional<CellStats> Find(CellIndex c, double carve_tolerance_m = std::numeric_limits<double>::infinity(),
                                double moved_height_m = std::numeric_limits<double>::infinity()) const;
  std::size_t TileCount() const;
  std::size_t MappedCells() const;  ///< Cells with at least one accepted point (carving aside).
  /// Smallest cell box containing every mapped cell: {i0, j0, i1, j1} inclusive, or nothing.
  std::optional<std::array<std::int64_t, 4>> MappedBounds() const;

  /// The exact accumulators as a Float64 raster over every cell that holds a point or a
  /// ceiling, for --resume and merging (docs/formats.md: the cell's ceiling, ceiling2,
  /// rejected and bin level, then per height bin its index and sums).
  io::GeoRaster ToStateRaster() const;
  /// The inverse of ToStateRaster; also reads the states of earlier versions (one band set,
  /// no ceilings). @throws InputError naming `source` for a raster that is not a state raster
  /// or whose origin is off the lattice.
  static TerrainGrid FromStateRaster(const io::GeoRaster& raster, const std::string& source);

 private:
  struct Record;
  struct Tile;
  Record* Cell(CellIndex c);
  const Record* FindRecord(CellIndex c) const;
  /// Smallest box of the cells holding a point or a ceiling.
  std::optional<std::array<std::int64_t, 4>> KnownBounds() const;
  double cell_m_;
  std::unordered_map<std::uint64_t, std::unique_ptr<Tile>> tiles_;
};

/// Dense layers over a cell box, north row first (GeoTIFF order).
struct MapLayers {
  double x_west_m = 0, y_north_m = 0, cell_m = 0.25;
  cv::Mat elevation_m, min_m, max_m, count, roughness_m, sigma_m, last_t_s, frames;  ///< CV_32F, NaN = unmapped.
  cv::Mat obstacle;  ///< CV_32F: 0 free, 1 step, 2 slope, 3 both; NaN = not judged.
  /// The time of the last pair that added points, exactly (CV_64F; a Float32 layer holds a Unix
  /// time to a minute or two), or empty when not known (the planner's causal reading of a map).
  cv::Mat last_t_exact_s;
  /// Cell (col, row) of world (x, y), or false when outside.
  bool CellOf(double x_m, double y_m, int* col, int* row) const;
};

/// What carving left out of a map's layers.
struct CarveCounts {
  long points = 0;         ///< Accepted points of the observations carved.
  long observations = 0;   ///< Frames' observations of cells carved.
  long points_moved_on = 0;        ///< Accepted points of the observations left out as moved on.
  long observations_moved_on = 0;  ///< Frames' observations left out as moved on.
  long cells_changed = 0;  ///< Cells that kept some of their observations (either rule).
  long cells_cleared = 0;  ///< Cells that kept none (unmapped in the layers).
};

/// The layers of `grid` over its mapped bounds (empty Mats when nothing is mapped); cells that
/// fewer than `min_frames` pairs saw are left out of the layers (NaN), not of the grid; each
/// cell's observations more than `carve_tolerance_m` above its ceiling2 and those that moved
/// on by `moved_height_m` are left out (TerrainGrid::Find), counted in `carved` when given.
MapLayers ComputeLayers(const TerrainGrid& grid, const ObstacleOptions& obstacles, int min_frames = 1,
                        double carve_tolerance_m = std::numeric_limits<double>::infinity(),
                        double moved_height_m = std::numeric_limits<double>::infinity(),
                        CarveCounts* carved = nullptr);

/// The obstacle layer (see MapLayers::obstacle) from elevation, min, max and count layers of
/// one size (CV_32F, NaN = unmapped; `count` may be empty: every mapped cell is judged).
/// `pair_step` (or empty): the step the pairs themselves measured at each cell (NaN: none did,
/// ObstacleOptions::pair_step_support); a step is flagged only where it passes too.
cv::Mat DetectObstacles(const cv::Mat& elevation_m, const cv::Mat& min_m, const cv::Mat& max_m, const cv::Mat& count,
                        double cell_m, const ObstacleOptions& options, const cv::Mat& roughness_m = cv::Mat(),
                        const cv::Mat& pair_step = cv::Mat());

/// The layers as the GeoTIFF `elevation.tif` writes them (bands in MapLayers' order, each
/// with its description and units; docs/terrain-map.md).
io::GeoRaster LayersToRaster(const MapLayers& layers);

namespace internal {

/// The padding, in columns of NaN on either side, of a row DepthEdgeRow reads; the largest
/// depth-edge margin.
inline constexpr int kEdgeRowPad = 64;

/// The depth-edge test (TerrainMapOptions::edge_margin_px) of every column of one image row:
/// edge[col] = 1 when, within `margin` px along the row, a point is more than `step` px of
/// disparity nearer than col's own surface carried there. In rectified images a plane's
/// disparity is linear along a row: where the surface is locally linear (its slopes to the
/// farthest points 2-4 px away on either side agree within 0.3 px per px) it is carried along
/// that slope, else level. A slanted surface (a parked car's side seen along the road, 0.3-0.5
/// px of disparity per px) has then no edge within it; a silhouette, where the slopes part,
/// has. `row` points at column 0 of the row's disparities (NaN: no point), readable from
/// -kEdgeRowPad to cols + kEdgeRowPad - 1 (NaN there); margin in 0..kEdgeRowPad.
void DepthEdgeRow(const float* row, int cols, int margin, float step, std::uint8_t* edge);

}  // namespace internal

}  // namespace lunarnav::mapping
