// The `terrain-map` run: a stereo-batch output directory and the vehicle's poses in, the
// terrain map (GeoTIFF layers, obstacles, preview) out. docs/terrain-map.md.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calib/triangulation.h"
#include "mapping/ground_alignment.h"
#include "mapping/terrain_grid.h"
#include "util/timer.h"

namespace lunarnav::mapping {

struct TerrainMapRunOptions {
  TerrainMapOptions map;
  /// stereo-batch's output directory (xyz/<stem>.exr, xyz_sigma/<stem>.exr when present);
  /// empty: no new frames (only --merge).
  std::filesystem::path stereo_dir;
  /// Only these stems of the stereo directory (each must be there); empty: every one. The
  /// closed loop (map-loop) adds its pairs one at a time.
  std::vector<std::string> stems;
  /// Poses: the simulator's truth/poses.csv, or a trajectory with a frame-times file.
  std::filesystem::path poses_csv, trajectory, frame_times;
  /// Rectified rig of the run (rectify's rig.json): the points' predicted errors from its
  /// geometry (ElevationErrorModel, sigma_d_px) instead of reading xyz_sigma/; empty: read
  /// xyz_sigma/<stem>.exr when present, else TerrainMapOptions::default_sigma_m.
  std::filesystem::path rig;
  double sigma_d_px = 1.0;  ///< Disparity error for the rig's error model, px, > 0.
  /// The disparity maps' reference image (the rays of the carving, hidden and depth-edge rules
  /// start at its camera). Unset: the one stereo-batch's summary.json in stereo_dir records,
  /// else the right image (stereo-batch's default).
  std::optional<calib::ReferenceImage> reference;
  /// The requests the pairs were matched with (`stereo-batch --requests`, plan-windows'
  /// requests.csv): a listed pair's points outside its Y interval are left out. Empty: none.
  std::filesystem::path requests;
  /// Output directories of earlier runs on disjoint sets of frames, merged into this map.
  std::vector<std::filesystem::path> merge_maps;
  bool resume = false;       ///< Continue the map in the output directory, skipping fused frames.
  /// Attitude from the ground (ground_alignment.h): each pair, in time order, brought onto the
  /// ground the pairs before it mapped (resumed and merged maps included) before it is fused;
  /// frames.csv then holds the corrected poses. Unset: the poses as given.
  std::optional<GroundAlignmentOptions> align;
  bool write_preview = true;  ///< preview.png.
  int num_threads = 0;        ///< Frames read in parallel; 0 = all cores.
  /// Shard K of N of the stereo directory's frames (the stems in name order, every N-th from
  /// the K-th, as stereo-batch shards its pairs): shard maps hold disjoint frames and merge
  /// (--merge) into the map of all. N = 1: every frame. A rolling window needs all frames.
  int shard_index = 0, shard_count = 1;
  bool show_progress = true;
  void Validate() const;  ///< std::invalid_argument for missing or conflicting inputs.
};

struct TerrainMapRunSummary {
  long frames_total = 0, frames_fused = 0, frames_resumed = 0, frames_merged = 0;
  long points_in = 0, points_fused = 0, points_rejected = 0, points_floating = 0, points_unsupported = 0,
       points_out_of_range = 0;
  long mapped_cells = 0, obstacle_cells = 0;
  long frames_without_points = 0;  ///< This run's pairs whose XYZ arrays held no valid point.
  long rays_cast = 0;              ///< This run's rays that set ceilings (carving; with a rig only).
  long points_hidden = 0;          ///< Points of observations the rays to them show hidden (with a rig only).
  long points_ground_only = 0;     ///< Kept as ground only (TerrainMapOptions::ground_sigma_cells).
  long points_off_ground = 0;      ///< Too uncertain for a cell and off their pair's ground plane.
  long points_lone_object = 0;     ///< Too uncertain for a cell, kept as a lone object (lone_object_height_m).
  long points_edge = 0;            ///< Standing at a depth edge, behind a nearer surface.
  CarveCounts carved;              ///< What carving left out of the layers.
  std::vector<GroundAlignment> alignments;  ///< With options.align: one per pair fused, in time order.
  std::vector<std::string> warnings;  ///< Printed as they arise and kept in summary.json.
  /// Where the points came from: the pairs' disparity maps triangulated with the rig, or the XYZ arrays.
  std::string points_source;
  /// With the disparity maps: what showed them to be the XYZ arrays' points (stereo-batch's
  /// summary.json recording the same rig and reference image, or the first pair's XYZ array
  /// compared bit for bit); empty otherwise.
  std::string points_check;
  /// The disparity maps' reference image the run used (TerrainMapRunOptions::reference).
  calib::ReferenceImage reference = calib::ReferenceImage::kRight;
  double seconds = 0, fuse_seconds = 0, fuse_cpu_seconds = 0, write_seconds = 0;
  /// Of fuse_cpu_seconds, the CPU time the threads spent getting the points (the EXR decoding, or the
  /// disparity maps read and triangulated).
  double read_cpu_seconds = 0;
  /// Every stage in the order it ran (docs/performance.md's profile): the per-pair stages as
  /// their threads' CPU time summed over the pairs, the others as wall time.
  util::StageTimes stage_seconds;
  double peak_memory_mib = 0;
  std::string BriefReport() const;  ///< e.g. "40 frames, 9.1 M points fused; 12,345 cells, 17 obstacle cells; 3.2 s".
};

/// Runs terrain-map: checks every input (a pair without a pose, a non-finite pose, an XYZ
/// map of another size than the run's first or than its xyz_sigma map are InputErrors naming
/// the stem) before writing anything, fuses the frames in time order, and writes OUT_DIR/
/// elevation.tif, state.tif, frames.csv, preview.png and summary.json, each atomically and
/// only when every frame was fused.
TerrainMapRunSummary RunTerrainMap(const TerrainMapRunOptions& options, const std::filesystem::path& output_dir,
                                   const nlohmann::json& invocation = nullptr);

}  // namespace lunarnav::mapping
