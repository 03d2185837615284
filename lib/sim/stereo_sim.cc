#include "sim/stereo_sim.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "calib/rectify.h"
#include "calib/stereo_rig_io.h"
#include "io/float_array_io.h"
#include "io/geotiff_io.h"
#include "sim/terrain_truth.h"
#include "io/atomic_file.h"
#include "io/image_io.h"
#include "io/json_io.h"
#include "util/check.h"
#include "util/log.h"
#include "util/parallel.h"
#include "util/parse.h"
#include "util/progress.h"
#include "util/resources.h"
#include "util/summary.h"
#include "util/timer.h"

namespace lunarnav::sim {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kTerrainMarginM = 22.0;  // terrain around the trajectory: the cameras see ~12 m ahead on level ground
constexpr double kWheelSpacingM = 1.0;    // ground samples for z, pitch and roll
constexpr double kBoxSizeM = 0.5;

struct PresetDefaults {
  double rock_density, relief;
};

PresetDefaults Defaults(const std::string& preset) {
  if (preset == "boxes") return {0.0, 0.0};
  return {0.4, 0.3};
}

// X of the centre of the box at Y = 2, 3, ..., 8 m: staggered so that every box is in view of
// both cameras and none hides another's front face.
constexpr double kBoxCentreX[] = {-0.35, 0.6, -1.0, 1.3, -1.7, 1.9, -0.3};

std::string Format(const char* format, double value) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, value);
  return buf;
}

cv::Mat ApplyFault(const cv::Mat& image, FrameFault fault) {
  cv::Mat out;
  switch (fault) {
    case FrameFault::kBlank:
      return cv::Mat::zeros(image.size(), image.type());
    case FrameFault::kSaturated:
      image.convertTo(out, image.type(), 4.0, 40.0);
      if (image.depth() == CV_32F) cv::min(out, 255.0, out);
      return out;
    default:
      return image;
  }
}

void WriteImage(const fs::path& path, const cv::Mat& image, bool truncate) {
  io::WriteImageAtomic(path, image);
  if (!truncate) return;
  // The first half of the encoded file, replacing it.
  std::ifstream in(path, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  LN_CHECK(in.good() || in.eof()) << path.string() << ": cannot read back";
  io::WriteFileAtomic(path, std::string_view(bytes).substr(0, bytes.size() / 2));
}

json RigSummary(const calib::StereoRig& rig) {
  const calib::RectifiedGeometry& g = *rig.rectified;
  const double f = g.P_left(0, 0);
  return {{"focal_px", rig.left.K(0, 0)},
          {"baseline_m", rig.BaselineM()},
          {"mast_height_m", rig.mast.height_m},
          {"tilt_deg", rig.mast.tilt_deg},
          {"size_px", {rig.width_px, rig.height_px}},
          {"lens_distortion", !rig.left.distortion.empty()},
          {"rectified_focal_px", f},
          {"rectified_baseline_m", -g.P_right(0, 3) / f}};
}

}  // namespace

std::string ToString(FrameFault fault) {
  switch (fault) {
    case FrameFault::kNone: return "none";
    case FrameFault::kBlank: return "blank";
    case FrameFault::kSaturated: return "saturated";
    case FrameFault::kTruncated: return "truncated";
  }
  return "none";
}

FrameFault FrameFaultFromString(const std::string& name) {
  if (name == "blank") return FrameFault::kBlank;
  if (name == "saturated") return FrameFault::kSaturated;
  if (name == "truncated") return FrameFault::kTruncated;
  LN_CHECK_ARG(false) << "fault: blank, saturated or truncated, got '" << name << "'";
  return FrameFault::kNone;
}

FrameFaultSpec ParseFrameFaultSpec(const std::string& text, const std::string& what) {
  const std::size_t colon = text.find(':');
  LN_CHECK_ARG(colon != std::string::npos) << what << ": expected FRAME:KIND (e.g. 3:blank), got '" << text << "'";
  FrameFaultSpec spec;
  spec.frame = util::ParseInt(text.substr(0, colon), what + " frame");
  spec.fault = FrameFaultFromString(text.substr(colon + 1));
  return spec;
}

std::string FrameStem(int k) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "%06d", k);
  return buf;
}

