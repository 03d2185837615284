#include "evaluation/trials_eval.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "evaluation/figure.h"
#include "io/atomic_file.h"
#include "io/json_io.h"
#include "util/check.h"
#include "util/errors.h"
#include "util/log.h"
#include "util/timer.h"

namespace lunarnav::evaluation {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

// Wraps degrees into (-180, 180].
double WrapDeg180(double deg) {
  double w = std::fmod(deg, 360.0);
  if (w <= -180) w += 360;
  if (w > 180) w -= 360;
  return w;
}

// A number at `key` of `object`, or nothing if absent or null; anything else is an error.
std::optional<double> OptionalNumber(const json& object, const char* key, const std::string& where) {
  const auto it = object.find(key);
  if (it == object.end() || it->is_null()) return std::nullopt;
  LN_CHECK_INPUT(it->is_number()) << where << ": \"" << key << "\" must be a number";
  const double value = it->get<double>();
  LN_CHECK_INPUT(std::isfinite(value)) << where << ": \"" << key << "\" must be finite";
  return value;
}

double RequiredNumber(const json& object, const char* key, const std::string& where) {
  const auto value = OptionalNumber(object, key, where);
  LN_CHECK_INPUT(value.has_value()) << where << ": missing \"" << key << "\"";
  return *value;
}

TrialPose ReadTrialPose(const json& object, const std::string& where) {
  LN_CHECK_INPUT(object.is_object()) << where << ": must be an object";
  TrialPose pose;
  pose.t_s = RequiredNumber(object, "t_s", where);
  pose.x_m = RequiredNumber(object, "x_m", where);
  pose.y_m = RequiredNumber(object, "y_m", where);
  pose.heading_deg = OptionalNumber(object, "heading_deg", where);
  return pose;
}

// The estimate's pose at t, or an error naming the trial when t is outside its span.
Eigen::Isometry3d EstimateAt(const std::vector<StampedPose>& estimate, double t_s, const Trial& trial) {
  LN_CHECK_INPUT(estimate.size() >= 2 && t_s >= estimate.front().t_s && t_s <= estimate.back().t_s)
      << "trial " << trial.id << ": time " << t_s << " s is outside the trajectory ("
      << (estimate.empty() ? 0.0 : estimate.front().t_s) << " to " << (estimate.empty() ? 0.0 : estimate.back().t_s)
      << " s)";
  return InterpolatePose(estimate, t_s);
}

Cell Num(double value, const char* reason) { return Cell::NumberOr(value, reason); }

}  // namespace

double HeadingDeg(const Eigen::Isometry3d& world_from_body) {
  const Eigen::Vector3d forward = world_from_body.linear().col(0);
  double h = std::atan2(forward.x(), forward.y()) * kRadToDeg;
  if (h < 0) h += 360;
  return h < 360 ? h : 0.0;  // a hair below 0 wraps to 360 itself
}

std::vector<Trial> ReadTrials(const fs::path& path) {
  const json doc = io::ReadJson(path);
  const std::string file = path.string();
  LN_CHECK_INPUT(doc.is_object()) << file << ": expected a JSON object";
  const auto format = doc.find("format");
  LN_CHECK_INPUT(format != doc.end() && format->is_string() && *format == "lunarnav.trials/1")
      << file << ": \"format\" must be \"lunarnav.trials/1\"";
  const auto list = doc.find("trials");
  LN_CHECK_INPUT(list != doc.end() && list->is_array()) << file << ": missing \"trials\" array";
  std::vector<Trial> trials;
  for (std::size_t i = 0; i < list->size(); ++i) {
    const json& item = (*list)[i];
    Trial trial;
    trial.id = static_cast<int>(i) + 1;
    std::string where = file + ": trial " + std::to_string(i + 1);
    LN_CHECK_INPUT(item.is_object()) << where << ": must be an object";
    if (const auto id = item.find("id"); id != item.end()) {
      LN_CHECK_INPUT(id->is_number_integer()) << where << ": \"id\" must be an integer";
      trial.id = id->get<int>();
      where = file + ": trial " + std::to_string(trial.id);
    }
    if (const auto d = item.find("description"); d != item.end() && d->is_string()) trial.description = *d;
    LN_CHECK_INPUT(item.contains("start") && item.contains("end")) << where << ": needs \"start\" and \"end\"";
    trial.start = ReadTrialPose(item["start"], where + " start");
    trial.end = ReadTrialPose(item["end"], where + " end");
    LN_CHECK_INPUT(trial.end.t_s > trial.start.t_s) << where << ": end time must be after start time";
    trials.push_back(std::move(trial));
  }
  LN_CHECK_INPUT(!trials.empty()) << file << ": no trials";
  return trials;
}

