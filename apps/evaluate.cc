// evaluate: results against ground truth -> the paper's tables and figures.
// docs/evaluate.md describes every subcommand, option and output. Each subcommand's work is a
// lib/evaluation call (Run<Name>Command); this file only declares the command lines.
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include "evaluation/boxes_eval.h"
#include "evaluation/correlation_study.h"
#include "evaluation/disparity_eval.h"
#include "evaluation/lidar_map_eval.h"
#include "util/check.h"
#include "evaluation/map_eval.h"
#include "stereo/window_requests.h"
#include "evaluation/request_study.h"
#include "evaluation/timing_study.h"
#include "evaluation/trajectory_eval.h"
#include "evaluation/trials_eval.h"
#include "io/image_io.h"
#include "util/cli.h"
#include "util/errors.h"
#include "util/log.h"
#include "util/parse.h"
#include "util/run_main.h"
#include "util/summary.h"

using namespace lunarnav;
using nlohmann::json;

namespace {

// One subcommand: its command line and the library call that runs it with the summary.json head.
struct Subcommand {
  CLI::App* cli = nullptr;
  std::function<int(const json& summary_head)> run;
};

// Declares the options of a subcommand bound to a Command struct and returns it with its runner.
template <typename Command>
Subcommand Declare(CLI::App* cli, std::shared_ptr<Command> command, int (*run)(const Command&, const json&)) {
  return {cli, [command, run](const json& head) { return run(*command, head); }};
}

Subcommand AddDisparity(CLI::App* app) {
  auto c = std::make_shared<evaluation::DisparityCommand>();
  CLI::App* cmd = app->add_subcommand("disparity",
                                      "disparity maps vs ground-truth disparity: density, bad-N %, mean and RMS error");
  cmd->add_option("RESULTS", c->results,
                  "stereo-batch output directory (disparity/<stem>.pfm) or a directory of .pfm files")
      ->required();
  cmd->add_option("--truth", c->truth, "truth directory: <stem>.pfm or 16-bit <stem>.png (also under disparity/)")
      ->required();
  cmd->add_option("--masks", c->masks, "directory of <stem>.png masks (nonzero = evaluate)");
  cmd->add_option("--mask-min", c->options.mask_min_value,
                  "score mask pixels of at least this value (255: Middlebury 2014's non-occluded)")
      ->capture_default_str();
  cmd->add_option("--bad", c->bad_thresholds_px, "bad-pixel thresholds, px (default 0.5 1 2 4)")->delimiter(',');
  cmd->add_option("--png-scale", c->options.png_truth_scale, "16-bit PNG truth holds disparity x this (KITTI: 256)")
      ->capture_default_str();
  cmd->add_option("-o,--output", c->output_dir, "output directory (created)")->required();
  return Declare(cmd, c, &evaluation::RunDisparityCommand);
}

Subcommand AddTrials(CLI::App* app) {
  auto c = std::make_shared<evaluation::TrialsCommand>();
  CLI::App* cmd = app->add_subcommand(
      "trials", "commanded-motion trials: distance and orientation errors (Figure 7), APE/RPE/drift");
  cmd->add_option("--set", c->sets,
                  "a trial set NAME=TRAJECTORY,TRIALS[,TRUTH]: posfilter trajectory (.csv or TUM), trials "
                  "file (lunarnav.trials/1), optional ground-truth trajectory; repeatable")
      ->required();
  cmd->add_option("--min-distance", c->options.min_distance_m,
                  "trials shorter than this (m) get no distance error in percent")
      ->capture_default_str();
  cmd->add_option("--align", c->alignment, "APE alignment: none, start, origin, rigid, rigid-2d or similarity-2d")
      ->capture_default_str();
  cmd->add_option("--rpe-delta", c->trajectory_options.rpe_delta_m,
                  "RPE pose pairs this far apart along the true path (m)")
      ->capture_default_str();
  cmd->add_option("--drift-segments", c->trajectory_options.drift_segments_m,
                  "KITTI drift segment lengths (m, default 5,10,20,40)")
      ->delimiter(',');
  cmd->add_option("-o,--output", c->output_dir, "output directory (created)")->required();
  return Declare(cmd, c, &evaluation::RunTrialsCommand);
}

Subcommand AddCorrelation(CLI::App* app) {
  auto c = std::make_shared<evaluation::CorrelationCommand>();
  CLI::App* cmd =
      app->add_subcommand("correlation", "correlation curve C(d) at one pixel for several subsamplings (Figure 5)");
  cmd->add_option("LEFT", c->left, "rectified left image")->required();
  cmd->add_option("RIGHT", c->right, "rectified right image")->required();
  cmd->add_option("--pixel", c->pixel, "X,Y: the pixel, in the reference image")
      ->required()
      ->delimiter(',')
      ->expected(2);
  cmd->add_option("--steps-x", c->options.steps_x, "column steps dx (default 1,3,5)")->delimiter(',');
  cmd->add_option("--steps-y", c->options.steps_y, "row steps dy (default 1,2,4)")->delimiter(',');
  cmd->add_option("--wx", c->options.matcher.half_window_x_px, "window half-width w_x (px)")->capture_default_str();
  cmd->add_option("--wy", c->options.matcher.half_window_y_px, "window half-height w_y (px)")->capture_default_str();
  cmd->add_option("--min-disparity", c->options.matcher.min_disparity_px, "d_min (px)")->capture_default_str();
  cmd->add_option("--max-disparity", c->options.matcher.max_disparity_px, "d_max (px)")->capture_default_str();
  cmd->add_option("--reference", c->reference, "reference image: right or left")->capture_default_str();
  cmd->add_option("--zoom", c->options.zoom_px, "half-width of the magnified plot around the peak (px)")
      ->capture_default_str();
  cmd->add_option("-o,--output", c->output_dir, "output directory (created)")->required();
  return Declare(cmd, c, &evaluation::RunCorrelationCommand);
}

Subcommand AddTiming(CLI::App* app, const bool* quiet) {
  auto c = std::make_shared<evaluation::TimingCommand>();
  CLI::App* cmd =
      app->add_subcommand("timing", "stereo time against the width dY of the requested distance interval (Figure 2)");
  cmd->add_option("PAIRS", c->pairs, "directory of rectified pairs (left/, right/)")->required();
  cmd->add_option("--rig", c->rig, "rectified rig file (rectify's rig.json)")->required();
  cmd->add_option("--y-min", c->options.y_min_m, "Y_min of every interval (m)")->capture_default_str();
  cmd->add_option("--delta-y", c->options.delta_y_m, "interval widths dY (m, default 1,2,...,15)")->delimiter(',');
  cmd->add_option("--z-range", c->z_range, "heights ZMIN:ZMAX of the objects (m)")->capture_default_str();
  cmd->add_option("--window", c->window, "half-sizes WXxWY of the correlation window")->capture_default_str();
  cmd->add_option("--step", c->step, "partial subsampling steps DXxDY")->capture_default_str();
  cmd->add_option("--disparity", c->disparity, "disparity range MIN:MAX of the whole-image search (the reference row)")
      ->capture_default_str();
  cmd->add_option("--reference", c->reference, "image the disparity map is referenced to")
      ->check(CLI::IsMember({"right", "left"}))
      ->capture_default_str();
  cmd->add_option("--repeat", c->options.repeat, "timed runs per window (the median is kept)")->capture_default_str();
  cmd->add_option("--max-pairs", c->max_pairs, "time only the first N pairs (0 = all)")->capture_default_str();
  cmd->add_option("-j,--threads", c->options.matcher.num_threads,
                  "matcher threads (1 = serial, the steadiest timing; 0 = all cores)")
      ->capture_default_str();
  cmd->add_option("-o,--output", c->output_dir, "output directory (created)")->required();
  return {cmd, [c, quiet](const json& head) {
            c->progress = !*quiet;
            return evaluation::RunTimingCommand(*c, head);
          }};
}

Subcommand AddRequests(CLI::App* app) {
  auto c = std::make_shared<evaluation::RequestsCommand>();
  CLI::App* cmd = app->add_subcommand(
      "requests", "mean and range of the requested rows, disparities and distances over a run (Figure 3)");
  cmd->add_option("RUN", c->run, "stereo-batch output directory of a run with --rig and --requests or --range-y")
      ->required();
  cmd->add_option("--tolerance", c->tolerance,
                  "a pair is steady when its bounds are within this fraction of their means")
      ->capture_default_str();
  cmd->add_option("-o,--output", c->output_dir, "output directory (created)")->required();
  return Declare(cmd, c, &evaluation::RunRequestsCommand);
}

Subcommand AddBoxes(CLI::App* app) {
  auto c = std::make_shared<evaluation::BoxesCommand>();
  CLI::App* cmd =
      app->add_subcommand("boxes", "box experiment: E_Y of box faces against distance per subsampling (Figure 4)");
  cmd->add_option("RUN_DIR", c->runs, "stereo-batch output directories run with --rig (one per (dx, dy))")->required();
  cmd->add_option("--boxes", c->boxes, "box list (lunarnav.boxes/1), e.g. simulate's truth/boxes.json")->required();
  cmd->add_option("--rig", c->rig, "rectified rig file: adds the predicted error of --sigma-d px");
  cmd->add_option("--sigma-d", c->sigma_d_px, "disparity error of the predicted curve (px)")->capture_default_str();
  cmd->add_option("--edge-margin", c->options.edge_margin_m, "face points this close to an edge are left out (m)")
      ->capture_default_str();
  cmd->add_option("--truth", c->truth,
                  "simulate's truth directory (labels/, xyz/): select each face's points by the truth");
  cmd->add_option_function<double>(
      "--y-gate", [c](double gate) { c->options.y_gate_fraction = gate; },
      "drop a face's points whose |Y - true Y| > this x true Y, and count them (default: none with --truth, "
      "0.1 without)");
  cmd->add_option("-o,--output", c->output_dir, "output directory (created)")->required();
  return Declare(cmd, c, &evaluation::RunBoxesCommand);
}

Subcommand AddTrajectory(CLI::App* app) {
  auto c = std::make_shared<evaluation::TrajectoryCommand>();
  CLI::App* cmd = app->add_subcommand(
      "trajectory",
      "trajectories of one run against its truth: APE, RPE, drift, and each one's mean position error\n"
      "as a multiple of the reference's (posfilter's trajectory.csv against its baseline.csv)");
  cmd->add_option("ESTIMATE", c->estimates, "NAME=TRAJECTORY (.csv: lunarnav; else TUM)")->required();
  cmd->add_option("--truth", c->truth, "ground truth (e.g. simulate's truth.csv)")->required();
  cmd->add_option("--align", c->alignment, "alignment: none, start, origin, rigid, rigid-2d or similarity-2d")->capture_default_str();
  cmd->add_option("--reference", c->reference, "the estimate the others are compared with")->capture_default_str();
  cmd->add_option("--rpe-delta", c->options.rpe_delta_m, "RPE pose pairs this far apart (m)")->capture_default_str();
  cmd->add_option("-o,--output", c->output_dir, "output directory (created)")->required();
  return Declare(cmd, c, &evaluation::RunTrajectoryCommand);
}

Subcommand AddMap(CLI::App* app) {
  struct MapArgs {
    std::filesystem::path map, truth, output_dir;
    evaluation::MapEvalOptions options;
    std::string seen_y = "2:10";
    std::filesystem::path requests;
    int threads = 0;
    evaluation::LidarMapCommand lidar;
    std::string band, z_range;
    std::string lidar_range = "3:25";
  };
  auto c = std::make_shared<MapArgs>();
  CLI::App* cmd = app->add_subcommand(
      "map", "a terrain-map output against a simulated run's true terrain: elevation RMSE and bias, coverage of\n"
             "the ground seen, obstacle precision and recall, rocks above the obstacle height found; or, with --lidar,\n"
             "against LiDAR sweeps: flat-ground error, coverage of the rig's band, obstacles against LiDAR relief");
  cmd->add_option("MAP_DIR", c->map, "terrain-map output directory")->required();
  cmd->add_option("--truth", c->truth, "simulate stereo output directory (truth/terrain.tif, rocks.csv)");
  // Against LiDAR (docs/evaluate.md, "Against LiDAR").
  evaluation::LidarMapCommand& l = c->lidar;
  cmd->add_option("--lidar", l.lidar_dir,
                  "instead of --truth: a directory of LiDAR sweeps named by frame (<stem>.bin of KITTI's Velodyne, "
                  ".ply, .pcd), placed by the poses of their stems");
  cmd->add_option("--lidar-calib", l.lidar_calib,
                  "the LiDAR's mounting: KITTI's calib.txt (Tr) or calib_velo_to_cam.txt (default: the sweeps are in "
                  "the vehicle frame)");
  cmd->add_flag("--lidar-in-world", l.lidar_in_world, "the sweeps are in the map's world frame already");
  cmd->add_option("--rig", l.rig, "with --lidar: the rectified rig (the band, the images, KITTI's camera poses)");
  cmd->add_option("--poses", l.poses_csv, "with --lidar: the vehicle's poses per frame (stem,t_s,x_m,...)");
  cmd->add_option("--trajectory", l.trajectory,
                  "with --lidar: or a trajectory (posfilter's, TUM, a KITTI pose file or oxts/) at --frame-times");
  cmd->add_option("--frame-times", l.frame_times, "stem,t_s per frame, or KITTI's times.txt or timestamps.txt");
  cmd->add_option("--pairs", l.pairs_dir,
                  "with --lidar: the stereo pairs taken (a pair directory): the band is theirs, mapped or not "
                  "(default: the map's frames.csv)");
  cmd->add_option("--stereo", l.stereo_dir,
                  "with --lidar: stereo-batch's output (xyz/): each pair against the sweep nearest in time");
  cmd->add_option("--band", c->band, "with --lidar: the band scored for coverage and recall, MIN:MAX m ahead "
                                     "(default: the rig's default search)");
  cmd->add_option("--z-range", c->z_range,
                  "with --lidar: the heights the stereo searched, ZMIN:ZMAX m (stereo-batch's --z-range; default "
                  "-0.5:1): an object counts for recall where a pair saw its part up to ZMAX");
  cmd->add_option("--lidar-range", c->lidar_range,
                  "with --lidar: returns MIN:MAX m from the sensor (horizontally) are used: nearer ones hit the vehicle, "
                  "farther ones carry the sensor's small angle errors as height errors")
      ->capture_default_str();
  cmd->add_option("--max-sweep-gap", l.options.max_sweep_gap_s,
                  "with --lidar: cells a pair saw farther in time than this from every sweep are not judged, s")
      ->capture_default_str();
  cmd->add_option("--sweeps-agree", l.options.sweeps_agree_m,
                  "with --lidar: the flat ground is also scored over the cells whose sweeps agree within this, m")
      ->capture_default_str();
  cmd->add_option("--flat-spread", l.options.flat_spread_m,
                  "with --lidar: a flat cell's returns lie within this of their median, m")
      ->capture_default_str();
  cmd->add_option("--object-height", l.options.object_height_m,
                  "with --lidar: a return this far above the local ground makes its cell an object, m")
      ->capture_default_str();
  cmd->add_option("--overhang", l.options.overhang_m,
                  "with --lidar: what stands only this far or more over ground seen beneath it (a canopy, a sign) is "
                  "an overhang, no object to find, m")
      ->capture_default_str();
  cmd->add_option("--min-points", c->options.min_points, "cells with fewer points are not scored")
      ->capture_default_str();
  cmd->add_option("--rock-height", c->options.rock_height_m, "rocks at least this tall are counted, m")
      ->capture_default_str();
  cmd->add_option("--rock-near", c->options.rock_near_m,
                  "a rock is found by a map obstacle cell whose centre is this close to its centre, m")
      ->capture_default_str();
  cmd->add_option("--relief-height", c->options.relief_height_m,
                  "precision: a map obstacle near this much true relief (a step or a rock) is real, m")
      ->capture_default_str();
  cmd->add_option("--relief-slope", c->options.relief_slope_deg,
                  "precision: a map obstacle near a true slope above this is real, deg")
      ->capture_default_str();
  cmd->add_option("--tolerance", c->options.tolerance_cells, "detections this many cells away count")
      ->capture_default_str();
  cmd->add_option("--large-error", c->options.large_error_m, "a cell farther than this from the truth is counted, m")
      ->capture_default_str();
  cmd->add_option("--seen-y", c->seen_y,
                  "the ground scored for coverage and recall: true points both cameras see MIN:MAX m ahead")
      ->capture_default_str();
  cmd->add_option("--requests", c->requests,
                  "the requests the pairs were matched with (map-loop's requests.csv): beside the score of all the "
                  "ground seen, a second view over each listed pair's requested ground (requested.md), with the "
                  "corridor's gaps");
  cmd->add_option("--corridor-width", c->options.corridor_width_m, "width of the corridor whose gaps are measured, m")
      ->capture_default_str();
  cmd->add_option("-j,--threads", c->threads, "threads (0 = all cores)")->capture_default_str();
  cmd->add_option("-o,--output", c->output_dir, "output directory (created)")->required();
  return {cmd, [c](const json& head) {
            LN_CHECK_ARG(c->truth.empty() != c->lidar.lidar_dir.empty()) << "give either --truth or --lidar";
            if (c->lidar.lidar_dir.empty()) {  // no option of --lidar's is silently ignored
              const evaluation::LidarMapCommand& l = c->lidar;
              for (const auto& [given, name] : {std::pair{!l.lidar_calib.empty(), "--lidar-calib"},
                                                {l.lidar_in_world, "--lidar-in-world"},
                                                {!l.rig.empty(), "--rig"},
                                                {!l.poses_csv.empty(), "--poses"},
                                                {!l.trajectory.empty(), "--trajectory"},
                                                {!l.frame_times.empty(), "--frame-times"},
                                                {!l.pairs_dir.empty(), "--pairs"},
                                                {!l.stereo_dir.empty(), "--stereo"},
                                                {!c->band.empty(), "--band"},
                                                {!c->z_range.empty(), "--z-range"}}) {
                LN_CHECK_ARG(!given) << name << ": only with --lidar (the simulated truth holds its own poses)";
              }
            } else {
              LN_CHECK_ARG(c->requests.empty()) << "--requests: only with --truth";
            }
            if (!c->lidar.lidar_dir.empty()) {
              evaluation::LidarMapCommand& l = c->lidar;
              LN_CHECK_ARG(!l.rig.empty()) << "--lidar needs --rig";
              LN_CHECK_ARG(l.lidar_in_world || l.poses_csv.empty() != l.trajectory.empty())
                  << "--lidar needs --poses or --trajectory with --frame-times";
              LN_CHECK_ARG(l.trajectory.empty() || !l.frame_times.empty()) << "--trajectory needs --frame-times";
              LN_CHECK_ARG(!l.lidar_in_world || !(l.poses_csv.empty() && l.trajectory.empty()))
                  << "the pairs' poses are still needed with --lidar-in-world (the band)";
              if (!c->band.empty()) {
                std::tie(l.band_min_y_m, l.band_max_y_m) = util::ParseDoublePair(c->band, ':', "--band");
              }
              if (!c->z_range.empty()) {
                std::tie(l.z_min_m, l.z_max_m) = util::ParseDoublePair(c->z_range, ':', "--z-range");
              }
              std::tie(l.options.min_range_m, l.options.max_range_m) =
                  util::ParseDoublePair(c->lidar_range, ':', "--lidar-range");
              l.map_dir = c->map;
              l.output_dir = c->output_dir;
              l.num_threads = c->threads;
              l.options.min_points = c->options.min_points;
              l.options.tolerance_cells = c->options.tolerance_cells;
              l.options.large_error_m = c->options.large_error_m;
              l.options.relief_height_m = c->options.relief_height_m;
              l.options.recall_height_m = c->options.rock_height_m;
              const evaluation::LidarEvalResult r = evaluation::RunLidarMapEvaluation(l, head.at("invocation"));
              LN_LOG(Info) << "evaluate map --lidar: " << r.BriefReport() << "; "
                           << (c->output_dir / "lidar.md").string();
              return static_cast<int>(kExitOk);
            }
            std::tie(c->options.seen_min_y_m, c->options.seen_max_y_m) =
                util::ParseDoublePair(c->seen_y, ':', "--seen-y");
            if (!c->requests.empty()) {
              for (const stereo::WindowRequest& r : stereo::ReadWindowRequests(c->requests)) {
                c->options.requested_y_m[r.stem] = {r.y_min_m, r.y_max_m};
              }
            }
            const evaluation::MapEvalResult r = evaluation::RunMapEvaluation(
                c->map, c->truth, c->options, c->output_dir, c->threads, head.at("invocation"));
            LN_LOG(Info) << "evaluate map: " << r.BriefReport() << "; " << (c->output_dir / "map.md").string();
            return static_cast<int>(kExitOk);
          }};
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
  long long max_pixels = io::kDefaultMaxImagePixels;
  util::AddMaxPixelsFlag(&app, &max_pixels);
  util::AddCommonFlags(&app, &quiet);

  const std::vector<Subcommand> subcommands = {
      AddDisparity(&app), AddTrials(&app), AddCorrelation(&app), AddTiming(&app, &quiet),
      AddRequests(&app),  AddBoxes(&app),  AddTrajectory(&app),          AddMap(&app),
  };

  if (const auto exit_code = util::ParseCommandLine(&app, argc, argv, quiet)) return *exit_code;
  return util::RunMain([&]() -> int {
    io::SetMaxImagePixels(max_pixels);
    for (const Subcommand& subcommand : subcommands) {
      if (!subcommand.cli->parsed()) continue;
      json head = util::SummaryHead("evaluate", util::CommandLineJson(argc, argv));
      head["subcommand"] = subcommand.cli->get_name();
      return subcommand.run(head);
    }
    return kExitUsage;
  });
}
