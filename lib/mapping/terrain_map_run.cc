#include "mapping/terrain_map_run.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <ctime>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include "calib/stereo_rig_io.h"
#include "calib/triangulation.h"
#include "io/atomic_file.h"
#include "io/float_array_io.h"
#include "io/geotiff_io.h"
#include "io/image_io.h"
#include "io/json_io.h"
#include "io/stereo_pairs.h"
#include "mapping/frame_poses.h"
#include "mapping/map_preview.h"
#include "stereo/batch.h"
#include "stereo/window_requests.h"
#include "util/check.h"
#include "util/errors.h"
#include "util/format.h"
#include "util/log.h"
#include "util/parallel.h"
#include "util/progress.h"
#include "util/resources.h"
#include "util/summary.h"
#include "util/timer.h"

namespace lunarnav::mapping {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

/// Whether stereo-batch's summary.json in `stereo_dir` records `rig` and `reference` as the rig
/// and reference image it matched and triangulated with: its XYZ arrays are then the rig's
/// triangulation of its disparity maps (calib::TriangulateDisparity; stereo-batch redoes a
/// resumed pair made with another rig, so the summary's rig is every pair's). False when
/// there is no such summary, it cannot be read, or it records another rig.
bool StereoSummaryRecordsRig(const fs::path& stereo_dir, const calib::StereoRig& rig,
                             calib::ReferenceImage reference) {
  const fs::path path = stereo_dir / "summary.json";
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return false;
  try {
    const json summary = io::ReadJson(path);  // bounded in size and values
    const json& o = summary.at("options");
    return o.at("reference") == calib::ToString(reference) && o.at("geometry").at("rig") == calib::StereoRigToJson(rig);
  } catch (const std::exception&) {  // not stereo-batch's, or damaged: the pixels decide
    return false;
  }
}

constexpr double kDeg = 180.0 / M_PI;

struct FusedFrame {
  FramePose pose;
  long points_fused = 0, points_rejected = 0;
};

std::string FramesCsv(const std::vector<FusedFrame>& frames) {
  std::string s =
      "# lunarnav terrain-map: the frames fused into this map and the vehicle pose used for each (world x east,\n"
      "# y north, z up, m; heading clockwise from north, pitch nose up, roll right side down, deg)\n"
      "stem,t_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg,points_fused,points_rejected\n";
  for (const FusedFrame& f : frames) {
    const FramePose& p = f.pose;
    s += p.stem + util::Format(",%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%ld,%ld\n", p.t_s, p.x_m, p.y_m, p.z_m,
                               p.heading_rad * kDeg, p.pitch_rad * kDeg, p.roll_rad * kDeg, f.points_fused,
                               f.points_rejected);
  }
  return s;
}

// The frames of a map at full precision, with their counts: state.tif's metadata, so that the
// sums and the list of what they hold are committed by one rename.
json FramesJson(const std::vector<FusedFrame>& frames) {
  json a = json::array();
  for (const FusedFrame& f : frames) {
    const FramePose& p = f.pose;
    a.push_back({p.stem, p.t_s, p.x_m, p.y_m, p.z_m, p.heading_rad, p.pitch_rad, p.roll_rad, f.points_fused,
                 f.points_rejected});
  }
  return a;
}

// What a map's sums depend on besides its frames: a map fused with other values cannot be
// continued or merged into this one.
json FusionJson(const TerrainMapRunOptions& options, const std::string& errors) {
  const TerrainMapOptions& mo = options.map;
  auto number = [](double v) { return std::isfinite(v) ? json(v) : json("inf"); };
  return {{"cell_m", mo.cell_m},
          {"gate_k", number(mo.gate_k)},
          {"gate_floor_m", mo.gate_floor_m},
          {"gate_min_points", mo.gate_min_points},
          {"visibility_k", number(mo.visibility_k)},
          {"visibility_floor_m", mo.visibility_floor_m},
          {"support_rise_m", number(mo.support_rise_m)},
          {"carve_reach_m", mo.carve_reach_m},
          {"hidden_tolerance_m", number(mo.hidden_tolerance_m)},
          {"hidden_ground_quantile", mo.hidden_ground_quantile},
          {"frame_floor_m", mo.frame_floor_m},
          {"max_range_m", number(mo.max_range_m)},
          {"max_horizontal_sigma_cells", number(mo.max_horizontal_sigma_cells)},
          {"ground_sigma_cells", number(mo.ground_sigma_cells)},
          {"ground_gate_m", mo.ground_gate_m},
          {"lone_object_height_m", number(mo.lone_object_height_m)},
          {"edge_margin_px", mo.edge_margin_px},
          {"edge_step_px", mo.edge_step_px},
          {"edge_height_m", mo.edge_height_m},
          // The pairs' own steps (BinFrame) read these obstacle options; off: none were measured.
          {"pair_steps", mo.obstacles.pair_step_support > 0
                             ? json{{"min_points", mo.obstacles.min_points},
                                    {"extreme_k", number(mo.obstacles.extreme_k)},
                                    {"low_extreme_k", number(mo.obstacles.low_extreme_k)}}
                             : json("off")},
          {"errors", errors}};
}

// The map's size against TerrainMapOptions::max_cells: the bounding box of what was added,
// kept as a union (recomputed from the grid when it outgrows the limit, since a window may
// have dropped tiles since), so that the check costs nothing per pair until a map nears it.
class ExtentGuard {
 public:
  ExtentGuard(std::int64_t max_cells, double cell_m) : max_cells_(max_cells), cell_m_(cell_m) {}
  /// After `grid` gained cells inside `box` ({i0, j0, i1, j1}): InputError "WHAT: ..." when the
  /// grid's mapped bounds now exceed the limit.
  void Check(const TerrainGrid& grid, const std::optional<std::array<std::int64_t, 4>>& box, const std::string& what) {
    if (!box) return;
    if (!union_) {
      union_ = box;
    } else {
      for (int k = 0; k < 2; ++k) (*union_)[k] = std::min((*union_)[k], (*box)[k]);
      for (int k = 2; k < 4; ++k) (*union_)[k] = std::max((*union_)[k], (*box)[k]);
    }
    if (Cells(*union_) <= static_cast<double>(max_cells_)) return;
    union_ = grid.MappedBounds();
    if (!union_ || Cells(*union_) <= static_cast<double>(max_cells_)) return;
    const double w = static_cast<double>((*union_)[2] - (*union_)[0] + 1), h = static_cast<double>((*union_)[3] - (*union_)[1] + 1);
    throw InputError(util::Format("%s: the map would span %.0f x %.0f cells (%.3g x %.3g km), more than the largest map's "
                                  "%lld cells (--max-map-cells; a pose or points far from the others? --window-m "
                                  "keeps a window around the rover)",
                                  what.c_str(), w, h, w * cell_m_ / 1000, h * cell_m_ / 1000,
                                  static_cast<long long>(max_cells_)));
  }