void StereoSimOptions::Validate() const {
  LN_CHECK_ARG(preset == "terrain" || preset == "boxes") << "preset: terrain or boxes, got '" << preset << "'";
  LN_CHECK_ARG(width_px >= 16 && height_px >= 16 && width_px <= 8192 && height_px <= 8192)
      << "image size: must be 16..8192 px, got " << width_px << "x" << height_px;
  LN_CHECK_ARG(std::isfinite(focal_px) && focal_px > 1) << "focal length: must be > 1 px";
  LN_CHECK_ARG(std::isfinite(baseline_m) && baseline_m > 0.01 && baseline_m < 10) << "baseline: must be in (0.01, 10) m";
  LN_CHECK_ARG(std::isfinite(mast_height_m) && mast_height_m > 0.1 && mast_height_m < 20)
      << "mast height: must be in (0.1, 20) m";
  LN_CHECK_ARG(std::isfinite(tilt_deg) && tilt_deg > -80 && tilt_deg < 80) << "tilt: must be in (-80, 80) deg";
  LN_CHECK_ARG(std::isfinite(noise_sigma) && noise_sigma >= 0) << "noise: must be >= 0";
  const int s = static_cast<int>(std::lround(std::sqrt(std::max(rays_per_pixel, 0))));
  LN_CHECK_ARG(rays_per_pixel >= 1 && rays_per_pixel <= 64 && s * s == rays_per_pixel)
      << "rays per pixel: must be a square in 1..64 (1, 4, 9, ...), got " << rays_per_pixel;
  LN_CHECK_ARG(frames >= 1 && frames <= 1000000) << "frames: must be 1 to 1000000, got " << frames;
  LN_CHECK_ARG(std::isfinite(speed_mps) && speed_mps >= 0 && speed_mps <= 10) << "speed: must be in [0, 10] m/s";
  LN_CHECK_ARG(std::isfinite(interval_s) && interval_s > 0) << "interval: must be > 0 s";
  LN_CHECK_ARG(std::isfinite(turn_radius_m) && (turn_radius_m == 0 || std::abs(turn_radius_m) >= 1))
      << "turn radius: 0 (straight) or at least 1 m";
  for (const FrameFaultSpec& f : faults) {
    LN_CHECK_ARG(f.frame >= 0 && f.frame < frames)
        << "fault: frame " << f.frame << " is not one of the " << frames << " frames";
  }
  LN_CHECK_ARG(terrain_cell_m >= 0.005 && terrain_cell_m <= 0.5) << "terrain cell: must be in [0.005, 0.5] m";
  LN_CHECK_ARG(rock_density_per_m2 == -1 || (rock_density_per_m2 >= 0 && rock_density_per_m2 <= 20))
      << "rock density: must be in [0, 20] per m^2";
  LN_CHECK_ARG(relief_amplitude_m == -1 || (relief_amplitude_m >= 0 && relief_amplitude_m <= 10))
      << "relief: must be in [0, 10] m";
  LN_CHECK_ARG(num_threads >= 0) << "threads: must be >= 0";
  LN_CHECK_ARG(truth_cell_m >= 0.05 && truth_cell_m <= 5) << "truth cell: must be in [0.05, 5] m";
}

json StereoSimOptions::ToJson() const {
  json faults_json = json::array();
  for (const FrameFaultSpec& f : faults) faults_json.push_back({{"frame", f.frame}, {"fault", ToString(f.fault)}});
  const PresetDefaults d = Defaults(preset);
  return {{"preset", preset},
          {"size_px", {width_px, height_px}},
          {"focal_px", focal_px},
          {"baseline_m", baseline_m},
          {"mast_height_m", mast_height_m},
          {"tilt_deg", tilt_deg},
          {"rectified", rectified},
          {"lens_distortion", lens_distortion},
          {"camera_rotation", camera_rotation},
          {"exposure_difference", exposure_difference},
          {"noise_sigma", noise_sigma},
          {"quantize", quantize},
          {"rays_per_pixel", rays_per_pixel},
          {"frames", frames},
          {"speed_mps", speed_mps},
          {"interval_s", interval_s},
          {"turn_radius_m", turn_radius_m},
          {"faults", faults_json},
          {"terrain_cell_m", terrain_cell_m},
          {"rock_density_per_m2", rock_density_per_m2 >= 0 ? rock_density_per_m2 : d.rock_density},
          {"relief_amplitude_m", relief_amplitude_m >= 0 ? relief_amplitude_m : d.relief},
          {"truth_cell_m", truth_cell_m},
          {"seed", seed}};
}