void TrialsEvalOptions::Validate() const {
  LN_CHECK_ARG(min_distance_m > 0) << "minimum trial distance: must be > 0 m";
}

std::vector<TrialResult> EvaluateTrials(const std::vector<StampedPose>& estimate, const std::vector<Trial>& trials,
                                        const TrialsEvalOptions& options) {
  options.Validate();
  std::vector<TrialResult> results;
  for (const Trial& trial : trials) {
    TrialResult r;
    r.trial = trial;
    const Eigen::Isometry3d a = EstimateAt(estimate, trial.start.t_s, trial);
    const Eigen::Isometry3d b = EstimateAt(estimate, trial.end.t_s, trial);
    const Eigen::Vector2d est_move = (b.translation() - a.translation()).head<2>();
    const Eigen::Vector2d true_move(trial.end.x_m - trial.start.x_m, trial.end.y_m - trial.start.y_m);
    r.true_distance_m = true_move.norm();
    r.estimated_distance_m = est_move.norm();
    if (r.true_distance_m >= options.min_distance_m) {
      r.distance_error_pct = 100.0 * (r.estimated_distance_m - r.true_distance_m) / r.true_distance_m;
    }
    r.position_error_m = (est_move - true_move).norm();
    r.estimated_turn_deg = WrapDeg180(HeadingDeg(b) - HeadingDeg(a));
    if (trial.start.heading_deg && trial.end.heading_deg) {
      r.true_turn_deg = WrapDeg180(*trial.end.heading_deg - *trial.start.heading_deg);
      r.heading_error_deg = WrapDeg180(r.estimated_turn_deg - r.true_turn_deg);
      r.orientation_error_pct = 100.0 * r.heading_error_deg / 360.0;
    }
    results.push_back(std::move(r));
  }
  return results;
}

TrialSetSummary SummarizeTrials(const std::string& name, const std::vector<TrialResult>& results) {
  TrialSetSummary s;
  s.name = name;
  s.trials = static_cast<long>(results.size());
  std::vector<double> distance, orientation, position, heading;
  for (const TrialResult& r : results) {
    position.push_back(r.position_error_m);
    if (std::isfinite(r.distance_error_pct)) distance.push_back(r.distance_error_pct);
    if (std::isfinite(r.orientation_error_pct)) {
      orientation.push_back(r.orientation_error_pct);
      heading.push_back(std::abs(r.heading_error_deg));
    }
  }
  s.distance_trials = static_cast<long>(distance.size());
  s.orientation_trials = static_cast<long>(orientation.size());
  s.distance_error_pct = ErrorStats::Of(std::move(distance));
  s.orientation_error_pct = ErrorStats::Of(std::move(orientation));
  s.position_error_m = ErrorStats::Of(std::move(position));
  s.abs_heading_error_deg = ErrorStats::Of(std::move(heading));
  return s;
}