 private:
  static double Cells(const std::array<std::int64_t, 4>& b) {
    return static_cast<double>(b[2] - b[0] + 1) * static_cast<double>(b[3] - b[1] + 1);
  }
  std::int64_t max_cells_;
  double cell_m_;
  std::optional<std::array<std::int64_t, 4>> union_;
};

// The cell box of a frame's contribution, or nothing when it added no cell.
std::optional<std::array<std::int64_t, 4>> ContributionBox(const FrameContribution& c) {
  std::optional<std::array<std::int64_t, 4>> b;
  for (const auto& [index, stats] : c.cells) {
    if (!b) b = std::array<std::int64_t, 4>{index.i, index.j, index.i, index.j};
    (*b)[0] = std::min((*b)[0], index.i);
    (*b)[1] = std::min((*b)[1], index.j);
    (*b)[2] = std::max((*b)[2], index.i);
    (*b)[3] = std::max((*b)[3], index.j);
  }
  return b;
}

// A map directory written by an earlier run: its grid, frames and fusion record.
struct StoredMap {
  TerrainGrid grid{1.0};
  std::vector<FusedFrame> frames;
  json fusion = json::object();
};

// Reads DIR's state.tif (the sums, the frames and the fusion values it was made with; maps of
// earlier versions list their frames in frames.csv only). `fusion`: this run's; a stored map
// made with other values is refused naming the first that differs (exit 2).
StoredMap ReadStoredMap(const fs::path& dir, const json& fusion) {
  const fs::path state = dir / "state.tif", frames_csv = dir / "frames.csv";
  LN_CHECK_INPUT(fs::is_regular_file(state))
      << dir.string() << ": not a terrain-map output (state.tif needed)";
  const io::GeoRaster raster = io::ReadGeoTiff(state);
  StoredMap m{TerrainGrid::FromStateRaster(raster, state.string()), {}};
  const double cell_m = fusion.at("cell_m").get<double>();
  LN_CHECK_ARG(std::abs(m.grid.cell_m() - cell_m) <= 1e-9 * cell_m)
      << state.string() << ": cell " << m.grid.cell_m() << " m, this run's is " << cell_m << " m";
  const auto frames_item = raster.metadata.find("lunarnav_frames");
  if (frames_item == raster.metadata.end()) {
    LN_CHECK_INPUT(fs::is_regular_file(frames_csv))
        << dir.string() << ": not a terrain-map output (state.tif lists no frames and there is no frames.csv)";
    for (const FramePose& p : ReadPosesCsv(frames_csv)) m.frames.push_back({p, 0, 0});
    return m;
  }
  const auto fusion_item = raster.metadata.find("lunarnav_fusion");
  try {
    const json stored = json::parse(fusion_item == raster.metadata.end() ? std::string("{}") : fusion_item->second);
    m.fusion = stored;
    for (const auto& [key, value] : fusion.items()) {
      LN_CHECK_ARG(stored.contains(key) && stored.at(key) == value)
          << state.string() << ": made with " << key << " " << (stored.contains(key) ? stored.at(key).dump() : "(not recorded)")
          << ", this run's is " << value.dump() << "; a map can only be continued or merged with the same fusion";
    }
    for (const json& f : json::parse(frames_item->second)) {
      FusedFrame frame;
      frame.pose.stem = f.at(0).get<std::string>();
      frame.pose.t_s = f.at(1).get<double>();
      frame.pose.x_m = f.at(2).get<double>();
      frame.pose.y_m = f.at(3).get<double>();
      frame.pose.z_m = f.at(4).get<double>();
      frame.pose.heading_rad = f.at(5).get<double>();
      frame.pose.pitch_rad = f.at(6).get<double>();
      frame.pose.roll_rad = f.at(7).get<double>();
      frame.points_fused = f.at(8).get<long>();
      frame.points_rejected = f.at(9).get<long>();
      m.frames.push_back(frame);
    }
  } catch (const json::exception& e) {
    throw InputError(state.string() + ": its frame list or fusion record is malformed (" + e.what() + ")");
  }
  return m;
}

std::vector<std::string> ListStems(const fs::path& xyz_dir) {
  io::CheckInputDirectory(xyz_dir, "(run stereo-batch with --rig to write vehicle-frame XYZ)");
  std::vector<std::string> stems;
  for (const auto& e : fs::directory_iterator(xyz_dir)) {
    if (e.path().extension() == ".exr" && !io::IsTempFileName(e.path())) stems.push_back(e.path().stem().string());
  }
  std::sort(stems.begin(), stems.end());
  return stems;
}

// A pair's points (CV_32FC3, vehicle frame, NaN where none) and the rows that hold them
// (all, when not known).
struct PairPoints {
  cv::Mat xyz;
  cv::Range rows = cv::Range::all();
};

// Attitude from the ground: the pairs in time order, each read (a sample of its pixels) and
// brought onto the ground the aligner holds (the stored map's cells, then each aligned pair),
// its pose in `todo` replaced by the corrected one. Reading runs in parallel blocks, the
// alignment in order: the result does not depend on the threads.
void AlignToGround(const TerrainMapRunOptions& options, const TerrainGrid& grid,
                   const std::function<cv::Mat(const FramePose&)>& read_points, std::vector<FramePose>* todo,
                   TerrainMapRunSummary* summary) {
  GroundAligner aligner(options.map.cell_m, *options.align);
  if (const auto bounds = grid.MappedBounds()) {
    // Only the stored cells the new pairs' samples can reach (map-loop adds one pair at a time
    // to a map that grows: seeding from all of it would cost the whole map each pair).
    const double c = options.map.cell_m, reach = options.align->max_range_m + c;
    double x0 = todo->front().x_m, x1 = x0, y0 = todo->front().y_m, y1 = y0;
    for (const FramePose& p : *todo) {
      x0 = std::min(x0, p.x_m), x1 = std::max(x1, p.x_m);
      y0 = std::min(y0, p.y_m), y1 = std::max(y1, p.y_m);
    }
    const std::int64_t i0 = std::max((*bounds)[0], static_cast<std::int64_t>(std::floor((x0 - reach) / c)));
    const std::int64_t i1 = std::min((*bounds)[2], static_cast<std::int64_t>(std::floor((x1 + reach) / c)));
    const std::int64_t j0 = std::max((*bounds)[1], static_cast<std::int64_t>(std::floor((y0 - reach) / c)));
    const std::int64_t j1 = std::min((*bounds)[3], static_cast<std::int64_t>(std::floor((y1 + reach) / c)));
    for (std::int64_t j = j0; j <= j1; ++j) {
      for (std::int64_t i = i0; i <= i1; ++i) {
        const std::optional<CellStats> cell = grid.Find({i, j}, options.map.carve_tolerance_m);
        if (cell && cell->sum_w > 0) aligner.AddReference((i + 0.5) * c, (j + 0.5) * c, cell->Mean());
      }
    }
  }
  const int threads = util::EffectiveThreadCount(options.num_threads);
  const std::size_t block = static_cast<std::size_t>(2 * threads);
  for (std::size_t b0 = 0; b0 < todo->size(); b0 += block) {
    const std::size_t n = std::min(block, todo->size() - b0);
    std::vector<std::vector<Eigen::Vector3f>> samples(n);
    util::ParallelForEachItem(n, threads, [&](std::size_t k) {
      samples[k] = SampleXyz(read_points((*todo)[b0 + k]), options.align->stride_px);
    });
    for (std::size_t k = 0; k < n; ++k) {
      GroundAlignment record;
      (*todo)[b0 + k] = aligner.Align((*todo)[b0 + k], samples[k], &record);
      if (record.contradicts) {
        summary->warnings.push_back(util::Format(
            "stem %s: its ground contradicts the map by more than %g deg or %g m (%s): fused with its own pose, "
            "not aligned",
            record.stem.c_str(), options.align->max_tilt_deg, options.align->max_shift_m, record.reason.c_str()));
      }
      summary->alignments.push_back(record);
    }
  }
}

}  // namespace

