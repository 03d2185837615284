#include "apps/simulate_stereo_cli.h"

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "sim/stereo_sim.h"
#include "util/log.h"
#include "util/run_main.h"

namespace lunarnav::apps {

void AddStereoRenderOptions(CLI::App* cmd, StereoRenderFlags* flags) {
  sim::StereoSimOptions& o = flags->options;
  cmd->add_option("--fault", flags->faults, "FRAME:KIND, KIND blank|saturated|truncated (repeatable)");
  cmd->add_option("--width", o.width_px, "image width, px")->capture_default_str();
  cmd->add_option("--height", o.height_px, "image height, px")->capture_default_str();
  cmd->add_option("--focal", o.focal_px, "focal length, px")->capture_default_str();
  cmd->add_option("--baseline", o.baseline_m, "baseline, m")->capture_default_str();
  cmd->add_option("--mast-height", o.mast_height_m, "head height above the mast base, m")->capture_default_str();
  cmd->add_option("--tilt", o.tilt_deg, "downward tilt, deg")->capture_default_str();
  cmd->add_flag("--rectified", o.rectified, "render the ideal rectified pair (no rectification needed)");
  cmd->add_flag("--no-distortion", flags->no_distortion, "raw cameras without lens distortion");
  cmd->add_flag("--no-rotation", flags->no_rotation, "no rotation between the cameras");
  cmd->add_flag("--no-exposure-difference", flags->no_exposure, "same gain and offset in both cameras");
  cmd->add_option("--noise", o.noise_sigma, "sensor noise sigma, grey levels (0 = off)")->capture_default_str();
  cmd->add_flag("--no-quantize", flags->no_quantize, "float32 TIFF images instead of 8-bit PNG");
  cmd->add_option("--rays", o.rays_per_pixel, "rays per pixel (a square: 1, 4, 9, ...)")->capture_default_str();
  cmd->add_option("--terrain-cell", o.terrain_cell_m, "height-field grid spacing, m")->capture_default_str();
  cmd->add_option("--truth-cell", o.truth_cell_m, "cell of the true DEM truth/terrain.tif, m (terrain-map's)")->capture_default_str();
  cmd->add_option("--rock-density", o.rock_density_per_m2, "rocks per m^2 (default: the preset's)");
  cmd->add_option("--relief", o.relief_amplitude_m, "relief amplitude, m (default: the preset's)");
  cmd->add_option("--seed", o.seed, "scene, texture and noise seed (same seed, same bytes)")->capture_default_str();
  cmd->add_option("-j,--threads", o.num_threads, "worker threads (0 = all cores)")->capture_default_str();
}

sim::StereoSimOptions StereoRenderFlags::Resolved(bool quiet) const {
  sim::StereoSimOptions opt = options;
  opt.lens_distortion = !no_distortion;
  opt.camera_rotation = !no_rotation;
  opt.exposure_difference = !no_exposure;
  opt.quantize = !no_quantize;
  opt.show_progress = !quiet;
  for (const std::string& f : faults) opt.faults.push_back(sim::ParseFrameFaultSpec(f));
  return opt;
}

std::function<int(const nlohmann::json&, bool)> RegisterStereoCommand(CLI::App& app) {
  struct State {
    StereoRenderFlags flags;
    std::filesystem::path output_dir;
  };
  auto state = std::make_shared<State>();
  sim::StereoSimOptions& o = state->flags.options;
  CLI::App* cmd = app.add_subcommand(
      "stereo",
      "Renders stereo pairs of the paper's rig (0.9 m baseline, 1.5 m up, 25 deg down, 640x480,\n"
      "f = 740 px) by ray casting, with ground truth: OUT_DIR/left, right, truth/, rig.json,\n"
      "summary.json (docs/simulate-stereo.md).");
  cmd->fallthrough();  // the tool's own flags (-q, --version) may follow the subcommand
  cmd->add_option("-o,--output", state->output_dir, "output directory (created)")->required();
  cmd->add_option("--preset", o.preset, "scene: terrain (rocky height field) or boxes (sec. 3.4)")
      ->check(CLI::IsMember({"terrain", "boxes"}))
      ->capture_default_str();
  cmd->add_option("--frames", o.frames, "frames along the trajectory")->capture_default_str();
  cmd->add_option("--speed", o.speed_mps, "vehicle speed, m/s")->capture_default_str();
  cmd->add_option("--interval", o.interval_s, "time between frames, s")->capture_default_str();
  cmd->add_option("--turn-radius", o.turn_radius_m, "0: straight; > 0 right-hand arc, < 0 left-hand, m")
      ->capture_default_str();
  AddStereoRenderOptions(cmd, &state->flags);

  return [state](const nlohmann::json& invocation, bool quiet) {
    return util::RunMain([&] {
      const sim::StereoSimOptions opt = state->flags.Resolved(quiet);
      const sim::StereoSimSummary summary = sim::RunStereoSimulation(opt, state->output_dir, invocation);
      LN_LOG(Info) << "simulate stereo: " << summary.BriefReport();
      LN_LOG(Info) << "outputs in " << state->output_dir.string() << "/{left,right,truth}, rig "
                   << (state->output_dir / "rig.json").string() << ", summary " << summary.summary_path.string();
      return 0;
    });
  };
}

}  // namespace lunarnav::apps