Table TrialsTable(const std::vector<TrialSetSummary>& sets) {
  Table table;
  table.title = "Statistics of position and orientation errors (Figure 7)";
  table.columns = {{"trial", "", "Trial", 0},
                   {"mean_distance", "pct", "Mean Distance (%)", 1},
                   {"mean_orient", "pct", "Mean Orient. (%)", 1},
                   {"stdev_distance", "pct", "StDev Distance (%)", 1},
                   {"stdev_orient", "pct", "StDev Orient. (%)", 1},
                   {"trials", "", "trials", 0},
                   {"distance_trials", "", "with distance", 0},
                   {"orientation_trials", "", "with heading", 0},
                   {"mean_position_error", "m", "mean position error (m)", 3},
                   {"mean_abs_heading_error", "deg", "mean abs. heading error (deg)", 2}};
  for (const TrialSetSummary& s : sets) {
    table.AddRow({Cell::Text(s.name), Num(s.distance_error_pct.mean, "no trial long enough"),
                  Num(s.orientation_error_pct.mean, "no true headings"),
                  Num(s.distance_error_pct.std, "no trial long enough"),
                  Num(s.orientation_error_pct.std, "no true headings"), Cell::Number(s.trials),
                  Cell::Number(s.distance_trials), Cell::Number(s.orientation_trials),
                  Num(s.position_error_m.mean, "no trials"), Num(s.abs_heading_error_deg.mean, "no true headings")});
  }
  table.notes = {
      "Errors are signed, computed minus true: distance as a percentage of the true start-to-end distance "
      "(horizontal), orientation (the change of heading over the trial) as a percentage of a full turn.",
      "Standard deviations are population ones (over n trials). Trials shorter than the minimum distance count for the "
      "orientation and position errors only."};
  return table;
}

Table TrialDetailsTable(const std::vector<std::pair<std::string, std::vector<TrialResult>>>& sets) {
  Table table;
  table.title = "Trials";
  table.columns = {{"set", "", "set", 0},
                   {"trial", "", "trial", 0},
                   {"description", "", "description", 0},
                   {"start", "s", "start (s)", 2},
                   {"end", "s", "end (s)", 2},
                   {"true_distance", "m", "true distance (m)", 3},
                   {"computed_distance", "m", "computed distance (m)", 3},
                   {"distance_error", "pct", "distance error (%)", 2},
                   {"position_error", "m", "position error (m)", 3},
                   {"true_turn", "deg", "true turn (deg)", 2},
                   {"computed_turn", "deg", "computed turn (deg)", 2},
                   {"heading_error", "deg", "heading error (deg)", 2},
                   {"orientation_error", "pct", "orientation error (%)", 2}};
  for (const auto& [name, results] : sets) {
    for (const TrialResult& r : results) {
      table.AddRow({Cell::Text(name), Cell::Number(r.trial.id), Cell::Text(r.trial.description),
                    Cell::Number(r.trial.start.t_s), Cell::Number(r.trial.end.t_s), Cell::Number(r.true_distance_m),
                    Cell::Number(r.estimated_distance_m), Num(r.distance_error_pct, "shorter than the minimum"),
                    Cell::Number(r.position_error_m), Num(r.true_turn_deg, "no true heading"),
                    Cell::Number(r.estimated_turn_deg), Num(r.heading_error_deg, "no true heading"),
                    Num(r.orientation_error_pct, "no true heading")});
    }
  }
  return table;
}