void TerrainMapRunOptions::Validate() const {
  map.Validate();
  LN_CHECK_ARG(!stereo_dir.empty() || !merge_maps.empty()) << "nothing to map: give a stereo directory or --merge";
  if (!stereo_dir.empty()) {
    const bool by_poses = !poses_csv.empty(), by_trajectory = !trajectory.empty();
    LN_CHECK_ARG(by_poses != by_trajectory) << "give either --poses or --trajectory (with --frame-times)";
    LN_CHECK_ARG(!by_trajectory || !frame_times.empty()) << "--trajectory needs --frame-times";
  }
  LN_CHECK_ARG(num_threads >= 0) << "threads: must be >= 0";
  if (align) align->Validate();
  LN_CHECK_ARG(!align || shard_count == 1)
      << "--align-to-ground: each pair is brought onto the pairs before it; map the shards' frames in one run";
  io::CheckShard(shard_index, shard_count);
  LN_CHECK_ARG(shard_count == 1 || map.window_m <= 0)
      << "--window-m: a rolling window follows the vehicle over every frame; map the shards whole and merge them";
  LN_CHECK_ARG(shard_count == 1 || !stereo_dir.empty()) << "--shard: give the stereo directory whose frames to share";
}

std::string TerrainMapRunSummary::BriefReport() const {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(2);
  s << frames_fused << " frames fused";
  if (frames_resumed > 0) s << " (+" << frames_resumed << " resumed)";
  if (frames_merged > 0) s << " (+" << frames_merged << " merged)";
  s << ", " << points_fused / 1e6 << " M points (" << points_rejected << " rejected by the gate, " << points_floating
    << " floating, " << points_unsupported << " unsupported, " << points_hidden << " hidden); " << mapped_cells
    << " cells, " << obstacle_cells << " obstacle cells; " << seconds << " s";
  return s.str();
}

