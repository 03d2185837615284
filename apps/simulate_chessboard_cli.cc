#include "apps/simulate_chessboard_cli.h"

#include <filesystem>
#include <memory>
#include <string>

#include "sim/chessboard_sim.h"
#include "util/log.h"
#include "util/parse.h"
#include "util/run_main.h"

namespace lunarnav::apps {

std::function<int(const nlohmann::json&, bool)> RegisterChessboardCommand(CLI::App& app) {
  struct State {
    sim::ChessboardSimOptions options;
    std::filesystem::path output_dir;
    std::string board = "9x6", distance = "2:5";
    bool no_distortion = false, no_rotation = false;
  };
  auto state = std::make_shared<State>();
  sim::ChessboardSimOptions& o = state->options;
  sim::ChessboardViewsOptions& v = o.views;
  CLI::App* cmd = app.add_subcommand(
      "chessboard",
      "Renders a chessboard in many poses through both raw cameras of the paper's rig (0.9 m\n"
      "baseline, 640x480, f = 740 px, lens distortion), with the true calibration: OUT_DIR/left,\n"
      "right (as `calibrate` reads them), rig.json, truth.json, summary.json (docs/simulate.md).");
  cmd->fallthrough();  // the tool's own flags (-q, --version) may follow the subcommand
  cmd->add_option("-o,--output", state->output_dir, "output directory (created)")->required();
  cmd->add_option("--views", v.num_views, "board poses (stereo views), 1..10000")->capture_default_str();
  cmd->add_option("--board", state->board, "inner corners COLSxROWS")->capture_default_str();
  cmd->add_option("--square", v.board.square_size_m, "side of one square, m")->capture_default_str();
  cmd->add_option("--distance", state->distance, "MIN:MAX depth of the board centre in the left camera, m")
      ->capture_default_str();
  cmd->add_option("--max-tilt", v.max_tilt_deg, "largest tilt of the board away from the left camera, deg (0..60)")
      ->capture_default_str();
  cmd->add_option("--noise", v.noise_sigma, "sensor noise sigma, grey levels (0 = off)")->capture_default_str();
  cmd->add_option("--blur", v.blur_sigma_px, "optical blur sigma, px (0 = none)")->capture_default_str();
  cmd->add_flag("--no-distortion", state->no_distortion, "raw cameras without lens distortion");
  cmd->add_flag("--no-rotation", state->no_rotation, "no rotation between the cameras");
  cmd->add_option("--width", o.width_px, "image width, px")->capture_default_str();
  cmd->add_option("--height", o.height_px, "image height, px")->capture_default_str();
  cmd->add_option("--focal", o.focal_px, "focal length, px")->capture_default_str();
  cmd->add_option("--baseline", o.baseline_m, "baseline, m")->capture_default_str();
  cmd->add_option("--mast-height", o.mast_height_m, "head height above the mast base, m (recorded in rig.json)")
      ->capture_default_str();
  cmd->add_option("--tilt", o.tilt_deg, "downward tilt, deg (recorded in rig.json)")->capture_default_str();
  cmd->add_option("--seed", v.seed, "poses and noise seed (same seed, same bytes)")->capture_default_str();
  cmd->add_option("-j,--threads", o.num_threads, "worker threads (0 = all cores)")->capture_default_str();

  return [state](const nlohmann::json& invocation, bool /*quiet*/) {
    return util::RunMain([&] {
      sim::ChessboardSimOptions opt = state->options;
      std::tie(opt.views.board.cols, opt.views.board.rows) = util::ParseIntPair(state->board, 'x', "--board");
      std::tie(opt.views.min_distance_m, opt.views.max_distance_m) =
          util::ParseDoublePair(state->distance, ':', "--distance");
      opt.lens_distortion = !state->no_distortion;
      opt.camera_rotation = !state->no_rotation;
      const sim::ChessboardSimSummary summary = sim::RunChessboardSimulation(opt, state->output_dir, invocation);
      LN_LOG(Info) << "simulate chessboard: " << summary.BriefReport();
      LN_LOG(Info) << "outputs in " << state->output_dir.string() << "/{left,right}, rig "
                   << (state->output_dir / "rig.json").string() << ", summary " << summary.summary_path.string();
      return 0;
    });
  };
}

}  // namespace lunarnav::apps
