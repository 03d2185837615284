// Commanded-motion trials scored as in Figure 7 of Krotkov & Hebert (1995): for each motion,
// the distance and orientation the positioning system computed against the ones measured
// with a tape measure and protractor; per trial set, the mean and standard deviation of
// both errors in percent.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "evaluation/table.h"
#include "evaluation/trajectory_eval.h"

namespace lunarnav::evaluation {

/// A measured pose at the start or end of a trial (world frame of the trials file: x east,
/// y north, metres; heading clockwise from north, degrees). The heading may be unknown
/// (not measured), as for the paper's trial C.
struct TrialPose {
  double t_s = 0;
  double x_m = 0, y_m = 0;
  std::optional<double> heading_deg;
};

struct Trial {
  int id = 0;
  std::string description;
  TrialPose start, end;
};

/// Reads a trials file (format "lunarnav.trials/1", docs/formats.md): as `simulate
/// telemetry` writes it, or typed in by hand. @throws InputError naming the file and trial.
std::vector<Trial> ReadTrials(const std::filesystem::path& path);

struct TrialsEvalOptions {
  /// Trials whose true start-to-end distance is shorter than this (turns in place) have no
  /// distance error in percent; their position error in metres is still reported.
  double min_distance_m = 0.5;
  void Validate() const;
};

/// One trial scored. Errors are signed, estimate minus truth.
struct TrialResult {
  Trial trial;
  double true_distance_m = 0, estimated_distance_m = 0;  ///< Horizontal, start to end.
  double distance_error_pct = NAN;  ///< 100 (estimated - true) / true; NaN below min_distance_m.
  double position_error_m = 0;      ///< |estimated displacement - true displacement|, horizontal.
  double true_turn_deg = NAN, estimated_turn_deg = 0;  ///< Heading change, in (-180, 180].
  double heading_error_deg = NAN;   ///< estimated - true turn, wrapped; NaN without true headings.
  double orientation_error_pct = NAN;  ///< heading_error_deg as a percentage of a full turn.
};

/// Scores every trial on `estimate` (poses interpolated at the trial's start and end times;
/// the heading is that of the body's forward axis). @throws InputError when a trial's times
/// lie outside the estimate's span.
std::vector<TrialResult> EvaluateTrials(const std::vector<StampedPose>& estimate,
                                        const std::vector<Trial>& trials,
                                        const TrialsEvalOptions& options);

/// The statistics of one trial set: Figure 7's row.
struct TrialSetSummary {
  std::string name;
  long trials = 0, distance_trials = 0, orientation_trials = 0;
  ErrorStats distance_error_pct, orientation_error_pct;  ///< Signed errors.
  ErrorStats position_error_m, abs_heading_error_deg;
};
TrialSetSummary SummarizeTrials(const std::string& name, const std::vector<TrialResult>& results);

/// Figure 7: one row per set (mean and standard deviation of the distance and orientation
/// errors in percent, with the trial counts and the errors in metres and degrees).
Table TrialsTable(const std::vector<TrialSetSummary>& sets);
/// Every trial of every set, one row each.
Table TrialDetailsTable(const std::vector<std::pair<std::string, std::vector<TrialResult>>>& sets);
/// APE, RPE and drift per set, for sets with a full ground-truth trajectory.
Table TrajectoryErrorsTable(const std::vector<std::pair<std::string, TrajectoryErrors>>& sets,
                            const TrajectoryEvalOptions& options);

/// The heading (clockwise from north, degrees in [0, 360)) of a pose's forward axis.
double HeadingDeg(const Eigen::Isometry3d& world_from_body);

/// The inputs and options of `evaluate trials` (docs/evaluate.md).
struct TrialsCommand {
  /// Trial sets as NAME=TRAJECTORY,TRIALS[,TRUTH]: a posfilter trajectory (.csv or TUM), a
  /// trials file, and optionally the ground-truth trajectory (adds APE/RPE/drift).
  std::vector<std::string> sets;
  std::filesystem::path output_dir;
  std::string alignment = "start";  ///< APE alignment of the truth comparison (AlignmentFromString).
  TrialsEvalOptions options;
  TrajectoryEvalOptions trajectory_options;  ///< Its alignment is set from `alignment`.
};

/// `evaluate trials`: scores every set and writes trials, trial_details and (with truths)
/// trajectory_errors tables, the trials figure and summary.json (`summary_head` plus inputs,
/// options, counts, tables, figures).
/// @return kExitOk. @throws std::invalid_argument for a malformed set or bad options;
///         InputError for unreadable inputs.
int RunTrialsCommand(const TrialsCommand& command, const nlohmann::json& summary_head);

}  // namespace lunarnav::evaluation