TerrainMapRunSummary RunTerrainMap(const TerrainMapRunOptions& options, const fs::path& out, const json& invocation) {
  options.Validate();
  util::Timer total;
  TerrainMapRunSummary summary;
  const TerrainMapOptions& mo = options.map;

  // Everything is checked before anything is written.
  std::optional<calib::StereoRig> rig;
  if (!options.rig.empty()) rig = calib::ReadStereoRig(options.rig);
  std::vector<FramePose> todo;
  bool has_sigma = false;
  if (!options.stereo_dir.empty()) {
    std::vector<std::string> all_stems = ListStems(options.stereo_dir / "xyz");
    LN_CHECK_INPUT(!all_stems.empty()) << (options.stereo_dir / "xyz").string() << ": no <stem>.exr arrays";
    if (!options.stems.empty()) {
      const std::set<std::string> present(all_stems.begin(), all_stems.end());
      for (const std::string& stem : options.stems) {
        LN_CHECK_INPUT(present.count(stem) > 0)
            << (options.stereo_dir / "xyz" / (stem + ".exr")).string() << ": no such array";
      }
      all_stems = options.stems;
      std::sort(all_stems.begin(), all_stems.end());
    }
    std::vector<std::string> stems;
    for (const std::string* stem : io::SelectShard(all_stems, options.shard_index, options.shard_count)) {
      stems.push_back(*stem);
    }
    std::optional<Eigen::Isometry3d> vehicle_from_camera;
    if (rig) vehicle_from_camera = rig->VehicleFromLeft();
    todo = PosesOfPairs(options.poses_csv, options.trajectory, options.frame_times, stems, vehicle_from_camera);
    has_sigma = options.rig.empty() && fs::is_directory(options.stereo_dir / "xyz_sigma");
  }
  std::map<std::string, std::pair<double, double>> y_interval;  // per stem, from --requests
  if (!options.requests.empty()) {
    for (const stereo::WindowRequest& r : stereo::ReadWindowRequests(options.requests)) {
      y_interval[r.stem] = {r.y_min_m, r.y_max_m};
    }
  }
  // The reference image: as given, else as the stereo run records it, else stereo-batch's default.
  calib::ReferenceImage reference = calib::ReferenceImage::kRight;
  if (options.reference) {
    reference = *options.reference;
  } else if (!options.stereo_dir.empty()) {
    reference = stereo::ReadRunReference(options.stereo_dir).value_or(calib::ReferenceImage::kRight);
  }
  summary.reference = reference;
  std::optional<ElevationErrorModel> error_model;
  if (rig) error_model.emplace(*rig, reference, options.sigma_d_px);
  summary.frames_total = static_cast<long>(todo.size());

  TerrainGrid grid(mo.cell_m);
  ExtentGuard extent(mo.max_cells, mo.cell_m);
  std::vector<FusedFrame> fused;
  std::set<std::string> known;
  const std::string errors_source = has_sigma      ? "xyz_sigma arrays"
                                    : error_model ? "the rig's error model, sigma_d " + std::to_string(options.sigma_d_px) + " px"
                                                  : "default sigma " + std::to_string(mo.default_sigma_m) + " m";
  // A run that only merges fuses nothing itself: the first stored map's error source becomes
  // the reference the others must share.
  json fusion = FusionJson(options, errors_source);
  if (options.stereo_dir.empty()) fusion.erase("errors");
  // This run's pose of each stem it knows: a stored frame fused with another pose is refused.
  std::map<std::string, const FramePose*> run_pose;
  for (const FramePose& p : todo) run_pose[p.stem] = &p;
  auto absorb = [&](StoredMap&& m, const std::string& what) {
    for (const FusedFrame& f : m.frames) {
      LN_CHECK_INPUT(known.insert(f.pose.stem).second)
          << "stem " << f.pose.stem << ": fused twice (" << what << " and another map); merged maps must hold disjoint frames";
      if (const auto it = run_pose.find(f.pose.stem); it != run_pose.end()) {
        const FramePose& a = f.pose;
        const FramePose& b = *it->second;
        const double d = std::max({std::abs(a.x_m - b.x_m), std::abs(a.y_m - b.y_m), std::abs(a.z_m - b.z_m),
                                   std::abs(a.heading_rad - b.heading_rad), std::abs(a.pitch_rad - b.pitch_rad),
                                   std::abs(a.roll_rad - b.roll_rad), std::abs(a.t_s - b.t_s)});
        LN_CHECK_INPUT(d <= 1e-6)
            << "stem " << a.stem << ": " << what << " fused it at (" << a.x_m << ", " << a.y_m << ", " << a.z_m
            << ") m, heading " << a.heading_rad * kDeg << " deg; this run's pose is (" << b.x_m << ", " << b.y_m << ", "
            << b.z_m << ") m, heading " << b.heading_rad * kDeg << " deg: a map made with other poses";
      }
      fused.push_back(f);
    }
    grid.Merge(m.grid);
    extent.Check(grid, grid.MappedBounds(), what);
    for (const auto& [key, value] : m.fusion.items()) {
      if (!fusion.contains(key)) fusion[key] = value;
    }
  };
  if (options.resume && fs::is_regular_file(out / "state.tif")) {
    StoredMap m = ReadStoredMap(out, fusion);
    summary.frames_resumed = static_cast<long>(m.frames.size());
    absorb(std::move(m), (out / "state.tif").string());
  }
  for (const fs::path& dir : options.merge_maps) {
    StoredMap m = ReadStoredMap(dir, fusion);
    summary.frames_merged += static_cast<long>(m.frames.size());
    absorb(std::move(m), dir.string());
  }
  todo.erase(std::remove_if(todo.begin(), todo.end(), [&](const FramePose& p) { return known.count(p.stem) > 0; }),
             todo.end());

  // The points: with the rig stereo-batch matched with, triangulated from the pairs' disparity
  // maps (a raw float read, the same function stereo-batch's XYZ arrays come from: the same
  // points, a third of the time of decoding the arrays); checked to be the arrays' points (by
  // stereo-batch's summary, or on the first pair against its XYZ array, bit for bit), so that
  // another rig falls back to reading the arrays.
  auto disparity_path = [&](const std::string& stem) { return options.stereo_dir / "disparity" / (stem + ".pfm"); };
  // A pair's points from its disparity map; a map of another size than the rig's rectified
  // images is bad input naming the file.
  auto triangulate = [&](const std::string& stem) {
    const fs::path path = disparity_path(stem);
    const cv::Mat disparity = io::ReadPfm(path);
    LN_CHECK_INPUT(disparity.cols == rig->rectified->width_px && disparity.rows == rig->rectified->height_px)
        << "stem " << stem << ": " << path.string() << " is " << disparity.cols << "x" << disparity.rows
        << ", the rig's rectified images " << rig->rectified->width_px << "x" << rig->rectified->height_px;
    // No matcher returns a disparity as large as the image is wide: such a value is damage, not
    // a point (1e30 px would put a point on the camera, a phantom under the vehicle). The same
    // pass finds the rows that hold a disparity (a rig's search matches a band of rows).
    const float widest = static_cast<float>(disparity.cols);
    PairPoints points;
    int first = disparity.rows, last = -1;
    for (int y = 0; y < disparity.rows; ++y) {
      const float* row = disparity.ptr<float>(y);
      bool any = false;
      for (int x = 0; x < disparity.cols; ++x) {
        const bool finite = std::isfinite(row[x]);
        LN_CHECK_INPUT(!(finite && std::abs(row[x]) >= widest))  // +inf and NaN: no match
            << "stem " << stem << ": " << path.string() << ": pixel (" << x << ", " << y << ") holds a disparity of "
            << row[x] << " px, beyond the image's width (" << disparity.cols << " px)";
        any = any || finite;
      }
      if (any) {
        first = std::min(first, y);
        last = y;
      }
    }
    points.xyz = calib::TriangulateDisparity(*rig, disparity, reference);
    points.rows = last >= first ? cv::Range(first, last + 1) : cv::Range(0, 0);
    return points;
  };
  // When stereo-batch's summary records this rig and reference image, that is the check: no
  // XYZ array is read (nor the OpenEXR reader loaded, a third of the process's time on a real
  // drive of 51 pairs).
  bool from_disparity = false;
  const bool disparity_first =
      rig && rig->rectified && !todo.empty() && fs::is_regular_file(disparity_path(todo.front().stem));
  if (disparity_first && StereoSummaryRecordsRig(options.stereo_dir, *rig, reference)) {
    from_disparity = true;
    summary.points_check = "stereo-batch's summary.json records this rig and reference image";
  } else if (disparity_first) {
    io::PreloadExrReader();
    const std::string& stem = todo.front().stem;
    const cv::Mat stored = io::ReadExr(options.stereo_dir / "xyz" / (stem + ".exr")).pixels;
    const cv::Mat ours = triangulate(stem).xyz;
    from_disparity = stored.type() == CV_32FC3 && ours.size() == stored.size() &&
                     std::memcmp(ours.ptr(), stored.ptr(), ours.total() * ours.elemSize()) == 0;
    if (from_disparity) summary.points_check = "the first pair's XYZ array, bit for bit";
    if (!from_disparity) {
      summary.warnings.push_back("stem " + stem + ": the XYZ array differs from the disparity map triangulated with " +
                                 options.rig.string() +
                                 " (stereo-batch used another rig or reference image?): the XYZ arrays are read");
    }
  }
  summary.points_source = from_disparity ? "disparity maps triangulated with the rig" : "XYZ arrays";
  // The OpenEXR reader loaded now when arrays will be read, so that the reads' timings measure
  // reading only (a pair without its disparity map still loads it when its array is read).
  if (!todo.empty() && (!from_disparity || has_sigma)) io::PreloadExrReader();
  // The points of a pair: triangulated from its disparity map with the rig, or its XYZ array.
  auto read_pair = [&](const FramePose& pose) {
    const fs::path xyz_path = options.stereo_dir / "xyz" / (pose.stem + ".exr");
    PairPoints points;
    if (from_disparity && fs::is_regular_file(disparity_path(pose.stem))) {
      points = triangulate(pose.stem);
    } else {
      points.xyz = io::ReadExr(xyz_path).pixels;
    }
    LN_CHECK_INPUT(points.xyz.type() == CV_32FC3)
        << "stem " << pose.stem << ": " << xyz_path.string() << " has " << points.xyz.channels()
        << " channels, expected 3 (X, Y, Z)";
    return points;
  };
  auto read_points = [&](const FramePose& pose) { return read_pair(pose).xyz; };

  // The inputs read and checked (poses, rig, the pairs listed, a resumed or merged map, the
  // first pair's points against its XYZ array).
  summary.stage_seconds.emplace_back("read and check the inputs", total.ElapsedSeconds());
  util::Timer fuse_timer;
  const std::clock_t fuse_cpu_start = std::clock();  // the process's CPU time: the figure on a shared machine
  // The alignment's reading and fitting count in the fusion's time (points per CPU second).
  if (options.align && !todo.empty()) {
    util::Timer align_timer;
    AlignToGround(options, grid, read_points, &todo, &summary);
    summary.stage_seconds.emplace_back("align to the ground", align_timer.ElapsedSeconds());
  }
  double bin_cpu_seconds = 0, add_seconds = 0;
  util::ProgressBar progress(todo.size(), "terrain-map frames", options.show_progress);
  const int threads = util::EffectiveThreadCount(options.num_threads);
  const std::size_t block = static_cast<std::size_t>(2 * threads);
  cv::Size first_size;
  std::string first_stem, first_empty;
  for (std::size_t b0 = 0; b0 < todo.size(); b0 += block) {
    const std::size_t n = std::min(block, todo.size() - b0);
    std::vector<FrameContribution> parts(n);
    std::vector<cv::Size> sizes(n);
    std::vector<double> read_cpu(n, 0.0), bin_cpu(n, 0.0);
    util::ParallelForEachItem(n, threads, [&](std::size_t k) {
      const FramePose& pose = todo[b0 + k];
      const double read_start = util::ThreadCpuSeconds();
      const PairPoints points = read_pair(pose);
      cv::Mat sigma;
      const fs::path sigma_path = options.stereo_dir / "xyz_sigma" / (pose.stem + ".exr");
      if (has_sigma && fs::is_regular_file(sigma_path)) {
        sigma = io::ReadExr(sigma_path).pixels;
        LN_CHECK_INPUT(sigma.type() == CV_32FC3 && sigma.size() == points.xyz.size())
            << "stem " << pose.stem << ": " << sigma_path.string() << " is " << sigma.cols << "x" << sigma.rows
            << " with " << sigma.channels() << " channels, the XYZ array " << points.xyz.cols << "x" << points.xyz.rows
            << " with 3";
      }
      read_cpu[k] = util::ThreadCpuSeconds() - read_start;
      sizes[k] = points.xyz.size();
      const auto interval = y_interval.find(pose.stem);
      constexpr double kInf = std::numeric_limits<double>::infinity();
      const double bin_start = util::ThreadCpuSeconds();
      // Only the rows that hold points (the others add nothing: binning reads no row's index).
      parts[k] = BinFrame(points.xyz.rowRange(points.rows), sigma.empty() ? sigma : sigma.rowRange(points.rows),
                          pose.WorldFromVehicle(), pose.t_s, mo, error_model ? &*error_model : nullptr,
                          interval != y_interval.end() ? interval->second.first : -kInf,
                          interval != y_interval.end() ? interval->second.second : kInf);
      bin_cpu[k] = util::ThreadCpuSeconds() - bin_start;
      progress.Increment();
    });
    util::Timer add_timer;
    for (std::size_t k = 0; k < n; ++k) {
      const FramePose& pose = todo[b0 + k];
      summary.read_cpu_seconds += read_cpu[k];
      bin_cpu_seconds += bin_cpu[k];
      if (first_stem.empty()) {
        first_stem = pose.stem;
        first_size = sizes[k];
      }
      LN_CHECK_INPUT(sizes[k] == first_size)
          << "stem " << pose.stem << ": XYZ array " << sizes[k].width << "x" << sizes[k].height << ", but "
          << first_stem << "'s is " << first_size.width << "x" << first_size.height
          << " (one rig: every pair the same size)";
      const FrameContribution& c = parts[k];
      grid.Add(c);
      if (mo.window_m) grid.KeepWindow(pose.x_m, pose.y_m, *mo.window_m);
      extent.Check(grid, ContributionBox(c), "stem " + pose.stem);
      summary.points_in += c.points_in;
      summary.points_fused += c.points_fused;
      summary.points_rejected += c.points_rejected;
      summary.points_floating += c.points_floating;
      summary.points_unsupported += c.points_unsupported;
      summary.points_out_of_range += c.points_out_of_range;
      summary.rays_cast += c.rays_cast;
      summary.points_hidden += c.points_hidden;
      summary.points_ground_only += c.points_ground_only;
      summary.points_off_ground += c.points_off_ground;
      summary.points_lone_object += c.points_lone_object;
      summary.points_edge += c.points_edge;
      fused.push_back({pose, c.points_fused, c.points_rejected});
      ++summary.frames_fused;
      if (c.points_in == 0 && summary.frames_without_points++ == 0) first_empty = pose.stem;
    }
    add_seconds += add_timer.ElapsedSeconds();
  }
  summary.stage_seconds.emplace_back("read the points (CPU)", summary.read_cpu_seconds);
  summary.stage_seconds.emplace_back("transform, bin and the per-pair rules (CPU)", bin_cpu_seconds);
  summary.stage_seconds.emplace_back("add to the grid", add_seconds);
  summary.fuse_seconds = fuse_timer.ElapsedSeconds();
  summary.fuse_cpu_seconds = static_cast<double>(std::clock() - fuse_cpu_start) / CLOCKS_PER_SEC;
  std::stable_sort(fused.begin(), fused.end(),
                   [](const FusedFrame& a, const FusedFrame& b) { return a.pose.t_s < b.pose.t_s; });
  if (mo.window_m && !fused.empty()) grid.KeepWindow(fused.back().pose.x_m, fused.back().pose.y_m, *mo.window_m);

  // Silent emptiness is a warning: pairs whose XYZ arrays are all NaN (a blank pair, or the
  // wrong directory), and a map with nothing in it (no elevation.tif).
  if (summary.frames_without_points > 0) {
    summary.warnings.push_back(util::Format("%ld of %ld pairs had no valid point in their XYZ arrays (all NaN; the first: stem %s)",
                                            summary.frames_without_points, summary.frames_fused, first_empty.c_str()));
  }
  if (grid.MappedCells() == 0) {
    summary.warnings.push_back("nothing was mapped: no point of any pair was fused, so no elevation.tif is written");
  }
  for (const std::string& w : summary.warnings) LN_LOG(Warning) << w;

  // Outputs.
  util::Timer write_timer;
  io::CreateOutputDirectory(out);
  io::RemoveStaleTempFiles(out);
  util::StageClock clock;
  const MapLayers layers =
      ComputeLayers(grid, mo.obstacles, mo.min_frames, mo.carve_tolerance_m, mo.moved_height_m, &summary.carved);
  clock.Lap("layers (carving, obstacles)");
  summary.mapped_cells = static_cast<long>(grid.MappedCells());
  if (!layers.obstacle.empty()) {
    summary.obstacle_cells = cv::countNonZero(layers.obstacle > 0);
  }
  if (summary.mapped_cells > 0) {
    io::GeoRaster raster = LayersToRaster(layers);
    raster.metadata["lunarnav_tool"] = "terrain-map";
    io::WriteGeoTiffAtomic(out / "elevation.tif", raster);
  }
  clock.Lap("write elevation.tif");
  // The commit: the sums with the frames they hold and the fusion values, in one file renamed
  // into place; frames.csv, after it, is the same list for people and tools.
  io::GeoRaster state = grid.ToStateRaster();
  state.metadata["lunarnav_frames"] = FramesJson(fused).dump();
  state.metadata["lunarnav_fusion"] = fusion.dump();
  io::WriteGeoTiffAtomic(out / "state.tif", state);
  clock.Lap("write state.tif");
  io::WriteFileAtomic(out / "frames.csv", FramesCsv(fused));
  if (options.write_preview) {
    std::vector<Eigen::Vector2d> path;
    for (const FusedFrame& f : fused) path.emplace_back(f.pose.x_m, f.pose.y_m);
    io::WriteImageAtomic(out / "preview.png", RenderMapPreview(layers, path));
  }
  clock.Lap("write frames.csv and preview.png");
  for (auto& stage : clock.Take()) summary.stage_seconds.push_back(std::move(stage));
  summary.write_seconds = write_timer.ElapsedSeconds();
  summary.seconds = total.ElapsedSeconds();
  summary.peak_memory_mib = util::PeakResidentMemoryMiB();

  json j = util::SummaryHead("terrain-map", invocation);
  j["inputs"] = {
      {"stereo_dir", options.stereo_dir.string()},
      {"poses", options.poses_csv.string()},
      {"trajectory", options.trajectory.string()},
      {"frame_times", options.frame_times.string()},
      {"xyz_sigma", has_sigma},
      {"points", summary.points_source},
      {"points_check", summary.points_check.empty() ? json(nullptr) : json(summary.points_check)},
      {"reference", calib::ToString(summary.reference)},
      {"rig", options.rig.string()},
      {"requests", options.requests.string()},
      {"errors", has_sigma     ? "xyz_sigma arrays"
                 : error_model ? "the rig's error model, sigma_d " + std::to_string(options.sigma_d_px) + " px"
                               : "default sigma " + std::to_string(mo.default_sigma_m) + " m"},
      {"merge", json::array()},
      {"resume", options.resume}};
  for (const fs::path& p : options.merge_maps) j["inputs"]["merge"].push_back(p.string());
  j["options"] = mo.ToJson();
  j["threads"] = threads;
  j["grid"] = {{"cell_m", layers.cell_m},
               {"x_west_m", layers.x_west_m},
               {"y_north_m", layers.y_north_m},
               {"width", layers.elevation_m.cols},
               {"height", layers.elevation_m.rows},
               {"tiles", grid.TileCount()}};
  j["counts"] = {{"frames_total", summary.frames_total},
                 {"frames_fused", summary.frames_fused},
                 {"frames_resumed", summary.frames_resumed},
                 {"frames_merged", summary.frames_merged},
                 {"points_in", summary.points_in},
                 {"points_fused", summary.points_fused},
                 {"points_rejected", summary.points_rejected},
                 {"points_floating", summary.points_floating},
                 {"points_unsupported", summary.points_unsupported},
                 {"points_hidden", summary.points_hidden},
                 {"points_out_of_range", summary.points_out_of_range},
                 {"points_ground_only", summary.points_ground_only},
                 {"points_lone_object", summary.points_lone_object},
                 {"points_off_ground", summary.points_off_ground},
                 {"points_edge", summary.points_edge},
                 {"mapped_cells", summary.mapped_cells},
                 {"obstacle_cells", summary.obstacle_cells},
                 {"frames_without_points", summary.frames_without_points}};
  // Free-space carving (docs/terrain-map.md): the rays that set ceilings, and what the layers left out.
  j["counts"]["carving"] = {{"rays_cast", summary.rays_cast},
                            {"points_carved", summary.carved.points},
                            {"observations_carved", summary.carved.observations},
                            {"points_moved_on", summary.carved.points_moved_on},
                            {"observations_moved_on", summary.carved.observations_moved_on},
                            {"cells_changed", summary.carved.cells_changed},
                            {"cells_cleared", summary.carved.cells_cleared}};
  if (options.align) {
    long applied = 0;
    double tilt2 = 0, shift2 = 0;
    json pairs = json::array();
    for (const GroundAlignment& a : summary.alignments) {
      pairs.push_back(a.ToJson());
      if (!a.applied) continue;
      ++applied;
      tilt2 += a.tilt_x_deg * a.tilt_x_deg + a.tilt_y_deg * a.tilt_y_deg;
      shift2 += a.shift_m * a.shift_m;
    }
    j["alignment"] = {{"options", options.align->ToJson()},
                      {"pairs", summary.alignments.size()},
                      {"applied", applied},
                      {"tilt_rms_deg", applied > 0 ? std::sqrt(tilt2 / (2.0 * applied)) : 0.0},
                      {"shift_rms_m", applied > 0 ? std::sqrt(shift2 / applied) : 0.0},
                      {"per_pair", pairs}};
  }
  j["timings_s"] = {{"total", summary.seconds},
                    {"read_and_fuse", summary.fuse_seconds},
                    {"read_and_fuse_cpu", summary.fuse_cpu_seconds},
                    {"read_cpu", summary.read_cpu_seconds},
                    {"write", summary.write_seconds}};
  json stages = json::array();
  for (const auto& [stage, seconds] : summary.stage_seconds) stages.push_back({{"stage", stage}, {"seconds", seconds}});
  j["timings_s"]["stages"] = std::move(stages);
  // Points (valid XYZ) read and fused per second of wall time, and per second of CPU time
  // (with -j 1, one core's rate even when other processes share the machine).
  j["points_per_second"] = summary.fuse_seconds > 0 ? summary.points_in / summary.fuse_seconds : 0.0;
  j["points_per_cpu_second"] = summary.fuse_cpu_seconds > 0 ? summary.points_in / summary.fuse_cpu_seconds : 0.0;
  j["peak_memory_mib"] = summary.peak_memory_mib;
  j["warnings"] = summary.warnings;
  io::WriteJsonAtomic(out / "summary.json", j);
  return summary;
}

}  // namespace lunarnav::mapping