calib::StereoRig MakeSimulatedRig(const StereoSimOptions& options) {
  options.Validate();
  calib::StereoRig rig;
  rig.width_px = options.width_px;
  rig.height_px = options.height_px;
  for (calib::CameraIntrinsics* c : {&rig.left, &rig.right}) {
    c->K << options.focal_px, 0, 0.5 * (options.width_px - 1), 0, options.focal_px, 0.5 * (options.height_px - 1),
        0, 0, 1;
  }
  if (options.lens_distortion) {
    // Mild barrel distortion of 8 mm lenses, slightly different per lens.
    rig.left.distortion = {-0.12, 0.05, 0.0005, -0.0003, 0.0};
    rig.right.distortion = {-0.11, 0.045, -0.0004, 0.0002, 0.0};
  }
  rig.right_from_left_t_m = Eigen::Vector3d(-options.baseline_m, 0, 0);
  if (options.camera_rotation) {
    rig.right_from_left_R =
        Eigen::AngleAxisd(0.2 * kDeg, Eigen::Vector3d(0.3, 1.0, 0.2).normalized()).toRotationMatrix();
    rig.right_from_left_t_m = Eigen::Vector3d(-options.baseline_m, 0.002, 0.001);
  }
  rig.mast = calib::MastPose{options.mast_height_m, options.tilt_deg, 0.0, 0.0};
  return calib::RectifyRig(rig, 0.0);
}

std::vector<VehiclePose> MakeTrajectory(const StereoSimOptions& options, const Terrain* terrain) {
  std::vector<VehiclePose> poses;
  for (int k = 0; k < options.frames; ++k) {
    const double s = k * options.speed_mps * options.interval_s;
    VehiclePose p;
    if (options.turn_radius_m == 0) {
      p.y_m = s;
    } else {
      const double r = options.turn_radius_m;
      p.heading_rad = s / r;
      p.x_m = r * (1 - std::cos(p.heading_rad));
      p.y_m = r * std::sin(p.heading_rad);
    }
    if (terrain != nullptr) {
      // Forward and right unit vectors on the ground plane.
      const Eigen::Vector2d fwd(std::sin(p.heading_rad), std::cos(p.heading_rad));
      const Eigen::Vector2d right(fwd.y(), -fwd.x());
      const double h = 0.5 * kWheelSpacingM;
      auto ground = [&](const Eigen::Vector2d& offset) {
        const double z = terrain->HeightAt(p.x_m + offset.x(), p.y_m + offset.y());
        LN_CHECK(std::isfinite(z)) << "trajectory leaves the terrain";
        return z;
      };
      const double front = ground(h * fwd), back = ground(-h * fwd), rgt = ground(h * right), lft = ground(-h * right);
      p.z_m = 0.25 * (front + back + rgt + lft);
      p.pitch_rad = std::atan2(front - back, kWheelSpacingM);
      p.roll_rad = std::atan2(lft - rgt, kWheelSpacingM);
    }
    poses.push_back(p);
  }
  return poses;
}

