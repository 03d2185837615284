// Synthetic stereo views of a chessboard target, with the exact corner positions, for
// testing calibration and for `simulate chessboard` (sim/chessboard_sim.h).
//
// A planar board (black and white squares on a white plate with a margin, in front of a
// uniform background) is placed in N poses in front of a stereo rig; both cameras image it
// through their lens distortion. Each pixel integrates the scene over S x S samples (box
// filter, anti-aliased edges). The exact corners are the board's inner corners projected
// with OpenCV's camera model (cv::projectPoints), the model calibration estimates.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "calib/chessboard.h"
#include "calib/stereo_rig.h"

namespace lunarnav::sim {

/// How the views are chosen and drawn.
struct ChessboardViewsOptions {
  calib::ChessboardSpec board;  ///< 9x6 inner corners, 0.1 m squares.
  int num_views = 12;           ///< N, >= 1.
  /// Range of the board centre's depth along the left camera's optical axis, metres. The
  /// board must fit in both images: with a 0.9 m baseline and a 740 px focal length a 1 m
  /// board fits from about 2 m.
  double min_distance_m = 2.0;
  double max_distance_m = 5.0;
  /// Largest out-of-plane tilt of the board away from facing the left camera, degrees
  /// [0, 60]; each view's tilt is drawn in [0.3, 1] x this, about a random in-plane axis
  /// (tilted views are what make the focal length observable).
  double max_tilt_deg = 40.0;
  double max_roll_deg = 30.0;    ///< In-plane rotation, uniform in +-this, degrees.
  double border_squares = 0.75;  ///< White plate margin around the squares, in squares.
  double margin_px = 2.0;        ///< The whole plate stays this far inside both images.
  int samples_per_axis = 2;      ///< S: S x S samples per pixel, 1..16.
  double black = 30.0;           ///< Grey level of the black squares (0..255).
  double white = 215.0;          ///< Grey level of the white squares and plate.
  double background = 90.0;      ///< Grey level behind the board.
  /// Gaussian blur of the optics (point spread function), pixels, [0, 10]; 0 = none. A
  /// little blur, as any lens has, lets sub-pixel corner refinement reach 0.05 px.
  double blur_sigma_px = 0.7;
  double noise_sigma = 0.0;      ///< Gaussian noise added to each image, grey levels, >= 0.
  bool render_images = true;     ///< false: poses and exact corners only (fast).
  std::uint32_t seed = 1;        ///< Everything is a deterministic function of the seed.

  /// @throws std::invalid_argument naming the option.
  void Validate() const;
  nlohmann::json ToJson() const;
};

/// One stereo view of the board.
struct ChessboardView {
  cv::Mat left, right;  ///< CV_8UC1 of the rig's raw size; empty unless render_images.
  /// Exact projections of the inner corners, pixels (centres at integers), board order
  /// (calib::ChessboardSpec): what a perfect detector would return.
  std::vector<cv::Point2d> left_corners_px, right_corners_px;
  Eigen::Isometry3d left_from_board = Eigen::Isometry3d::Identity();  ///< Board pose, metres.
};

/// Generates `options.num_views` views of the board seen by `rig`. Poses are spread over the
/// image (the board centre visits the cells of a 3 x 3 grid over the stereo overlap in turn),
/// and every pose keeps the whole plate inside both images and facing both cameras.
/// Rendering uses all cores; the result does not depend on the number of threads.
/// @throws std::invalid_argument for bad options, or when no pose can be found that shows the
///         whole board in both images (the board is too large for the overlap at these
///         distances).
std::vector<ChessboardView> GenerateChessboardViews(const calib::StereoRig& rig,
                                                    const ChessboardViewsOptions& options);

/// The file stem of view `index`: "view_000", "view_001", ...
std::string ChessboardViewStem(int index);

/// Writes rendered views as a `calibrate` input directory, every file atomically:
/// DIR/left/<stem>.png and DIR/right/<stem>.png (stems from ChessboardViewStem), DIR/rig.json
/// (the true rig, lunarnav.rig/1) and DIR/truth.json (the options, and per view the board
/// pose in the left camera frame and the exact corners of both images, pixels). DIR and its
/// subdirectories are created.
/// @throws std::invalid_argument when the views were not rendered.
void WriteChessboardViews(const std::filesystem::path& dir, const calib::StereoRig& rig,
                          const ChessboardViewsOptions& options, const std::vector<ChessboardView>& views);

}  // namespace lunarnav::sim
