// `simulate stereo`: sequences of stereo pairs of the paper's rig driving over simulated
// terrain, with exact ground truth (Krotkov & Hebert sec. 3.1-3.5). docs/simulate-stereo.md
// describes the presets, options and outputs.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calib/stereo_rig.h"
#include "sim/scene.h"
#include "sim/stereo_render.h"
#include "sim/vehicle_pose.h"

namespace lunarnav::sim {

/// A fault injected into one frame (sec. 3.5: "disconnection of video cables, and ... abrupt
/// lighting changes that overwhelm the auto-iris lenses").
enum class FrameFault {
  kNone,
  kBlank,      ///< Both images black (cable disconnected).
  kSaturated,  ///< Both images overexposed: grey * 4 + 40, clipped (abrupt light change).
  kTruncated   ///< The left image file cut to half its bytes (a partial write).
};
std::string ToString(FrameFault fault);
/// "blank", "saturated" or "truncated"; std::invalid_argument otherwise.
FrameFault FrameFaultFromString(const std::string& name);

struct FrameFaultSpec {
  int frame = 0;
  FrameFault fault = FrameFault::kBlank;
};
/// "K:KIND", e.g. "3:blank"; std::invalid_argument naming `what` otherwise.
FrameFaultSpec ParseFrameFaultSpec(const std::string& text, const std::string& what = "--fault");

/// Options of a simulated stereo run; the defaults are the paper's.
struct StereoSimOptions {
  std::string preset = "terrain";  ///< "terrain" (rocky height field) or "boxes" (sec. 3.4).

  // The rig (sec. 3.1): 640 x 480, 8 mm lenses on a 6.9 mm wide sensor (f = 740 px: a 1-px
  // disparity error is 10 cm of range at 8 m, 60 cm at 20 m), 0.9 m baseline, head 1.5 m
  // above the mast base, tilted 25 deg down.
  int width_px = 640, height_px = 480;
  double focal_px = 740.0;
  double baseline_m = 0.9;
  double mast_height_m = 1.5;
  double tilt_deg = 25.0;

  // Realism, each switchable.
  bool rectified = false;        ///< Render the ideal rectified pair instead of the raw cameras.
  bool lens_distortion = true;   ///< Raw cameras with radial/tangential distortion.
  bool camera_rotation = true;   ///< A small rotation (about 0.2 deg) between the cameras.
  bool exposure_difference = true;  ///< Different gain and offset per camera (auto-iris).
  double noise_sigma = 1.0;      ///< Sensor noise, grey levels (0 = off).
  bool quantize = true;          ///< 8-bit PNG images; false: float32 TIFF, unrounded.
  int rays_per_pixel = 4;        ///< A square: 1, 4, 9, ..., 64.

  // Sequence (sec. 4.2's speeds: 310 images over 150 m at 0.15 m/s).
  int frames = 1;                 ///< Frames along the trajectory, >= 1.
  double speed_mps = 0.15;        ///< Vehicle speed.
  double interval_s = 3.2;        ///< Time between frames (0.48 m at 0.15 m/s).
  double turn_radius_m = 0.0;     ///< 0: straight; > 0 a right-hand arc, < 0 a left-hand one.
  std::vector<FrameFaultSpec> faults;  ///< Frames to spoil.

  // Scene.
  double terrain_cell_m = 0.02;   ///< Height-field grid spacing.
  double rock_density_per_m2 = -1;  ///< -1: the preset's (terrain 0.4, boxes 0).
  double relief_amplitude_m = -1;   ///< -1: the preset's (terrain 0.3, boxes 0).

  /// Cell of the true DEM truth/terrain.tif, metres, in [0.05, 5] (terrain-map's default).
  double truth_cell_m = 0.25;

  std::uint64_t seed = 1;  ///< Scene, texture and noise; the same seed gives the same bytes.
  int num_threads = 0;     ///< 0 = all cores.
  bool show_progress = true;

  void Validate() const;  ///< std::invalid_argument naming the option.
  nlohmann::json ToJson() const;
};

/// The simulated rig: the paper's geometry with the realism switches applied, rectified
/// (calib::RectifyRig, alpha 0): the geometry of the ground truth.
calib::StereoRig MakeSimulatedRig(const StereoSimOptions& options);

/// The vehicle's poses along the trajectory, resting on `terrain` (z, pitch and roll from
/// the ground under its wheels, 1 m apart both ways). The trajectory starts at the world
/// origin heading north.
std::vector<VehiclePose> MakeTrajectory(const StereoSimOptions& options, const Terrain* terrain);

/// The scene of the preset for a trajectory (the terrain covers what the cameras see from
/// every pose). The boxes preset: flat textured ground and seven 0.5 m boxes whose front
/// faces are at vehicle Y = 2, 3, ..., 8 m from the first pose (sec. 3.4).
SceneOptions MakeSceneOptions(const StereoSimOptions& options);

/// The render options the simulation options imply.
StereoRenderOptions MakeRenderOptions(const StereoSimOptions& options);

struct StereoSimSummary {
  int frames = 0, faults = 0;
  double seconds = 0, scene_seconds = 0, render_seconds = 0, write_seconds = 0;
  std::filesystem::path summary_path;
  std::string BriefReport() const;  ///< e.g. "3 frames (1 fault); 2.10 s".
};

/// Renders the run and writes OUT_DIR/left/<stem>.png, right/<stem>.png (stems 000000,
/// 000001, ...), truth/disparity/<stem>.pfm, truth/xyz/<stem>.exr, truth/poses.csv,
/// truth/boxes.json, truth/terrain.tif (the true DEM, sim/terrain_truth.h), truth/rocks.csv,
/// rig.json and summary.json, every file atomically.
/// @throws std::invalid_argument for bad options or an unusable output directory.
StereoSimSummary RunStereoSimulation(const StereoSimOptions& options, const std::filesystem::path& output_dir,
                                     const nlohmann::json& invocation = nullptr);

/// Renders and writes the frames of `poses` (world poses of the vehicle over `scene`, one per
/// frame, options.frames of them) as RunStereoSimulation does, poses.csv's t_s from `times_s`;
/// the written heights (poses.csv's z, terrain.tif's elevations) are taken relative to
/// `z_origin_m`. `summary_head`: summary.json's first keys (the tool, version, command line,
/// subcommand); `scene_seconds`: what building the scene took, for the timings.
StereoSimSummary RenderStereoSequence(const StereoSimOptions& options, const Scene& scene,
                                      const std::vector<VehiclePose>& poses, const std::vector<double>& times_s,
                                      double z_origin_m, const std::filesystem::path& output_dir,
                                      const nlohmann::json& summary_head, double scene_seconds);

/// The file stem of frame k: six digits.
std::string FrameStem(int k);

}  // namespace lunarnav::sim