Table TrajectoryErrorsTable(const std::vector<std::pair<std::string, TrajectoryErrors>>& sets,
                            const TrajectoryEvalOptions& options) {
  Table table;
  table.title = "Trajectory error against the ground-truth trajectory";
  table.columns = {{"set", "", "set", 0},
                   {"poses", "", "poses", 0},
                   {"path_length", "m", "path (m)", 2},
                   {"ape_rmse", "m", "APE RMSE (m)", 3},
                   {"ape_max", "m", "APE max (m)", 3},
                   {"ape_rot_rmse", "deg", "APE rot. RMSE (deg)", 2},
                   {"rpe_rmse", "m", "RPE RMSE (m)", 4},
                   {"rpe_rot_rmse", "deg", "RPE rot. RMSE (deg)", 3},
                   {"drift", "pct", "drift (%)", 2},
                   {"drift_rot", "deg_per_m", "drift rot. (deg/m)", 4},
                   {"drift_segments", "", "segments", 0}};
  bool positions_only = false;
  for (const auto& [name, e] : sets) {
    const char* no_rotation = e.truth_has_attitude ? nullptr : "truth without attitude";
    positions_only = positions_only || !e.truth_has_attitude;
    table.AddRow({Cell::Text(name), Cell::Number(e.poses_matched), Cell::Number(e.path_length_m),
                  Num(e.ape_translation_m.rmse, "no poses"), Num(e.ape_translation_m.max, "no poses"),
                  Num(e.ape_rotation_deg.rmse, no_rotation ? no_rotation : "no poses"),
                  Num(e.rpe_translation_m.rmse, "path too short"),
                  Num(e.rpe_rotation_deg.rmse, no_rotation ? no_rotation : "path too short"),
                  Num(e.drift_translation_pct, "path too short"),
                  Num(e.drift_rotation_deg_per_m, no_rotation ? no_rotation : "path too short"),
                  Cell::Number(e.drift_segments)});
  }
  std::ostringstream rpe, segments;
  rpe << options.rpe_delta_m;
  for (std::size_t i = 0; i < options.drift_segments_m.size(); ++i) {
    segments << (i ? ", " : "") << options.drift_segments_m[i];
  }
  table.notes = {"Alignment: " + ToString(options.alignment) + ". APE and RPE as evo defines them (RPE over pose "
                     "pairs " + rpe.str() + " m apart along the true path).",
                 "Drift as the KITTI odometry benchmark defines it, averaged over segments of " + segments.str() +
                     " m starting every " + std::to_string(options.drift_step) + " poses."};
  if (positions_only) {
    table.notes.push_back("The truth is a position track (no attitude): RPE and drift compare the aligned estimate's "
                          "displacements with the truth's; rotation errors are not defined.");
  }
  return table;
}

namespace {

// One trial set of `evaluate trials`: NAME=TRAJECTORY,TRIALS[,TRUTH].
struct TrialSetSpec {
  std::string name;
  std::filesystem::path trajectory, trials, truth;
};

TrialSetSpec ParseTrialSet(const std::string& text) {
  const auto eq = text.find('=');
  std::vector<std::string> paths;
  if (eq != std::string::npos) {
    const std::string rest = text.substr(eq + 1);
    for (std::size_t from = 0;;) {
      const auto comma = rest.find(',', from);
      paths.push_back(rest.substr(from, comma - from));
      if (comma == std::string::npos) break;
      from = comma + 1;
    }
  }
  const bool ok = eq != std::string::npos && eq > 0 && (paths.size() == 2 || paths.size() == 3) &&
                  std::none_of(paths.begin(), paths.end(), [](const std::string& p) { return p.empty(); });
  if (!ok) {
    throw std::invalid_argument("--set: expected NAME=TRAJECTORY,TRIALS[,TRUTH], got '" + text + "'");
  }
  TrialSetSpec spec{text.substr(0, eq), paths[0], paths[1], {}};
  if (paths.size() == 3) spec.truth = paths[2];
  return spec;
}

// The figure of `evaluate trials`: each trial's distance error against its length, per set.
FigureResult TrialsFigure(const std::filesystem::path& dir, const std::vector<TrialSetSpec>& specs) {
  std::ostringstream gp;
  gp << "set title \"Distance error of each commanded motion (Figure 7's trials)\"\n"
     << "set xlabel \"true distance (m)\"\nset ylabel \"distance error (%)\"\nset grid\n"
     << "set key outside right top\nset offsets graph 0.05, 0.05, 0.1, 0.1\nset xzeroaxis\n"
     << "plot ";
  for (std::size_t i = 0; i < specs.size(); ++i) {
    // trial_details.csv: column 1 the set, 6 the true distance, 8 the distance error.
    gp << (i ? ", \\\n     " : "") << "\"trial_details.csv\" using ((strcol(1) eq " << GnuplotString(specs[i].name)
       << ") ? $6 : 1/0):8 with points pt 7 ps 1.2 title " << GnuplotString(specs[i].name);
  }
  gp << "\n";
  return WriteFigure(dir, "trials", gp.str());
}

}  // namespace

