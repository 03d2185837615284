// evaluate: results against ground truth -> the paper's tables and figures.
// docs/evaluate.md describes every subcommand, option and output.
#include <algorithm>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "calib/stereo_rig_io.h"
#include "calib/triangulation.h"
#include "evaluation/boxes_eval.h"
#include "evaluation/correlation_study.h"
#include "evaluation/disparity_eval.h"
#include "evaluation/figure.h"
#include "evaluation/trials_eval.h"
#include "io/atomic_file.h"
#include "io/float_array_io.h"
#include "io/image_io.h"
#include "io/json_io.h"
#include "util/check.h"
#include "util/cli.h"
#include "util/errors.h"
#include "util/log.h"
#include "util/run_main.h"
#include "util/timer.h"
#include "util/version.h"

namespace fs = std::filesystem;
using namespace lunarnav;
using nlohmann::json;

namespace {

// The summary.json every subcommand writes next to its tables.
json SummaryHead(const std::string& subcommand, int argc, char** argv) {
  return {{"tool", "evaluate"},
          {"subcommand", subcommand},
          {"version", kVersion},
          {"git_revision", kGitRevision},
          {"invocation", util::CommandLineJson(argc, argv)}};
}

struct DisparityArgs {
  fs::path results, truth, masks, output_dir;
  std::vector<double> thresholds;
  evaluation::DisparityEvalOptions options;
};

int RunDisparity(const DisparityArgs& args, int argc, char** argv) {
  util::Timer timer;
  evaluation::DisparityEvalOptions options = args.options;
  if (!args.thresholds.empty()) options.bad_thresholds_px = args.thresholds;
  options.Validate();
  io::CreateOutputDirectory(args.output_dir);
  const auto items = evaluation::EvaluateDisparityDirectories(args.results, args.truth, args.masks, options);
  int failed = 0;
  json failed_json = json::array();
  for (const auto& item : items) {
    if (item.problem.empty()) continue;
    ++failed;
    LN_LOG(Error) << "pair " << item.stem << ": " << item.problem;
    failed_json.push_back({{"stem", item.stem}, {"error", item.problem}});
  }
  const evaluation::Table table = evaluation::DisparityTable(items, options);
  evaluation::WriteTable(args.output_dir, "disparity", table);
  json summary = SummaryHead("disparity", argc, argv);
  summary["inputs"] = {{"results", args.results.string()},
                       {"truth", args.truth.string()},
                       {"masks", args.masks.string()}};
  summary["options"] = {{"bad_thresholds_px", options.bad_thresholds_px},
                        {"png_truth_scale", options.png_truth_scale}};
  summary["counts"] = {{"stems", items.size()}, {"scored", items.size() - failed}, {"failed", failed}};
  summary["failed"] = failed_json;
  summary["table"] = table.ToJson();
  summary["timings_s"] = {{"total", timer.ElapsedSeconds()}};
  io::WriteJsonAtomic(args.output_dir / "summary.json", summary);
  LN_LOG(Info) << "evaluate disparity: " << items.size() - failed << " of " << items.size()
               << " pairs scored; " << (args.output_dir / "disparity.md").string();
  return failed > 0 ? kExitBatchPartial : kExitOk;
}

// One trial set of `evaluate trials`: NAME=TRAJECTORY,TRIALS[,TRUTH].
struct TrialSetSpec {
  std::string name;
  fs::path trajectory, trials, truth;
};

TrialSetSpec ParseTrialSet(const std::string& text) {
  const auto eq = text.find('=');
  std::vector<std::string> paths;
  if (eq != std::string::npos) {
    std::string rest = text.substr(eq + 1);
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

struct TrialsArgs {
  std::vector<std::string> sets;
  fs::path output_dir;
  std::string alignment = "start";
  evaluation::TrialsEvalOptions options;
  evaluation::TrajectoryEvalOptions trajectory_options;
};

// The figure of `evaluate trials`: each trial's distance error against its length, per set.
evaluation::FigureResult TrialsFigure(const fs::path& dir, const std::vector<TrialSetSpec>& specs) {
  std::ostringstream gp;
  gp << "set title \"Distance error of each commanded motion (Figure 7's trials)\"\n"
     << "set xlabel \"true distance (m)\"\nset ylabel \"distance error (%)\"\nset grid\n"
     << "set key outside right top\nset offsets graph 0.05, 0.05, 0.1, 0.1\nset xzeroaxis\n"
     << "plot ";
  for (std::size_t i = 0; i < specs.size(); ++i) {
    // trial_details.csv: column 1 the set, 6 the true distance, 8 the distance error.
    gp << (i ? ", \\\n     " : "") << "\"trial_details.csv\" using ((strcol(1) eq "
       << evaluation::GnuplotString(specs[i].name) << ") ? $6 : 1/0):8 with points pt 7 ps 1.2 title "
       << evaluation::GnuplotString(specs[i].name);
  }
  gp << "\n";
  return evaluation::WriteFigure(dir, "trials", gp.str());
}

int RunTrials(const TrialsArgs& args, int argc, char** argv) {
  util::Timer timer;
  std::vector<TrialSetSpec> specs;
  for (const std::string& text : args.sets) specs.push_back(ParseTrialSet(text));
  evaluation::TrajectoryEvalOptions trajectory_options = args.trajectory_options;
  trajectory_options.alignment = evaluation::AlignmentFromString(args.alignment);
  trajectory_options.Validate();
  args.options.Validate();
  io::CreateOutputDirectory(args.output_dir);

  std::vector<evaluation::TrialSetSummary> summaries;
  std::vector<std::pair<std::string, std::vector<evaluation::TrialResult>>> details;
  std::vector<std::pair<std::string, evaluation::TrajectoryErrors>> trajectory_errors;
  json inputs = json::array();
  for (const TrialSetSpec& spec : specs) {
    const auto estimate = evaluation::ReadPoses(spec.trajectory);
    const auto trials = evaluation::ReadTrials(spec.trials);
    auto results = evaluation::EvaluateTrials(estimate, trials, args.options);
    summaries.push_back(evaluation::SummarizeTrials(spec.name, results));
    details.emplace_back(spec.name, std::move(results));
    json input = {{"name", spec.name}, {"trajectory", spec.trajectory.string()}, {"trials", spec.trials.string()}};
    if (!spec.truth.empty()) {
      const auto truth = evaluation::ReadPoses(spec.truth);
      trajectory_errors.emplace_back(spec.name, evaluation::EvaluateTrajectory(estimate, truth, trajectory_options));
      input["truth"] = spec.truth.string();
    }
    inputs.push_back(input);
  }
  const evaluation::Table table = evaluation::TrialsTable(summaries);
  const evaluation::Table details_table = evaluation::TrialDetailsTable(details);
  evaluation::WriteTable(args.output_dir, "trials", table);
  evaluation::WriteTable(args.output_dir, "trial_details", details_table);
  json summary = SummaryHead("trials", argc, argv);
  summary["inputs"] = inputs;
  summary["options"] = {{"min_distance_m", args.options.min_distance_m},
                        {"alignment", args.alignment},
                        {"rpe_delta_m", trajectory_options.rpe_delta_m},
                        {"drift_segments_m", trajectory_options.drift_segments_m},
                        {"drift_step", trajectory_options.drift_step}};
  long trial_count = 0;
  for (const auto& s : summaries) trial_count += s.trials;
  summary["counts"] = {{"sets", specs.size()}, {"trials", trial_count}};
  summary["table"] = table.ToJson();
  if (!trajectory_errors.empty()) {
    const evaluation::Table errors_table = evaluation::TrajectoryErrorsTable(trajectory_errors, trajectory_options);
    evaluation::WriteTable(args.output_dir, "trajectory_errors", errors_table);
    summary["trajectory_errors"] = errors_table.ToJson();
  }
  const evaluation::FigureResult figure = TrialsFigure(args.output_dir, specs);
  if (!figure.rendered) {
    LN_LOG(Warning) << figure.png.string() << ": not drawn: " << figure.problem;
  }
  summary["figures"] = {{{"png", figure.png.filename().string()},
                         {"data", "trial_details.csv"},
                         {"rendered", figure.rendered},
                         {"problem", figure.problem}}};
  summary["timings_s"] = {{"total", timer.ElapsedSeconds()}};
  io::WriteJsonAtomic(args.output_dir / "summary.json", summary);
  LN_LOG(Info) << "evaluate trials: " << trial_count << " trials in " << specs.size() << " sets; "
               << (args.output_dir / "trials.md").string();
  return kExitOk;
}

struct CorrelationArgs {
  fs::path left, right, output_dir;
  std::vector<int> pixel;
  std::string reference = "right";
  evaluation::CorrelationStudyOptions options;
};

int RunCorrelation(CorrelationArgs args, int argc, char** argv) {
  util::Timer timer;
  args.options.x = args.pixel[0];
  args.options.y = args.pixel[1];
  args.options.matcher.reference = stereo::ReferenceImageFromString(args.reference);
  args.options.Validate();
  const cv::Mat left = io::ReadGreyImage(args.left);
  const cv::Mat right = io::ReadGreyImage(args.right);
  LN_CHECK_INPUT(left.size() == right.size() && left.type() == right.type())
      << args.left.string() << ", " << args.right.string() << ": the images differ in size or bit depth";
  LN_CHECK_INPUT(args.options.x >= 0 && args.options.x < left.cols && args.options.y >= 0 &&
                 args.options.y < left.rows)
      << "--pixel " << args.options.x << "," << args.options.y << ": outside the " << left.cols << " x "
      << left.rows << " image";
  const evaluation::CorrelationStudy study = evaluation::RunCorrelationStudy(left, right, args.options);
  io::CreateOutputDirectory(args.output_dir);
  io::WriteFileAtomic(args.output_dir / "correlation_curves.csv", evaluation::CorrelationCurvesCsv(study));
  const evaluation::Table table = evaluation::CorrelationPeaksTable(study);
  evaluation::WriteTable(args.output_dir, "correlation", table);
  const evaluation::FigureResult figure = evaluation::WriteFigure(
      args.output_dir, "correlation", evaluation::CorrelationFigureCommands(study, "correlation_curves.csv"), 1200,
      550);
  if (!figure.rendered) {
    LN_LOG(Warning) << figure.png.string() << ": not drawn: " << figure.problem;
  }
  json summary = SummaryHead("correlation", argc, argv);
  summary["inputs"] = {{"left", args.left.string()}, {"right", args.right.string()}};
  summary["options"] = {{"pixel", {args.options.x, args.options.y}},
                        {"steps_x", args.options.steps_x},
                        {"steps_y", args.options.steps_y},
                        {"zoom_px", args.options.zoom_px},
                        {"matcher", args.options.matcher.ToJson()}};
  summary["counts"] = {{"curves", study.entries.size()},
                       {"disparities", args.options.matcher.max_disparity_px - args.options.matcher.min_disparity_px + 1}};
  summary["table"] = table.ToJson();
  summary["figures"] = {{{"png", figure.png.filename().string()},
                         {"data", "correlation_curves.csv"},
                         {"rendered", figure.rendered},
                         {"problem", figure.problem}}};
  summary["timings_s"] = {{"total", timer.ElapsedSeconds()}};
  io::WriteJsonAtomic(args.output_dir / "summary.json", summary);
  LN_LOG(Info) << "evaluate correlation: " << study.entries.size() << " curves; "
               << (args.output_dir / "correlation.md").string();
  return kExitOk;
}

struct BoxesArgs {
  std::vector<fs::path> runs;
  fs::path boxes, rig, output_dir;
  double sigma_d_px = 1.0;
  evaluation::BoxesEvalOptions options;
};

// One stereo-batch run's XYZ maps scored against the box list.
evaluation::BoxRunResult ScoreBoxRun(const fs::path& run, const evaluation::BoxList& boxes,
                                     const evaluation::BoxesEvalOptions& options, json* run_json, int* failed) {
  const json summary = io::ReadJson(run / "summary.json");
  LN_CHECK_INPUT(summary.value("tool", "") == "stereo-batch")
      << (run / "summary.json").string() << ": not a stereo-batch summary";
  evaluation::BoxRunResult result;
  const json& step = summary["options"]["step_px"];
  LN_CHECK_INPUT(step.is_array() && step.size() == 2) << (run / "summary.json").string() << ": no options.step_px";
  result.step_x = step[0].get<int>();
  result.step_y = step[1].get<int>();
  result.name = "dx" + std::to_string(result.step_x) + "_dy" + std::to_string(result.step_y);
  const fs::path xyz_dir = run / "xyz";
  LN_CHECK_INPUT(fs::is_directory(xyz_dir)) << xyz_dir.string() << ": no XYZ maps (run stereo-batch with --rig)";
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(xyz_dir)) {
    if (entry.path().extension() == ".exr") files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  LN_CHECK_INPUT(!files.empty()) << xyz_dir.string() << ": no .exr files";
  long maps = 0;
  for (const fs::path& file : files) {
    const std::string stem = file.stem().string();
    try {
      const io::ExrImage xyz = io::ReadExr(file);
      LN_CHECK_INPUT(xyz.pixels.type() == CV_32FC3) << file.string() << ": expected 3 channels (X, Y, Z)";
      const auto& faces = boxes.For(stem);
      const auto errors = evaluation::EvaluateBoxFaces(xyz.pixels, faces, options);
      for (std::size_t k = 0; k < faces.size(); ++k) {
        result.by_distance_cm[std::lround(faces[k].front_y_m * 100)].Add(errors[k]);
      }
      ++maps;
    } catch (const InputError& e) {
      ++*failed;
      LN_LOG(Error) << "pair " << stem << ": " << e.what();
    }
  }
  *run_json = {{"dir", run.string()}, {"name", result.name}, {"maps", maps}, {"step_px", {result.step_x, result.step_y}}};
  return result;
}

// Figure 4: E_Y against Y per subsampling, with the predicted 1-pixel curve.
evaluation::FigureResult BoxesFigure(const fs::path& dir, const std::vector<evaluation::BoxRunResult>& runs,
                                     bool predicted) {
  std::ostringstream gp;
  gp << "set title \"Error in measured distance against distance, per subsampling (Figure 4)\"\n"
     << "set xlabel \"Y (m)\"\nset ylabel \"E_Y (m)\"\nset grid\nset key top left\n"
     << "set offsets graph 0.03, 0.03, 0.05, 0\nset yrange [0:*]\nplot ";
  int column = 2;
  bool first = true;
  if (predicted) {
    gp << "\"boxes.csv\" using 1:2 with lines lw 2 dt 2 lc rgb \"black\" title \"predicted, 1 px\"";
    first = false;
    ++column;
  }
  for (const auto& run : runs) {
    gp << (first ? "" : ", \\\n     ") << "\"boxes.csv\" using 1:" << column << " with linespoints pt 7 title \"("
       << run.step_x << ", " << run.step_y << ")\"";
    first = false;
    column += 3;  // E_Y, bias, points
  }
  gp << "\n";
  return evaluation::WriteFigure(dir, "boxes", gp.str());
}

int RunBoxes(const BoxesArgs& args, int argc, char** argv) {
  util::Timer timer;
  args.options.Validate();
  LN_CHECK_ARG(args.sigma_d_px > 0) << "--sigma-d: must be > 0";
  const evaluation::BoxList boxes = evaluation::ReadBoxList(args.boxes);
  io::CreateOutputDirectory(args.output_dir);
  std::vector<evaluation::BoxRunResult> runs;
  json runs_json = json::array();
  int failed = 0;
  for (const fs::path& run : args.runs) {
    json run_json;
    runs.push_back(ScoreBoxRun(run, boxes, args.options, &run_json, &failed));
    runs_json.push_back(run_json);
  }
  // The predicted E_Y of a one-pixel disparity error at the centre of each face.
  std::map<long, double> predicted;
  if (!args.rig.empty()) {
    const calib::StereoRig rig = calib::ReadStereoRig(args.rig);
    LN_CHECK_ARG(rig.rectified.has_value()) << args.rig.string() << ": not a rectified rig";
    std::vector<evaluation::BoxFace> faces = boxes.boxes;
    for (const auto& [stem, list] : boxes.frames) faces.insert(faces.end(), list.begin(), list.end());
    for (const auto& f : faces) {
      const Eigen::Vector3d centre(0.5 * (f.x_min_m + f.x_max_m), f.front_y_m, 0.5 * (f.z_min_m + f.z_max_m));
      predicted[std::lround(f.front_y_m * 100)] =
          calib::PredictPointSigma(rig, centre, calib::ReferenceImage::kRight, args.sigma_d_px).y();
    }
  }
  const evaluation::Table table = evaluation::BoxesTable(runs, predicted);
  evaluation::WriteTable(args.output_dir, "boxes", table);
  const evaluation::FigureResult figure = BoxesFigure(args.output_dir, runs, !predicted.empty());
  if (!figure.rendered) {
    LN_LOG(Warning) << figure.png.string() << ": not drawn: " << figure.problem;
  }
  json summary = SummaryHead("boxes", argc, argv);
  summary["inputs"] = {{"runs", runs_json}, {"boxes", args.boxes.string()}, {"rig", args.rig.string()}};
  summary["options"] = {{"edge_margin_m", args.options.edge_margin_m},
                        {"y_gate_fraction", args.options.y_gate_fraction},
                        {"sigma_d_px", args.sigma_d_px}};
  summary["counts"] = {{"runs", runs.size()}, {"distances", table.rows.size()}, {"failed_maps", failed}};
  summary["table"] = table.ToJson();
  summary["figures"] = {{{"png", figure.png.filename().string()},
                         {"data", "boxes.csv"},
                         {"rendered", figure.rendered},
                         {"problem", figure.problem}}};
  summary["timings_s"] = {{"total", timer.ElapsedSeconds()}};
  io::WriteJsonAtomic(args.output_dir / "summary.json", summary);
  LN_LOG(Info) << "evaluate boxes: " << runs.size() << " runs, " << table.rows.size() << " distances; "
               << (args.output_dir / "boxes.md").string();
  return failed > 0 ? kExitBatchPartial : kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "Scores lunarnav results against ground truth into the tables and figures of Krotkov &\n"
      "Hebert (1995). Each subcommand writes its table as CSV, JSON and Markdown, its figures\n"
      "as PNG with the data behind them as CSV, and summary.json, into OUT_DIR.\n"
      "Exit codes: 0 ok, 1 internal error, 2 usage, 3 bad input, 4 some items could not be scored."};
  app.require_subcommand(1);
  app.fallthrough();  // --quiet, --version also after the subcommand
  bool quiet = false;
  util::AddCommonFlags(&app, &quiet);

  DisparityArgs disparity;
  CLI::App* disparity_cmd = app.add_subcommand(
      "disparity", "disparity maps vs ground-truth disparity: density, bad-N %, mean and RMS error");
  disparity_cmd->add_option("RESULTS", disparity.results,
                            "stereo-batch output directory (disparity/<stem>.pfm) or a directory of .pfm files")
      ->required();
  disparity_cmd->add_option("--truth", disparity.truth,
                            "truth directory: <stem>.pfm or 16-bit <stem>.png (also under disparity/)")
      ->required();
  disparity_cmd->add_option("--masks", disparity.masks, "directory of <stem>.png masks (nonzero = evaluate)");
  disparity_cmd->add_option("--bad", disparity.thresholds, "bad-pixel thresholds, px (default 0.5 1 2 4)")
      ->delimiter(',');
  disparity_cmd->add_option("--png-scale", disparity.options.png_truth_scale,
                            "16-bit PNG truth holds disparity x this (KITTI: 256)")
      ->capture_default_str();
  disparity_cmd->add_option("-o,--output", disparity.output_dir, "output directory (created)")->required();

  TrialsArgs trials;
  CLI::App* trials_cmd = app.add_subcommand(
      "trials", "commanded-motion trials: distance and orientation errors (Figure 7), APE/RPE/drift");
  trials_cmd
      ->add_option("--set", trials.sets,
                   "a trial set NAME=TRAJECTORY,TRIALS[,TRUTH]: posfilter trajectory (.csv or TUM), trials "
                   "file (lunarnav.trials/1), optional ground-truth trajectory; repeatable")
      ->required();
  trials_cmd->add_option("--min-distance", trials.options.min_distance_m,
                         "trials shorter than this (m) get no distance error in percent")
      ->capture_default_str();
  trials_cmd->add_option("--align", trials.alignment, "APE alignment: none, start, origin or rigid")
      ->capture_default_str();
  trials_cmd->add_option("--rpe-delta", trials.trajectory_options.rpe_delta_m,
                         "RPE pose pairs this far apart along the true path (m)")
      ->capture_default_str();
  trials_cmd->add_option("--drift-segments", trials.trajectory_options.drift_segments_m,
                         "KITTI drift segment lengths (m, default 5,10,20,40)")
      ->delimiter(',');
  trials_cmd->add_option("-o,--output", trials.output_dir, "output directory (created)")->required();

  CorrelationArgs correlation;
  CLI::App* correlation_cmd = app.add_subcommand(
      "correlation", "correlation curve C(d) at one pixel for several subsamplings (Figure 5)");
  correlation_cmd->add_option("LEFT", correlation.left, "rectified left image")->required();
  correlation_cmd->add_option("RIGHT", correlation.right, "rectified right image")->required();
  correlation_cmd->add_option("--pixel", correlation.pixel, "X,Y: the pixel, in the reference image")
      ->required()
      ->delimiter(',')
      ->expected(2);
  correlation_cmd->add_option("--steps-x", correlation.options.steps_x, "column steps dx (default 1,3,5)")
      ->delimiter(',');
  correlation_cmd->add_option("--steps-y", correlation.options.steps_y, "row steps dy (default 1,2,4)")
      ->delimiter(',');
  correlation_cmd->add_option("--wx", correlation.options.matcher.half_window_x_px, "window half-width w_x (px)")
      ->capture_default_str();
  correlation_cmd->add_option("--wy", correlation.options.matcher.half_window_y_px, "window half-height w_y (px)")
      ->capture_default_str();
  correlation_cmd->add_option("--min-disparity", correlation.options.matcher.min_disparity_px, "d_min (px)")
      ->capture_default_str();
  correlation_cmd->add_option("--max-disparity", correlation.options.matcher.max_disparity_px, "d_max (px)")
      ->capture_default_str();
  correlation_cmd->add_option("--reference", correlation.reference, "reference image: right or left")
      ->capture_default_str();
  correlation_cmd->add_option("--zoom", correlation.options.zoom_px,
                              "half-width of the magnified plot around the peak (px)")
      ->capture_default_str();
  correlation_cmd->add_option("-o,--output", correlation.output_dir, "output directory (created)")->required();

  BoxesArgs boxes;
  CLI::App* boxes_cmd = app.add_subcommand(
      "boxes", "box experiment: E_Y of box faces against distance per subsampling (Figure 4)");
  boxes_cmd->add_option("RUN_DIR", boxes.runs, "stereo-batch output directories run with --rig (one per (dx, dy))")
      ->required();
  boxes_cmd->add_option("--boxes", boxes.boxes, "box list (lunarnav.boxes/1), e.g. simulate's truth/boxes.json")
      ->required();
  boxes_cmd->add_option("--rig", boxes.rig, "rectified rig file: adds the predicted error of --sigma-d px");
  boxes_cmd->add_option("--sigma-d", boxes.sigma_d_px, "disparity error of the predicted curve (px)")
      ->capture_default_str();
  boxes_cmd->add_option("--edge-margin", boxes.options.edge_margin_m, "face points this close to an edge are left out (m)")
      ->capture_default_str();
  boxes_cmd->add_option("--y-gate", boxes.options.y_gate_fraction,
                        "a point belongs to a face when |Y - true Y| <= this x true Y")
      ->capture_default_str();
  boxes_cmd->add_option("-o,--output", boxes.output_dir, "output directory (created)")->required();

  if (const auto exit_code = util::ParseCommandLine(&app, argc, argv, quiet)) return *exit_code;
  return util::RunMain([&]() -> int {
    if (disparity_cmd->parsed()) return RunDisparity(disparity, argc, argv);
    if (trials_cmd->parsed()) return RunTrials(trials, argc, argv);
    if (correlation_cmd->parsed()) return RunCorrelation(correlation, argc, argv);
    if (boxes_cmd->parsed()) return RunBoxes(boxes, argc, argv);
    return kExitUsage;
  });
}