SceneOptions MakeSceneOptions(const StereoSimOptions& options) {
  options.Validate();
  const PresetDefaults d = Defaults(options.preset);
  SceneOptions scene;
  TerrainOptions& t = scene.terrain;
  t.seed = options.seed;
  t.cell_m = options.terrain_cell_m;
  t.rock_density_per_m2 = options.rock_density_per_m2 >= 0 ? options.rock_density_per_m2 : d.rock_density;
  t.relief_amplitude_m = options.relief_amplitude_m >= 0 ? options.relief_amplitude_m : d.relief;
  // The terrain covers the trajectory and a margin, its edges on multiples of the cell (so
  // that any two runs share the same grid where they overlap).
  const std::vector<VehiclePose> path = MakeTrajectory(options, nullptr);
  double x0 = 0, x1 = 0, y0 = 0, y1 = 0;
  for (const VehiclePose& p : path) {
    x0 = std::min(x0, p.x_m);
    x1 = std::max(x1, p.x_m);
    y0 = std::min(y0, p.y_m);
    y1 = std::max(y1, p.y_m);
  }
  const double c = t.cell_m;
  t.min_x_m = std::floor((x0 - kTerrainMarginM) / c) * c;
  t.max_x_m = std::ceil((x1 + kTerrainMarginM) / c) * c;
  t.min_y_m = std::floor((y0 - kTerrainMarginM) / c) * c;
  t.max_y_m = std::ceil((y1 + kTerrainMarginM) / c) * c;
  if (options.preset == "boxes") {
    // Boxes rest on the ground: a small terrain around each (the same surface, since the
    // terrain is a function of world coordinates on the same cell lattice) gives its base.
    for (int k = 0; k < 7; ++k) {
      const double cx = kBoxCentreX[k], front = path.front().y_m + 2.0 + k;
      TerrainOptions local = t;
      local.min_x_m = std::floor((cx - 1) / c) * c;
      local.max_x_m = std::ceil((cx + 1) / c) * c;
      local.min_y_m = std::floor((front - 1) / c) * c;
      local.max_y_m = std::ceil((front + kBoxSizeM + 1) / c) * c;
      const Terrain ground(local);
      scene.boxes.push_back(BoxOnTerrain(ground, cx, front, kBoxSizeM, kBoxSizeM, kBoxSizeM,
                                         options.seed * 16 + static_cast<std::uint64_t>(k)));
    }
  }
  return scene;
}

StereoRenderOptions MakeRenderOptions(const StereoSimOptions& options) {
  StereoRenderOptions r;
  r.mode = options.rectified ? CameraMode::kRectified : CameraMode::kRaw;
  r.samples_per_axis = static_cast<int>(std::lround(std::sqrt(options.rays_per_pixel)));
  r.left_exposure = {1.0, 0.0};
  r.right_exposure = options.exposure_difference ? CameraExposure{0.92, 6.0} : CameraExposure{1.0, 0.0};
  r.noise_sigma = options.noise_sigma;
  r.quantize = options.quantize;
  r.compute_truth = true;
  r.seed = options.seed;
  return r;
}

std::string StereoSimSummary::BriefReport() const {
  std::ostringstream s;
  s << frames << " frame" << (frames == 1 ? "" : "s");
  if (faults > 0) s << " (" << faults << " with faults)";
  s.setf(std::ios::fixed);
  s.precision(2);
  s << "; " << seconds << " s (scene " << scene_seconds << " s, render " << render_seconds << " s)";
  return s.str();
}

StereoSimSummary RunStereoSimulation(const StereoSimOptions& options, const fs::path& output_dir,
                                     const json& invocation) {
  options.Validate();
  io::CreateOutputDirectory(output_dir);  // an unusable directory is refused before the scene is built
  tbb::task_arena arena(util::EffectiveThreadCount(options.num_threads));
  util::Timer scene_timer;
  std::unique_ptr<Scene> scene;
  arena.execute([&] { scene = std::make_unique<Scene>(MakeSceneOptions(options)); });
  const std::vector<VehiclePose> poses = MakeTrajectory(options, &scene->terrain());
  std::vector<double> times_s(poses.size());
  for (std::size_t k = 0; k < poses.size(); ++k) times_s[k] = static_cast<double>(k) * options.interval_s;
  json head = util::SummaryHead("simulate", invocation);
  head["subcommand"] = "stereo";
  return RenderStereoSequence(options, *scene, poses, times_s, 0.0, output_dir, head, scene_timer.ElapsedSeconds());
}

