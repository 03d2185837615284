// Trajectory error against ground truth: absolute and relative pose error as evo defines
// them (APE, RPE), and drift over path segments as the KITTI odometry benchmark defines it.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

namespace lunarnav::evaluation {

/// A pose in the ENU world frame: world_from_body (body x forward, y left, z up).
struct StampedPose {
  double t_s = 0;
  Eigen::Isometry3d world_from_body = Eigen::Isometry3d::Identity();
  /// False for a position track (a GPS log): the rotation is the identity and means nothing.
  bool has_attitude = true;
};

/// Reads a trajectory: lunarnav's trajectory CSV (`.csv`, docs/formats.md), a position track
/// (`.csv` with the header `t,east,north[,up]` or `t_s,x_m,y_m[,z_m]`: a GPS log in a local
/// east-north-up frame, metres; further columns ignored; poses without attitude) or TUM
/// ("t x y z qx qy qz qw", any other extension). @throws InputError with file:line.
std::vector<StampedPose> ReadPoses(const std::filesystem::path& path);

/// How the estimate is aligned to the truth before absolute errors are taken.
enum class Alignment {
  kNone,      ///< As they are (both in one world frame, e.g. a compass-referenced ENU).
  kStart,     ///< Translated so the first positions coincide (dead reckoning starts at 0).
  kOrigin,    ///< The first poses made to coincide (evo's --align_origin).
  kRigid,     ///< Least-squares rotation and translation over all poses (Umeyama; evo -a).
  /// Least-squares rotation about the vertical and horizontal translation over all poses,
  /// and the errors horizontal (x, y) only: for 2-D trajectories and maps (a plain dead
  /// reckoning with z = 0, a GPS track).
  kRigid2d,
  /// kRigid2d with a scale of the estimate's positions too (least squares, Umeyama; evo's
  /// --correct_scale in the plane): what is left is the path's shape, without a distance
  /// scale error (e.g. wheels whose rolling radius is not the one stated) that would
  /// otherwise dominate every other error.
  kSimilarity2d
};
/// Whether the alignment is in the plane (its errors horizontal).
bool IsHorizontal(Alignment alignment);
std::string ToString(Alignment alignment);
Alignment AlignmentFromString(const std::string& text);  ///< std::invalid_argument if unknown.

struct TrajectoryEvalOptions {
  Alignment alignment = Alignment::kStart;
  /// RPE pairs: consecutive, non-overlapping pose pairs this far apart along the true path.
  double rpe_delta_m = 1.0;
  /// KITTI drift: segment lengths along the true path, from every `drift_step` pose.
  std::vector<double> drift_segments_m = {5, 10, 20, 40};
  int drift_step = 10;
  void Validate() const;
};

/// evo's statistics of one error.
struct ErrorStats {
  long count = 0;
  double rmse = NAN, mean = NAN, median = NAN, std = NAN, min = NAN, max = NAN;
  static ErrorStats Of(std::vector<double> values);
};

struct TrajectoryErrors {
  long poses_matched = 0;           ///< Estimate poses inside the truth's time span.
  double path_length_m = 0;         ///< Of the truth over the matched span.
  ErrorStats ape_translation_m, ape_rotation_deg;
  ErrorStats rpe_translation_m, rpe_rotation_deg;
  /// KITTI: translation error per distance travelled (%) and rotation error (deg/m),
  /// averaged over all segments; NaN when the path is shorter than every segment.
  double drift_translation_pct = NAN, drift_rotation_deg_per_m = NAN;
  long drift_segments = 0;
  /// False when the truth is a position track: the rotation errors are not defined (NaN), and
  /// the relative errors compare displacements (the aligned estimate's against the truth's)
  /// instead of relative poses.
  bool truth_has_attitude = true;
  /// The alignment applied to the estimate (world_from_estimate_world), and the time stamps
  /// of the estimate's matched poses.
  Eigen::Isometry3d alignment = Eigen::Isometry3d::Identity();
  /// The scale applied to the estimate's positions before `alignment` (1 but with
  /// kSimilarity2d): the aligned position is alignment * (scale x position).
  double scale = 1;
  std::vector<double> matched_t_s;
};

/// The truth interpolated at the estimate's time stamps (linear in position, slerp in
/// rotation; estimate poses outside the truth's span are dropped), then the errors.
/// @throws InputError when fewer than 2 estimate poses fall inside the truth's span.
TrajectoryErrors EvaluateTrajectory(const std::vector<StampedPose>& estimate,
                                    const std::vector<StampedPose>& truth,
                                    const TrajectoryEvalOptions& options);

/// The truth's pose at time t (t inside its span), interpolated.
Eigen::Isometry3d InterpolatePose(const std::vector<StampedPose>& truth, double t_s);

/// The mean position error of `estimate`, aligned by `errors.scale` and `errors.alignment`
/// (its own, from EvaluateTrajectory), at the instants `t_s` that lie inside both its span
/// and the truth's (estimate and truth interpolated there; horizontal with a 2-D alignment);
/// sets `count` to their number (NaN when none). Two estimates written at different rates are compared
/// at the same instants so (`evaluate trajectory`'s ape_mean_ratio).
double MeanPositionErrorAt(const std::vector<StampedPose>& estimate, const TrajectoryErrors& errors,
                           const std::vector<StampedPose>& truth, const TrajectoryEvalOptions& options,
                           const std::vector<double>& t_s, long* count);

/// The inputs and options of `evaluate trajectory` (docs/evaluate.md).
struct TrajectoryCommand {
  std::vector<std::string> estimates;  ///< NAME=TRAJECTORY (.csv: lunarnav; else TUM).
  std::filesystem::path truth, output_dir;
  std::string alignment = "rigid-2d";  ///< AlignmentFromString.
  std::string reference = "baseline";  ///< The estimate the others' mean errors are divided by.
  TrajectoryEvalOptions options;       ///< Its alignment is set from `alignment`.
};

/// `evaluate trajectory`: every estimate against the truth; writes the trajectory_errors
/// table and summary.json (`summary_head` plus inputs, options, table, and per estimate its
/// APE mean, RMSE and maximum and, when the reference is among them, ape_mean_ratio).
/// @return kExitOk. @throws std::invalid_argument for a malformed ESTIMATE or bad options;
///         InputError for unreadable inputs.
int RunTrajectoryCommand(const TrajectoryCommand& command, const nlohmann::json& summary_head);

}  // namespace lunarnav::evaluation
