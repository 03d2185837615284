// A terrain map (terrain-map's elevation.tif) against LiDAR: the sweeps of a vehicle that
// carried one (KITTI's Velodyne .bin, PLY, PCD), each placed in the map's world by its
// vehicle's pose and the LiDAR's mounting, gridded on the map's lattice by code of its own.
// `evaluate map --lidar`; docs/evaluate.md, "Against LiDAR".
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "calib/stereo_rig.h"
#include "calib/triangulation.h"
#include "evaluation/table.h"
#include "io/geotiff_io.h"
#include "mapping/frame_poses.h"

namespace lunarnav::evaluation {

struct LidarEvalOptions {
  /// Map cells with at least this many points are scored, >= 1.
  int min_points = 3;
  /// A LiDAR cell needs this many returns (all sweeps) to be judged, >= 1.
  int min_lidar_points = 3;
  /// Flat ground: every return of the cell lies within this of the cell's median, metres...
  double flat_spread_m = 0.08;
  /// ...and no return of it or its 8 neighbours stands this far above the local ground (the
  /// lowest of the 5 x 5 cells' low returns): something stood there in some sweep, metres.
  double object_height_m = 0.15;
  /// Returns more than this above the local ground are overhead (branches, wires, signs), not
  /// relief, metres.
  double clearance_m = 3.0;
  /// LiDAR returns nearer than `min_range_m` to the sensor (the vehicle itself) or farther than
  /// `max_range_m` are not used, metres (horizontal distance): far returns graze the ground and
  /// carry the sensor's angle errors as height errors (0.1 deg of pitch is 4 cm at 25 m, 9 cm at
  /// 50 m; KITTI raw drive 0005's frames 5-36 against sweep 4 at up to 50 m: 0.4 m apart).
  double min_range_m = 3.0, max_range_m = 25.0;
  /// Obstacle precision counts a map obstacle as real when a LiDAR cell within tolerance_cells
  /// has this much relief (its highest return above the local ground), metres.
  double relief_height_m = 0.15;
  /// Recall: LiDAR objects (8-connected cells whose relief is at least this) inside the mapped
  /// band, found when a map obstacle lies within tolerance_cells of one of their cells, metres.
  double recall_height_m = 0.20;
  /// An overhang is no object: in a cell where returns show the ground (under recall_height_m
  /// over the ground's plane), what stands only this far or more over that plane (a tree's
  /// canopy, a sign on its post, seen with the ground beneath) stands on nothing, metres, > 0.
  double overhang_m = 1.5;
  int tolerance_cells = 1;
  /// A compared cell farther than this from the truth is a large error (a phantom), metres.
  double large_error_m = 0.30;
  /// The band the rig maps: ground this far ahead of a pair (vehicle-frame Y), in both images
  /// and in both cameras' lines of sight (not behind a LiDAR object), metres.
  double band_min_y_m = 0, band_max_y_m = 0;
  /// The heights the rig's search matches (the region's Z_max, vehicle frame: stereo-batch's
  /// `--z-range`), metres: an object is in the band where a pair saw its part up to this height
  /// (the part above it no pair's search matched), over any other object in the line of sight.
  double band_max_z_m = 1.0;
  /// The flat ground is also scored where the truth agrees with itself this well: the cells
  /// whose sweeps' medians (two sweeps or more) lie within this of each other, metres, > 0.
  double sweeps_agree_m = 0.02;
  /// Cells in the band (3 m wider at each end) of a pair taken farther in time than this from
  /// every sweep are not judged: what stood there then (a cyclist who rode on) no sweep shows,
  /// seconds, >= 0 (infinity: judge every cell).
  double max_sweep_gap_s = 0.3;
  void Validate() const;
  nlohmann::json ToJson() const;
};

/// One sweep in the map's world.
struct LidarSweep {
  std::string stem;
  double t_s = 0;
  Eigen::Vector3d sensor_m = Eigen::Vector3d::Zero();  ///< The LiDAR's position in the world.
  std::vector<Eigen::Vector3f> points;                 ///< World coordinates (after the range cut).
};

/// The LiDAR truth on the map's lattice (one band each, NaN where unknown): `ground_m` the
/// median return of a flat-ground cell (NaN otherwise), `relief_m` the highest return below the
/// clearance above the local ground (every cell with returns), `top_m` that highest return's
/// height (for lines of sight), `class` 0 none, 1 flat ground, 2 object (relief >=
/// object_height_m), 3 other (rough, beside an object, or sunk: low returns 0.3 m below the
/// 9 x 9 cells', a reflection), `returns`, `standing_m` the highest return over the plane
/// through the 5 x 5 cells' low returns (a slope's rise is no object), `persistence` the share
/// of the sweeps that saw the cell in which something recall_height_m tall stood there (a
/// passing car stands in few).
/// `stood_in`, when given, receives per cell (row-major on the truth's lattice) the sweeps (their
/// indices) in which something recall_height_m tall stood over that plane.
io::GeoRaster GridLidarTruth(const std::vector<LidarSweep>& sweeps, const io::GeoRaster& lattice,
                             const LidarEvalOptions& options, std::vector<std::vector<int>>* stood_in = nullptr);

/// One LiDAR object of the band (recall): its cells' centre, extent and height, and whether a
/// map obstacle lay within the tolerance of one of its cells.
struct LidarObject {
  double x_m = 0, y_m = 0;  ///< The centre of its cells, world.
  long cells = 0;
  double height_m = 0;  ///< The most it stands over the ground's plane (standing_m).
  bool found = false;
};

/// The flat ground's error over one band of lateral offset from the path (profile.csv).
struct LateralBin {
  double from_m = 0, to_m = 0;  ///< Signed offset from the pairs' path, right of travel positive.
  long cells = 0;
  double median_m = 0, rmse_m = 0;  ///< Of the map minus the LiDAR (NaN without cells).
};

struct LidarEvalResult {
  long sweeps = 0, returns = 0;
  long flat_cells = 0;           ///< LiDAR flat-ground cells.
  long flat_cells_untimely = 0;  ///< Of those, not judged: a pair far in time from every sweep saw them.
  long cells_compared = 0;       ///< Flat cells the map holds (>= min_points).
  double rmse_m = 0, median_m = 0, mean_m = 0, p90_abs_m = 0, max_abs_m = 0;
  /// The same error by lateral offset from the path (1 m bands, the pairs' positions joined in
  /// order and carried 100 m on along the first and last headings): where it grows.
  std::vector<LateralBin> lateral_profile;
  /// The same over the flat cells whose sweeps agree within sweeps_agree_m (with the truth's
  /// band `sweep_spread_m`, MeasureSweepConsistency's; else none): where a pose error is not
  /// taken for a map error.
  long agree_cells = 0;
  double agree_rmse_m = std::numeric_limits<double>::quiet_NaN();
  double agree_median_m = std::numeric_limits<double>::quiet_NaN();
  long cells_large_error = 0;
  double large_error_x_m = std::numeric_limits<double>::quiet_NaN();  ///< Where the largest error lies.
  double large_error_y_m = std::numeric_limits<double>::quiet_NaN();
  long band_cells = 0, band_mapped = 0;  ///< Flat cells in the band of some pair, and mapped.
  double coverage = 0;
  long obstacle_map = 0, obstacle_judged = 0, obstacle_tp = 0;
  double precision = 0;
  long objects = 0, objects_found = 0;  ///< LiDAR objects in the band.
  std::vector<LidarObject> object_list;  ///< Each of them (objects.csv).
  double object_recall = 0;
  /// The truth's own consistency: over flat cells that two sweeps saw (>= min_lidar_points
  /// each), the difference of the two sweeps' medians: RMS, median |.|, count.
  long sweep_pairs = 0;
  double sweep_rms_m = 0, sweep_median_abs_m = 0;
  /// Each pair against the sweep nearest in time (with stereo points): the median over a
  /// pair's flat cells of its points' median minus the sweep's; over the pairs, the median and
  /// largest |offset| and the pairs measured; over the pairs within max_sweep_gap_s of their
  /// sweep, the median offset (signed: the stereo's height over the LiDAR's at one instant, what
  /// the sensors' calibration leaves between them, no pose between).
  long pairs_measured = 0;
  double pair_offset_median_m = std::numeric_limits<double>::quiet_NaN();
  double pair_offset_median_abs_m = std::numeric_limits<double>::quiet_NaN();
  double pair_offset_max_abs_m = std::numeric_limits<double>::quiet_NaN();
  /// The same instant in the images (PairDisparityOffset, the pairs within max_sweep_gap_s of
  /// their sweep): the median over those pairs of the stereo's disparity minus the LiDAR's at
  /// the pixels where the sweep's flat ground falls, px. Constant over the distance ahead, an
  /// offset of the images' calibration (the matcher's own: `evaluate disparity`'s bias); NaN
  /// without the pairs' disparity maps.
  long pairs_disparity_measured = 0;
  double pair_disparity_offset_px = std::numeric_limits<double>::quiet_NaN();
  /// What the run could not measure and why (also printed as it arises; summary.json's
  /// `warnings`).
  std::vector<std::string> warnings;
  nlohmann::json ToJson() const;
  Table ToTable() const;
  std::string BriefReport() const;
};

/// Scores `map` against the gridded truth (GridLidarTruth on the map's lattice) over the pairs'
/// poses `pairs` (the band: `rig`'s images, options.band_*). `sweep_times_s`: the sweeps'
/// times, for options.max_sweep_gap_s (empty: every cell is judged). `untimely`, when given,
/// receives the cells not judged for time (CV_8UC1 on the truth's lattice, 1 = not judged).
/// Recall's objects: with `stood_in` (GridLidarTruth's) and the sweeps' times, an object cell
/// counts where a pair saw its top in the band while it stood there (in the sweep nearest the
/// pair: a car driving ahead stands in every sweep somewhere, each time elsewhere); without,
/// where it stood in most of the sweeps that saw it. `band`, when given, receives the cells the
/// coverage and recall count (CV_8UC1 on the truth's lattice: 1 flat ground a timely pair saw
/// in the band, 2 an object's top seen there while it stood, 0 neither).
LidarEvalResult EvaluateMapAgainstLidar(const io::GeoRaster& map, const io::GeoRaster& truth,
                                        const std::vector<mapping::FramePose>& pairs, const calib::StereoRig& rig,
                                        const LidarEvalOptions& options, const std::vector<double>& sweep_times_s = {},
                                        cv::Mat* untimely = nullptr,
                                        const std::vector<std::vector<int>>* stood_in = nullptr,
                                        cv::Mat* band = nullptr);

/// The sweep-to-sweep consistency of the truth (LidarEvalResult::sweep_*); with `spread`, each
/// flat cell's largest difference between two sweeps' medians (CV_32FC1 on the truth's lattice,
/// NaN where fewer than two sweeps saw the cell with min_lidar_points returns).
void MeasureSweepConsistency(const std::vector<LidarSweep>& sweeps, const io::GeoRaster& truth,
                             const LidarEvalOptions& options, LidarEvalResult* result, cv::Mat* spread = nullptr);

/// One pair against a sweep on the truth's flat ground: over the flat cells where the pair's
/// points (world frame, 3 or more) and the sweep's returns (min_lidar_points or more) both
/// fall, the median of (the points' median minus the returns' median); NaN with fewer than 10
/// such cells.
double PairOffset(const std::vector<Eigen::Vector3f>& stereo_world, const LidarSweep& sweep,
                  const io::GeoRaster& truth, const LidarEvalOptions& options);

/// One pair against a sweep of the same instant in the pair's reference image: the sweep's
/// returns on the truth's flat ground within the band (options.band_*, vehicle Y at the pair's
/// pose `world_from_vehicle`) projected into the rectified pair (calib::ProjectToRectified),
/// and at each one's pixel the pair's `disparity` (NaN, +-inf: none) minus the return's; the
/// median of the differences within 3 px (a wrong match, or a return the camera does not see
/// there, is no offset); NaN with fewer than 50 of them.
double PairDisparityOffset(const cv::Mat& disparity, calib::ReferenceImage reference, const LidarSweep& sweep,
                           const io::GeoRaster& truth, const Eigen::Isometry3d& world_from_vehicle,
                           const calib::StereoRig& rig, const LidarEvalOptions& options);

/// The pairs' offsets (NaN: not measured) and each pair's time from its sweep into
/// LidarEvalResult's pairs_measured, pair_offset_median_abs_m and pair_offset_max_abs_m (every
/// pair measured) and pair_offset_median_m (signed, the pairs within max_sweep_gap_s).
void SummarizePairOffsets(const std::vector<double>& offsets_m, const std::vector<double>& gaps_s,
                          const LidarEvalOptions& options, LidarEvalResult* result);

/// `evaluate map --lidar`.
struct LidarMapCommand {
  std::filesystem::path map_dir, lidar_dir, output_dir;
  /// The LiDAR's mounting: a KITTI calib.txt (Tr) or calib_velo_to_cam.txt; empty: the clouds
  /// are in the vehicle frame.
  std::filesystem::path lidar_calib;
  bool lidar_in_world = false;  ///< The clouds are in the map's world already (no poses).
  std::filesystem::path rig;
  std::filesystem::path poses_csv, trajectory, frame_times;
  /// The pairs taken: a stereo pair directory (io::ListStereoPairs); empty: the map's frames.csv.
  std::filesystem::path pairs_dir;
  /// stereo-batch's output (xyz/<stem>.exr) for each pair against its nearest sweep; optional.
  std::filesystem::path stereo_dir;
  /// The band; NaN: the rig's default search (calib::SelectGroundWindow).
  double band_min_y_m = std::numeric_limits<double>::quiet_NaN();
  double band_max_y_m = std::numeric_limits<double>::quiet_NaN();
  /// The search's heights (stereo-batch's --z-range); NaN: its default, -0.5:1 m.
  double z_min_m = std::numeric_limits<double>::quiet_NaN();
  double z_max_m = std::numeric_limits<double>::quiet_NaN();
  LidarEvalOptions options;
  int num_threads = 0;
};

namespace internal {

/// The signed distance of points from a polyline (right of travel positive): the nearest of
/// its segments (the first in order among equally near ones), found through a grid of buckets
/// of `bucket_m` holding the segments that cross them, searched in rings around the point until
/// no farther ring can hold a nearer one: the same as the scan of every segment, at the cost
/// of the segments near the point (a drive of thousands of pairs against a map's every cell).
class PathOffsets {
 public:
  explicit PathOffsets(std::vector<Eigen::Vector2d> path, double bucket_m = 4.0);
  /// NaN when the path has no segment of nonzero length.
  double Offset(const Eigen::Vector2d& w) const;

 private:
  std::int64_t Key(std::int64_t bx, std::int64_t by) const { return bx * kStride + by; }
  static constexpr std::int64_t kStride = std::int64_t{1} << 32;
  std::vector<Eigen::Vector2d> path_;
  double bucket_m_;
  Eigen::Vector2d origin_ = Eigen::Vector2d::Zero();
  std::int64_t bx0_ = 0, bx1_ = -1, by0_ = 0, by1_ = -1;  // the buckets' extent
  std::unordered_map<std::int64_t, std::vector<int>> buckets_;
};

}  // namespace internal

/// Reads the map, the sweeps and the poses, scores, writes OUT_DIR/lidar.{csv,json,md},
/// cells.csv (every flat cell: truth, map, error), error.png (the picture) and summary.json.
LidarEvalResult RunLidarMapEvaluation(const LidarMapCommand& command, const nlohmann::json& invocation);

}  // namespace lunarnav::evaluation
