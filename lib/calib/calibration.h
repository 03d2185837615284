// Stereo calibration from chessboard views (the `calibrate` tool): corner detection in
// INPUT_DIR/left and INPUT_DIR/right, OpenCV's calibrateCamera for each camera, then
// stereoCalibrate for the pose between them, with the quality measures a user needs to
// trust the result (reprojection errors per view, row error after rectification).
#pragma once

#include <cmath>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "calib/chessboard.h"
#include "calib/stereo_rig.h"

namespace lunarnav::calib {

/// Options of a calibration. The camera model is OpenCV's pinhole with k1 k2 p1 p2 k3.
struct CalibrationOptions {
  ChessboardSpec board;  ///< --board COLSxROWS (inner corners), --square METRES.
  MastPose mast;         ///< Written to the rig file as given (calibration cannot see it).
  /// Fewest views with the board found in both images; fewer is an InputError. >= 3
  /// (OpenCV's minimum for a unique solution is 3; 5 leaves a margin against bad views).
  int min_views = 5;
  /// Estimate k3 as well (wide-angle lenses). Off by default: with a few views of a small
  /// board k3 is poorly determined and trades off against k1 k2 at the image corners.
  bool estimate_k3 = false;
  /// Keep each camera's intrinsics from its own calibrateCamera in stereoCalibrate
  /// (CALIB_FIX_INTRINSIC); by default they are refined jointly with the pose, which uses
  /// both images of every view (CALIB_USE_INTRINSIC_GUESS).
  bool fix_intrinsics = false;
  /// A view whose stereo RMS reprojection error exceeds this is flagged in the report
  /// ("high"), pixels, > 0. It is still used (unless dropped as an outlier).
  double flag_view_rms_px = 1.0;
  /// Drop outlier views: after a calibration, the view with the largest screening error
  /// (the larger of its two images' RMS reprojection errors when each camera keeps the
  /// intrinsics of its own calibrateCamera and only the pose between the cameras is fitted,
  /// so that a bad view cannot spread its error over the intrinsics) is dropped when it exceeds both
  /// median + drop_mad_factor x 1.4826 x MAD of all views' errors (a robust "k sigma") and
  /// drop_min_rms_px; the calibration is then run again, until no view stands out or only
  /// min_views are left.
  bool drop_outliers = true;
  double drop_mad_factor = 5.0;   ///< k of the threshold above, > 0.
  /// Never drop a view whose screening error is below this, pixels, > 0 (sub-pixel corners
  /// of a sound view stay well below it, whatever the spread of the others).
  double drop_min_rms_px = 0.5;
  /// A calibration whose stereo RMS reprojection error still exceeds this after the outliers
  /// are dropped has not converged (exit 3), pixels, > 0. Sub-pixel corners of a good
  /// target give 0.05-0.5 px.
  double max_rms_px = 2.0;
  /// The right image's corners are put in the left image's order unless the best order's
  /// displacement spread is within this factor of the next one's (MatchRightCornerOrder), > 1.
  double order_min_ratio = 2.0;
  int num_threads = 0;        ///< Corner detection threads; 0 = all cores.
  bool show_progress = true;  ///< Progress bar on stderr (only when it is a terminal).

