// Figure 2 of Krotkov & Hebert (1995), sec. 3.3: the stereo computation time as a function of
// the width dY = Y_max - Y_min of the requested distance interval for Y_min = 5 m, normalised
// to the largest, beside the share of the work (rows x disparities) window selection predicts.
#pragma once

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "calib/stereo_rig.h"
#include "calib/window_selection.h"
#include "evaluation/table.h"
#include "stereo/ncc_options.h"

namespace lunarnav::evaluation {

struct TimingStudyOptions {
  TimingStudyOptions() { matcher.num_threads = 1; }  // serial: the steadiest timing
  /// Window, steps, filters, reference and threads of the matcher (its defaults are the
  /// paper's). Its disparity range is the search of the whole image without window selection
  /// (the reference row of the table); each dY replaces rows and range by its window. Serial
  /// (num_threads = 1) by default.
  stereo::NccOptions matcher;
  double y_min_m = 5.0;                       ///< The paper's Y_min.
  std::vector<double> delta_y_m = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};
  double z_min_m = -0.5, z_max_m = 1.0;       ///< Heights of the objects (as stereo-batch --z-range).
  calib::WindowSelectionOptions window_selection;
  int repeat = 3;                             ///< Timed runs per window; the median is kept.
  /// Throws std::invalid_argument naming the bad option.
  void Validate() const;
  nlohmann::json ToJson() const;
};

/// One window of the study: a dY, or the whole image (no window selection).
struct TimingPoint {
  std::optional<double> delta_y_m;  ///< Unset for the whole image.
  calib::ImageWindow window;        ///< Rows and disparities searched (inclusive).
  /// rows x disparities of this window over image height x the full disparity range.
  double work_share = 0;
  /// Per repeat, the mean matching time of one pair, seconds.
  std::vector<double> repeat_seconds;
  double seconds = 0;               ///< Median of repeat_seconds.
  /// First and third quartiles of repeat_seconds (Quantile): the spread of the machine's
  /// timing. Two windows' times differ beyond that noise only when their interquartile
  /// ranges do not overlap.
  double seconds_q1 = 0, seconds_q3 = 0;
  long long evaluated_pixels = 0;   ///< Over all pairs (of one run).
  /// seconds and work_share divided by their largest value over the dY points; seconds over
  /// the whole image's.
  double time_normalised = 0, work_normalised = 0, time_share = 0;
};

struct TimingStudy {
  TimingStudyOptions options;
  int pairs = 0;
  int width_px = 0, height_px = 0;
  std::vector<TimingPoint> points;  ///< One per dY, in the order given.
  TimingPoint full;                 ///< The whole image with the matcher's disparity range.
};

/// Each value divided by the largest finite one (NaN stays NaN; all NaN or a largest value
/// <= 0 gives NaN everywhere).
std::vector<double> NormaliseToLargest(const std::vector<double>& values);

/// Median (the mean of the two middle values for an even count); NaN for none.
double Median(std::vector<double> values);
/// The p-quantile (p in [0, 1]) interpolated linearly between the sorted values: with
/// h = (n - 1) p, x[floor h] + (h - floor h) (x[floor h + 1] - x[floor h]) (R's type 7, numpy's
/// default; p = 0.5 is the median). NaN for none.
double Quantile(std::vector<double> values, double p);

/// The windows of the study for a rectified rig (no timing): every dY's window by
/// calib::SelectWindow and the whole image's, with their work shares.
/// @throws std::invalid_argument for bad options, a rig that is not rectified, or a dY whose
///         interval the reference camera does not see.
TimingStudy PlanTimingStudy(const calib::StereoRig& rig, const TimingStudyOptions& options);

/// Fills time_normalised, work_normalised and time_share from seconds and work_share.
void NormaliseTimingStudy(TimingStudy* study);

/// Plans the study, then times stereo::MatchStereoPair on every pair for every window
/// (`repeat` rounds; within a round every window runs over every pair in turn, so a change of
/// machine load affects all windows alike) and normalises.
/// @param pairs  rectified (left, right) images of the rig's rectified size.
/// @param progress  called after each window of each round (may be empty).
/// @throws InputError when a pair's size differs from the rig's; as PlanTimingStudy.
TimingStudy RunTimingStudy(const calib::StereoRig& rig, const std::vector<std::pair<cv::Mat, cv::Mat>>& pairs,
                           const TimingStudyOptions& options, const std::function<void()>& progress = {});

/// One row per dY and a last row for the whole image: window, rows, disparities, work share,
/// time per pair, normalised time and work, time as a share of the whole image's, and the
/// first and third quartiles of the repeated runs.
Table TimingTable(const TimingStudy& study);
/// The data of the figure: delta_y_m, y_max_m, time_normalised, work_normalised, time_ms,
/// rows, disparities, time_q1_normalised, time_q3_normalised (the runs' quartiles on the
/// median's scale; one line per dY).
std::string TimingCurveCsv(const TimingStudy& study);
/// gnuplot commands: normalised time (with the interquartile range) and predicted work
/// against dY, reading `curve_csv`.
std::string TimingFigureCommands(const TimingStudy& study, const std::string& curve_csv);

/// The inputs and options of `evaluate timing` (docs/evaluate.md), the pairs as text as the
/// command line gives them.
struct TimingCommand {
  std::filesystem::path pairs, rig, output_dir;  ///< pairs: a directory with left/ and right/.
  std::string window = "25x17";                  ///< Half-sizes WXxWY of the correlation window.
  std::string step = "1x1";                      ///< Partial subsampling steps DXxDY.
  std::string disparity = "0:127";               ///< MIN:MAX, the whole-image search.
  std::string z_range = "-0.5:1";                ///< ZMIN:ZMAX, heights of the objects (m).
  std::string reference = "right";               ///< stereo::ReferenceImageFromString.
  int max_pairs = 0;                             ///< Time only the first N pairs; 0 = all.
  bool progress = true;                          ///< Show a progress bar on stderr.
  TimingStudyOptions options;                    ///< Window, steps, range, heights and reference set from the above.
};

/// `evaluate timing`: reads the pairs, runs the study and writes the timing table, timing_curve.csv,
/// the figure and summary.json (`summary_head` plus inputs, options, counts, every repeat's
/// time, table, figures).
/// @return kExitOk. @throws std::invalid_argument for bad options (before any pair is read);
///         InputError for unreadable pairs or pairs of another size than the rig's.
int RunTimingCommand(const TimingCommand& command, const nlohmann::json& summary_head);

}  // namespace lunarnav::evaluation
