// Figure 5 of Krotkov & Hebert (1995): the correlation curve C(d) at one pixel for several
// partial-subsampling steps (dx, dy), beside the peak that conventional subsampling finds.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "evaluation/table.h"
#include "stereo/correlation_curve.h"

namespace lunarnav::evaluation {

struct CorrelationStudyOptions {
  stereo::NccOptions matcher;            ///< Window, disparity range, reference image.
  std::vector<int> steps_x = {1, 3, 5};  ///< The paper's dx.
  std::vector<int> steps_y = {1, 2, 4};  ///< The paper's dy.
  int x = 0, y = 0;                      ///< The pixel, in the reference image.
  int zoom_px = 5;                       ///< Half-width of the magnified plot around the peak.
  void Validate() const;
};

struct CorrelationStudy {
  struct Entry {
    int step_x = 1, step_y = 1;
    stereo::CorrelationCurve partial;       ///< Partial subsampling (the paper's method).
    stereo::CorrelationCurve conventional;  ///< Images and disparities subsampled.
  };
  CorrelationStudyOptions options;
  std::vector<Entry> entries;  ///< For every (dx, dy), dx varying slowest.
};

/// The curves for every (dx, dy). @throws std::invalid_argument for bad options or a pixel
/// outside the images.
CorrelationStudy RunCorrelationStudy(const cv::Mat& left, const cv::Mat& right, const CorrelationStudyOptions& options);

/// d_px and one column C_dx<dx>_dy<dy> per curve (nan where C is undefined).
std::string CorrelationCurvesCsv(const CorrelationStudy& study);
/// Per (dx, dy): the best disparity (integer and sub-pixel) and C, partial and conventional.
Table CorrelationPeaksTable(const CorrelationStudy& study);
/// gnuplot commands for the figure: the complete curves (left) and a magnified window of
/// +-zoom_px around the full-resolution peak (right), reading `curves_csv`.
std::string CorrelationFigureCommands(const CorrelationStudy& study, const std::string& curves_csv);

/// The inputs and options of `evaluate correlation` (docs/evaluate.md).
struct CorrelationCommand {
  std::filesystem::path left, right, output_dir;  ///< Rectified images.
  std::vector<int> pixel;                         ///< X, Y: the pixel, in the reference image.
  std::string reference = "right";                ///< stereo::ReferenceImageFromString.
  CorrelationStudyOptions options;                ///< Its pixel and reference are set from the above.
};

/// `evaluate correlation`: the curves at the pixel; writes correlation_curves.csv, the
/// correlation table and figure, and summary.json (`summary_head` plus inputs, options,
/// counts, table, figures).
/// @return kExitOk. @throws std::invalid_argument for bad options; InputError for unreadable
///         images, images of different sizes, or a pixel outside them.
int RunCorrelationCommand(const CorrelationCommand& command, const nlohmann::json& summary_head);

}  // namespace lunarnav::evaluation