int RunTrialsCommand(const TrialsCommand& command, const nlohmann::json& summary_head) {
  util::Timer timer;
  std::vector<TrialSetSpec> specs;
  for (const std::string& text : command.sets) {
    specs.push_back(ParseTrialSet(text));
    const std::string& name = specs.back().name;
    LN_CHECK_ARG(std::count_if(specs.begin(), specs.end(), [&](const TrialSetSpec& s) { return s.name == name; }) == 1)
        << "--set: the name '" << name << "' is given twice";
  }
  TrajectoryEvalOptions trajectory_options = command.trajectory_options;
  trajectory_options.alignment = AlignmentFromString(command.alignment);
  trajectory_options.Validate();
  command.options.Validate();
  io::CreateOutputDirectory(command.output_dir);

  std::vector<TrialSetSummary> summaries;
  std::vector<std::pair<std::string, std::vector<TrialResult>>> details;
  std::vector<std::pair<std::string, TrajectoryErrors>> trajectory_errors;
  nlohmann::json inputs = nlohmann::json::array();
  for (const TrialSetSpec& spec : specs) {
    const auto estimate = ReadPoses(spec.trajectory);
    auto results = EvaluateTrials(estimate, ReadTrials(spec.trials), command.options);
    summaries.push_back(SummarizeTrials(spec.name, results));
    details.emplace_back(spec.name, std::move(results));
    nlohmann::json input = {
        {"name", spec.name}, {"trajectory", spec.trajectory.string()}, {"trials", spec.trials.string()}};
    if (!spec.truth.empty()) {
      const std::vector<StampedPose> truth = ReadPoses(spec.truth);
      try {
        trajectory_errors.emplace_back(spec.name, EvaluateTrajectory(estimate, truth, trajectory_options));
      } catch (const InputError& e) {  // named: which trajectory against which truth
        throw InputError(spec.trajectory.string() + " against " + spec.truth.string() + ": " + e.what());
      }
      input["truth"] = spec.truth.string();
    }
    inputs.push_back(input);
  }
  const Table table = TrialsTable(summaries);
  WriteTable(command.output_dir, "trials", table);
  WriteTable(command.output_dir, "trial_details", TrialDetailsTable(details));
  nlohmann::json summary = summary_head;
  summary["inputs"] = inputs;
  summary["options"] = {{"min_distance_m", command.options.min_distance_m},
                        {"alignment", command.alignment},
                        {"rpe_delta_m", trajectory_options.rpe_delta_m},
                        {"drift_segments_m", trajectory_options.drift_segments_m},
                        {"drift_step", trajectory_options.drift_step}};
  long trial_count = 0;
  for (const auto& s : summaries) trial_count += s.trials;
  summary["counts"] = {{"sets", specs.size()}, {"trials", trial_count}};
  summary["table"] = table.ToJson();
  if (!trajectory_errors.empty()) {
    const Table errors_table = TrajectoryErrorsTable(trajectory_errors, trajectory_options);
    WriteTable(command.output_dir, "trajectory_errors", errors_table);
    summary["trajectory_errors"] = errors_table.ToJson();
  }
  summary["figures"] =
      nlohmann::json::array({FigureSummary(TrialsFigure(command.output_dir, specs), "trial_details.csv")});
  summary["timings_s"] = {{"total", timer.ElapsedSeconds()}};
  io::WriteJsonAtomic(command.output_dir / "summary.json", summary);
  LN_LOG(Info) << "evaluate trials: " << trial_count << " trials in " << specs.size() << " sets; "
               << (command.output_dir / "trials.md").string();
  return kExitOk;
}

}  // namespace lunarnav::evaluation