StereoSimSummary RenderStereoSequence(const StereoSimOptions& options, const Scene& scene_ref,
                                      const std::vector<VehiclePose>& poses, const std::vector<double>& times_s,
                                      double z_origin_m, const fs::path& output_dir, const json& summary_head,
                                      double scene_seconds) {
  options.Validate();
  LN_CHECK_ARG(static_cast<int>(poses.size()) == options.frames && times_s.size() == poses.size())
      << "a sequence of " << options.frames << " frames needs as many poses and times";
  util::Timer total;
  StereoSimSummary summary;
  summary.scene_seconds = scene_seconds;
  const Scene* scene = &scene_ref;
  const calib::StereoRig rig = MakeSimulatedRig(options);
  const StereoRenderOptions render_options = MakeRenderOptions(options);
  io::CreateOutputDirectory(output_dir);
  for (const char* sub : {"left", "right", "truth", "truth/disparity", "truth/xyz", "truth/labels"}) {
    io::CreateOutputDirectory(output_dir / sub);
    io::RemoveStaleTempFiles(output_dir / sub);
  }
  io::RemoveStaleTempFiles(output_dir);
  tbb::task_arena arena(util::EffectiveThreadCount(options.num_threads));
  std::vector<FrameFault> faults(options.frames, FrameFault::kNone);
  for (const FrameFaultSpec& f : options.faults) faults[f.frame] = f.fault;
  const StereoRenderer renderer(rig, render_options);
  LN_LOG(Info) << "scene: terrain " << scene->terrain().GridWidth() << " x " << scene->terrain().GridHeight()
               << " vertices, " << scene->boxes().size() << " boxes (" << summary.scene_seconds << " s)";

  calib::WriteStereoRig(output_dir / "rig.json", rig);
  // The true terrain on terrain-map's grid, its obstacles and rocks (evaluate map); the terrain
  // preset only (the boxes are not part of the height field, so its DEM would miss them).
  if (options.preset == "terrain") {
    util::Timer truth_timer;
    arena.execute([&] {
      io::GeoRaster truth = TerrainTruthRaster(scene->terrain(), options.truth_cell_m, TrueObstacleOptions());
      if (z_origin_m != 0) {
        for (const char* band : {"elevation_m", "min_m", "max_m"}) {
          const int b = truth.BandIndex(band);
          LN_CHECK(b >= 0) << "truth raster without " << band;
          truth.bands[b].pixels -= z_origin_m;  // NaN stays NaN
        }
      }
      io::WriteGeoTiffAtomic(output_dir / "truth" / "terrain.tif", truth);
    });
    io::WriteFileAtomic(output_dir / "truth" / "rocks.csv", RocksCsv(scene->terrain()));
    LN_LOG(Info) << "truth: terrain.tif (" << options.truth_cell_m << " m cells) and rocks.csv ("
                 << truth_timer.ElapsedSeconds() << " s)";
  }

  const std::string image_ext = options.quantize ? ".png" : ".tif";
  std::vector<StereoFrameStats> stats(options.frames);
  std::vector<double> write_s(options.frames);
  std::vector<json> box_frames(options.frames);
  util::ProgressBar progress(options.frames, "frames", options.show_progress);
  arena.execute([&] {
    tbb::parallel_for(0, options.frames, [&](int k) {
      const std::string stem = FrameStem(k);
      const StereoFrame frame = renderer.Render(*scene, poses[k], static_cast<std::uint64_t>(k));
      stats[k] = frame.stats;
      util::Timer write_timer;
      cv::Mat disparity = frame.truth_disparity_px.clone();
      cv::patchNaNs(disparity, std::numeric_limits<double>::infinity());
      io::WriteImageAtomic(output_dir / "truth" / "disparity" / (stem + ".pfm"), disparity);
      io::WriteExrAtomic(output_dir / "truth" / "xyz" / (stem + ".exr"), frame.truth_xyz_m, {},
                         {{"lunarnav:quantity", "XYZ"}, {"lunarnav:channels", "R=X G=Y B=Z"}, {"lunarnav:units", "m"},
                          {"lunarnav:frame", "vehicle"}, {"lunarnav:invalid", "NaN"}, {"lunarnav:stem", stem}});
      io::WriteLabelImageAtomic(output_dir / "truth" / "labels" / (stem + ".png"), frame.truth_label);
      json boxes = json::array();
      for (const BoxTruth& b : BoxTruthInVehicle(*scene, poses[k])) boxes.push_back(b.ToJson());
      box_frames[k] = {{"stem", stem}, {"boxes", boxes}};
      // The images last, the right one after the left: both present = frame complete.
      const FrameFault fault = faults[k];
      WriteImage(output_dir / "left" / (stem + image_ext), ApplyFault(frame.left, fault),
                 fault == FrameFault::kTruncated);
      io::WriteImageAtomic(output_dir / "right" / (stem + image_ext), ApplyFault(frame.right, fault));
      write_s[k] = write_timer.ElapsedSeconds();
      progress.Increment();
    }, tbb::simple_partitioner());
  });

  // poses.csv
  std::string csv;
  csv += "# lunarnav simulated vehicle poses: world x east, y north, z up (m), origin at the first pose's ground;\n";
  csv += "# heading clockwise from north (deg), pitch nose up (deg), roll right side down (deg); pose of the\n";
  csv += "# vehicle frame (X right, Y forward, Z up, origin at the mast base); fault: none|blank|saturated|truncated\n";
  csv += "stem,t_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg,fault\n";
  for (int k = 0; k < options.frames; ++k) {
    const VehiclePose& p = poses[k];
    csv += FrameStem(k) + "," + Format("%.3f", times_s[k]) + "," + Format("%.6f", p.x_m) + "," +
           Format("%.6f", p.y_m) + "," + Format("%.6f", p.z_m - z_origin_m) + "," + Format("%.6f", p.heading_rad / kDeg) + "," +
           Format("%.6f", p.pitch_rad / kDeg) + "," + Format("%.6f", p.roll_rad / kDeg) + "," + ToString(faults[k]) +
           "\n";
  }
  io::WriteFileAtomic(output_dir / "truth" / "poses.csv", csv);

  // boxes.json
  json boxes_world = json::array();
  for (std::size_t i = 0; i < scene->boxes().size(); ++i) {
    const Box& b = scene->boxes()[i];
    boxes_world.push_back({{"index", i},
                           {"label", SurfaceHit::kFirstBox + static_cast<int>(i)},
                           {"min_m", {b.min_m.x(), b.min_m.y(), b.min_m.z()}},
                           {"max_m", {b.max_m.x(), b.max_m.y(), b.max_m.z()}}});
  }
  io::WriteJsonAtomic(output_dir / "truth" / "boxes.json",
                      {{"format", "lunarnav.boxes/1"},
                       {"frame", "vehicle frame of the first pose (X right, Y forward, Z up, metres)"},
                       {"boxes", box_frames.front()["boxes"]},
                       {"world", boxes_world},
                       {"frames", box_frames}});

  // summary.json
  StereoFrameStats totals;
  json frames_json = json::array();
  for (int k = 0; k < options.frames; ++k) {
    const StereoFrameStats& st = stats[k];
    totals.pixels += st.pixels;
    totals.sky += st.sky;
    totals.occluded += st.occluded;
    totals.outside += st.outside;
    totals.disparity += st.disparity;
    summary.render_seconds += st.render_s;
    summary.write_seconds += write_s[k];
    if (faults[k] != FrameFault::kNone) ++summary.faults;
    json entry = st.ToJson();
    entry["stem"] = FrameStem(k);
    entry["fault"] = ToString(faults[k]);
    entry["write_s"] = write_s[k];
    frames_json.push_back(entry);
  }
  summary.frames = options.frames;
  summary.seconds = total.ElapsedSeconds();
  json j = summary_head;
  j["output_dir"] = output_dir.string();
  j["options"] = options.ToJson();
  j["render"] = render_options.ToJson();
  j["rig"] = RigSummary(rig);
  j["scene"] = scene->options().ToJson();
  j["threads"] = util::EffectiveThreadCount(options.num_threads);
  j["counts"] = {{"frames", summary.frames},
                 {"faults", summary.faults},
                 {"truth_pixels", totals.pixels},
                 {"truth_sky", totals.sky},
                 {"truth_occluded", totals.occluded},
                 {"truth_outside", totals.outside},
                 {"truth_disparity", totals.disparity}};
  j["timings_s"] = {{"total", summary.seconds},
                    {"scene", summary.scene_seconds},
                    {"render_sum", summary.render_seconds},
                    {"write_sum", summary.write_seconds}};
  j["peak_memory_mib"] = util::PeakResidentMemoryMiB();
  j["frames"] = frames_json;
  summary.summary_path = output_dir / "summary.json";
  io::WriteJsonAtomic(summary.summary_path, j);
  return summary;
}

}  // namespace lunarnav::sim
