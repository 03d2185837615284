// `simulate chessboard`: chessboard views of the paper's rig (Krotkov & Hebert sec. 3.1-3.2)
// for `calibrate`, with the true calibration. docs/simulate.md describes the options and
// outputs; the rendering is sim/chessboard_views.
#pragma once

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "calib/stereo_rig.h"
#include "sim/chessboard_views.h"

namespace lunarnav::sim {

/// Options of a simulated calibration session; the defaults are the paper's rig and a 9x6
/// board of 0.1 m squares in 15 poses.
struct ChessboardSimOptions {
  // The rig, exactly as `simulate stereo` builds it from the same values (MakeSimulatedRig):
  // 640 x 480, f = 740 px, 0.9 m baseline, head 1.5 m up, tilted 25 deg down.
  int width_px = 640, height_px = 480;
  double focal_px = 740.0;
  double baseline_m = 0.9;
  double mast_height_m = 1.5;
  double tilt_deg = 25.0;
  bool lens_distortion = true;  ///< The raw cameras' distortion (as `simulate stereo`).
  bool camera_rotation = true;  ///< The small rotation between the cameras (as `simulate stereo`).

  /// The board, its poses and the rendering; `views.seed` seeds everything. Defaults here:
  /// 15 views, 1 grey level of sensor noise.
  ChessboardViewsOptions views = DefaultViews();
  int num_threads = 0;  ///< 0 = all cores; the outputs do not depend on it.

  static ChessboardViewsOptions DefaultViews();
  /// @throws std::invalid_argument naming the option.
  void Validate() const;
  nlohmann::json ToJson() const;
};

/// The true rig of the session: MakeSimulatedRig of the same rig options (raw calibration
/// and its rectification), so `simulate stereo` with those options writes the same rig.json.
calib::StereoRig MakeChessboardRig(const ChessboardSimOptions& options);

struct ChessboardSimSummary {
  int views = 0;
  double seconds = 0, render_seconds = 0, write_seconds = 0;
  std::filesystem::path summary_path;
  std::string BriefReport() const;  ///< e.g. "15 views of a 9x6 board; 2.10 s".
};

/// Renders the session and writes OUTPUT_DIR/left/view_NNN.png, right/view_NNN.png, rig.json,
/// truth.json (WriteChessboardViews) and summary.json, every file atomically. Every file but
/// summary.json is a function of the options alone.
/// @throws std::invalid_argument for bad options, a board that cannot be placed in both
///         images, or an unusable output directory.
ChessboardSimSummary RunChessboardSimulation(const ChessboardSimOptions& options,
                                             const std::filesystem::path& output_dir,
                                             const nlohmann::json& invocation = nullptr);

}  // namespace lunarnav::sim