  /// @throws std::invalid_argument naming the option.
  void Validate() const;
  nlohmann::json ToJson() const;
};

/// The detected corners of one stereo view (both images), pixels, board order.
struct StereoCorners {
  std::string stem;
  std::vector<cv::Point2f> left, right;
};

/// What happened to one view.
struct ViewReport {
  enum class Status {
    kUsed,     ///< The board was found in both images; the view took part in the calibration.
    kSkipped,  ///< The board was not found in one or both images, or its orientation undecided.
    kDropped,  ///< An outlier: its reprojection error stood far above the others'.
    kFailed    ///< An image is missing, unreadable or of another size.
  };
  std::string stem;
  Status status = Status::kFailed;
  std::string reason;  ///< For kSkipped, kDropped and kFailed; a note for kUsed.
  /// For kUsed: RMS reprojection error of the view's corners after stereoCalibrate, pixels;
  /// for kDropped: in the calibration that dropped it.
  double rms_left_px = NAN, rms_right_px = NAN;
  /// For kUsed and kDropped: mean and max |y_left - y_right| of the view's corners after
  /// rectification with the calibrated rig, pixels (0 for a perfect calibration and detection).
  double mean_row_error_px = NAN, max_row_error_px = NAN;
};

std::string ToString(ViewReport::Status status);

/// The calibrated rig and its quality.
struct CalibrationResult {
  StereoRig rig;  ///< Raw calibration (no rectified geometry), with the options' mast pose.
  double rms_stereo_px = NAN;  ///< stereoCalibrate's RMS reprojection error over both images.
  double rms_left_px = NAN, rms_right_px = NAN;  ///< Each camera's calibrateCamera RMS.
  /// Over the corners of all used views after rectification, |y_left - y_right|, pixels.
  double mean_row_error_px = NAN, max_row_error_px = NAN;
  std::vector<ViewReport> views;  ///< Name order; every listed view.
  int views_listed = 0, views_used = 0, views_skipped = 0, views_dropped = 0, views_failed = 0;
  /// Stereo RMS of the first calibration (all views with a decided orientation), pixels.
  double first_rms_stereo_px = NAN;
  int calibrations = 0;  ///< Calibrations run (1 + the views dropped).

  /// Recounts views_listed, _used, _skipped, _dropped, _failed from `views`.
  void Recount();

  /// e.g. "12 views: 11 used, 1 skipped, 0 failed; RMS 0.08 px; row error 0.02 px".
  std::string BriefReport() const;
  /// The per-view table and the totals, one line each, for stdout.
  std::string Table() const;
  /// Results (not the rig itself) for summary.json.
  nlohmann::json ToJson() const;
};

/// Calibrates a rig from detected corners: the right image's corners of each view put in the
/// left image's order (MatchRightCornerOrder; a view whose order cannot be decided is
/// skipped), calibrateCamera per camera, then stereoCalibrate; outlier views dropped and the
/// calibration run again (CalibrationOptions::drop_outliers); then per-view errors and the
/// row error after rectification (RectifyRig + Rectifier).
/// @param image_size  the raw images' size.
/// @param views  views with the board found in both images (corners in any of the board's
///        symmetric orders).
/// @return a result whose `views` holds one report per input view (in input order): kUsed,
///         kSkipped (orientation undecided) or kDropped.
/// @throws InputError when fewer than options.min_views views are usable, or the calibration
///         fails or diverges (a non-positive focal length, a stereo RMS above max_rms_px, a
///         baseline that is not horizontal): the message names the views with the largest
///         errors and their RMS; std::invalid_argument for bad options.
CalibrationResult CalibrateStereoRig(const CalibrationOptions& options, const cv::Size& image_size,
                                     const std::vector<StereoCorners>& views);

/// What RunCalibration wrote.
struct CalibrationRun {
  CalibrationResult result;
  std::filesystem::path rig_path, summary_path;
  double seconds = 0, detect_seconds = 0, calibrate_seconds = 0;
};

/// The whole `calibrate` tool: lists the pairs of INPUT_DIR (left/, right/, same stems),
/// detects the board in both images of each (in parallel), logs every view skipped (board
/// not found) or failed (missing/unreadable image, other size) as one line, calibrates with
/// the rest, and writes the rig file and the summary atomically.
/// @param summary_path  where summary.json goes (options, counts, per-view table, timings).
/// @param invocation  recorded in the summary (e.g. the command line).
/// @throws InputError when INPUT_DIR is unusable or fewer than min_views views have the
///         board in both images (the message lists how many and why the others were left
///         out); std::invalid_argument for bad options.
CalibrationRun RunCalibration(const CalibrationOptions& options, const std::filesystem::path& input_dir,
                              const std::filesystem::path& rig_path,
                              const std::filesystem::path& summary_path,
                              const nlohmann::json& invocation = nullptr);

}  // namespace lunarnav::calib
