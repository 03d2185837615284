// stereo-batch: the paper's correlation matcher over a directory of rectified image pairs.
// docs/stereo-batch.md describes every option and output.
#include <filesystem>
#include <iostream>
#include <sstream>
#include <string>

#include "calib/stereo_rig_io.h"
#include "stereo/batch.h"
#include "stereo/window_requests.h"
#include "util/check.h"
#include "io/image_io.h"
#include "util/cli.h"
#include "util/errors.h"
#include "util/log.h"
#include "util/parse.h"
#include "util/run_main.h"

namespace fs = std::filesystem;
using namespace lunarnav;

int main(int argc, char** argv) {
  CLI::App app{
      "Normalized-correlation stereo (Krotkov & Hebert 1995) over INPUT_DIR/left and\n"
      "INPUT_DIR/right (rectified pairs with the same file stems). Writes OUT_DIR/disparity/\n"
      "<stem>.pfm, confidence/<stem>.tif, rejections/<stem>.png and summary.json; with --rig\n"
      "also xyz/<stem>.exr (vehicle-frame XYZ), cloud/<stem>.ply, xyz_sigma/<stem>.exr.\n"
      "Exit codes: 0 ok, 1 internal error, 2 usage, 3 bad input, 4 some pairs failed."};
  stereo::BatchOptions opt;  // defaults (the paper's) live in the library
  fs::path input_dir, output_dir;
  std::string window = "25x17", step = "1x1", disparity = "0:127", rows, shard, reference = "right";
  std::string rig_path, range_y, z_range, requests_path;
  double xyz_sigma = 1.0;
  bool quiet = false;
  app.add_option("INPUT_DIR", input_dir, "directory holding left/ and right/")->required();
  app.add_option("-o,--output", output_dir, "output directory (created)")->required();
  // Options that a preset sets: bound to their own variables and applied over the preset only
  // when given (an explicit option overrides the preset).
  std::string preset = "quality";
  const stereo::NccOptions paper = stereo::PresetOptions("paper");
  const stereo::NccOptions quality = stereo::PresetOptions("quality");
  stereo::NccOptions given = paper;
  std::string census = "4x3", aggregation = "semi-global";
  auto preset_default = [&](auto paper_value, auto quality_value) {
    std::ostringstream s;
    s << "paper " << paper_value << ", quality " << quality_value;
    return s.str();
  };
  app.add_option("--preset", preset,
                 "named defaults: quality (semi-global census matching with the paper's confidence and "
                 "filters, left-right and speckle checks) or paper (exactly the paper's matcher, sec. 3.2-3.4)")
      ->check(CLI::IsMember(stereo::PresetNames()))
      ->capture_default_str();
  app.add_option("--aggregation", aggregation, "window (the paper's) or semi-global")
      ->check(CLI::IsMember({"window", "semi-global"}))
      ->default_str("from the preset");
  app.add_option("--window", window,
                 "half-sizes WXxWY of the correlation window (quality: of the confidence C)")
      ->default_str(preset_default("25x17", "3x3"));
  app.add_option("--sigma-min", given.min_sigma,
                 "filter 1: min std dev of the reference window, 8-bit grey levels (scaled by the bit depth)")
      ->default_str(preset_default(paper.min_sigma, quality.min_sigma));
  app.add_option("--c-min", given.min_correlation, "filter 2: min best correlation C")
      ->default_str(preset_default(paper.min_correlation, quality.min_correlation));
  app.add_option("--ambiguity", given.ambiguity,
                 "filter 3: M, reject when (C - C')/C < M (0.1 = 10 %); window aggregation only")
      ->default_str(preset_default(paper.ambiguity, quality.ambiguity));
  app.add_option("--median", given.median_size, "filter 4: median size k (odd; 0 = off)")
      ->default_str(preset_default(paper.median_size, quality.median_size));
  app.add_option("--census", census, "semi-global: census window half-sizes XxY ((2X+1)(2Y+1)-1 <= 64)")
      ->capture_default_str();
  app.add_option("--p1", given.semi_global.penalty_small,
                 "semi-global: penalty of a 1-px disparity change between neighbours (census bits)")
      ->default_str(std::to_string(quality.semi_global.penalty_small));
  app.add_option("--p2", given.semi_global.penalty_large,
                 "semi-global: penalty of a larger disparity change (census bits)")
      ->default_str(std::to_string(quality.semi_global.penalty_large));
  app.add_option("--p2-edge", given.semi_global.edge_levels,
                 "semi-global: P2 falls to P2 E / (E + g) across a grey-level step g (8-bit levels); 0 = constant")
      ->default_str(std::to_string(quality.semi_global.edge_levels));
  app.add_option("--paths", given.semi_global.num_paths, "semi-global: aggregation directions, 4 or 8")
      ->default_str(std::to_string(quality.semi_global.num_paths));
  app.add_option("--uniqueness", given.semi_global.uniqueness,
                 "semi-global: reject when the best cost outside the minimum's lobe is within this "
                 "fraction of the best (0 = off)")
      ->default_str(std::to_string(quality.semi_global.uniqueness));
  app.add_option("--lr-check", given.semi_global.left_right_max_diff_px,
                 "semi-global: max left-right disagreement, px (-1 = off)")
      ->default_str(std::to_string(quality.semi_global.left_right_max_diff_px));
  app.add_option("--speckle-size", given.semi_global.speckle_max_size_px,
                 "semi-global: reject disconnected regions of at most this many pixels (0 = off)")
      ->default_str(std::to_string(quality.semi_global.speckle_max_size_px));
  app.add_option("--speckle-range", given.semi_global.speckle_range_px,
                 "semi-global: disparity step, px, that disconnects a region")
      ->default_str(std::to_string(quality.semi_global.speckle_range_px));
  app.add_option("--border-tolerance", given.border_tolerance_px,
                 "border rule: reject a pixel whose search runs past the other image when its match lies this many "
                 "px left of the surface's to its left (-1 = off)")
      ->default_str(preset_default(paper.border_tolerance_px, quality.border_tolerance_px));
  app.add_option("--bit-depth", given.bit_depth,
                 "significant bits of 16-bit images (default: a PNG's sBIT, else 16)");
  CLI::Option* disparity_option =
      app.add_option("--disparity", disparity,
                     "disparity range MIN:MAX, pixels, inclusive (default with --rig: the ground the rig sees)")
          ->capture_default_str();
  CLI::Option* rows_option =
      app.add_option("--rows", rows, "row band MIN:MAX of the reference image (default: all rows)");
  app.add_option("--step", step, "partial subsampling steps DXxDY")->capture_default_str();
  app.add_option("--reference", reference, "image the disparity map is referenced to")
      ->check(CLI::IsMember({"right", "left"}))
      ->capture_default_str();
  app.add_option("--blank-sigma", opt.frame_check.blank_max_sigma,
                 "a frame with intensity std dev below this (8-bit grey levels) is blank")
      ->capture_default_str();
  app.add_option("--saturation-fraction", opt.frame_check.saturated_max_fraction,
                 "a frame with more than this fraction of pixels at full scale is saturated")
      ->capture_default_str();
  CLI::Option* rig_option = app.add_option(
      "--rig", rig_path, "rectified rig file (rectify's rig.json): also write xyz/<stem>.exr, vehicle frame");
  app.add_flag("--ply", opt.write_ply, "also write cloud/<stem>.ply (needs --rig)");
  app.add_flag("--preview", opt.write_preview,
               "also write preview/<stem>.png: the disparity colour-mapped with a legend, rejected pixels "
               "marked by reason");
  CLI::Option* sigma_option =
      app.add_option("--xyz-sigma", xyz_sigma,
                     "also write xyz_sigma/<stem>.exr, the X Y Z error of a disparity error of SIGMA px "
                     "(needs --rig)")
          ->expected(0, 1)
          ->default_str("1");
  CLI::Option* range_option = app.add_option(
      "--range-y", range_y,
      "window selection: measure only Y in YMIN:YMAX metres (vehicle frame); replaces --rows and "
      "--disparity (needs --rig)");
  app.add_option(
      "--z-range", z_range,
      "heights ZMIN:ZMAX metres of the objects for window selection and the rig's default search (default -0.5:1)");
  CLI::Option* requests_option = app.add_option(
      "--requests", requests_path,
      "CSV stem,y_min_m,y_max_m: each listed pair's own distance interval (needs --rig)");
  range_option->excludes(rows_option)->excludes(disparity_option)->needs(rig_option);
  requests_option->needs(rig_option);  // --rows and --disparity then serve the pairs not listed
  sigma_option->needs(rig_option);
  app.get_option("--ply")->needs(rig_option);
  util::AddBatchFlags(&app, "skip pairs whose outputs are complete (same options)", &opt.resume, &shard,
                     &opt.num_threads);
  long long max_pixels = io::kDefaultMaxImagePixels;
  util::AddMaxPixelsFlag(&app, &max_pixels);
  util::AddCommonFlags(&app, &quiet);
  if (const auto exit_code = util::ParseCommandLine(&app, argc, argv, quiet)) return *exit_code;

  return util::RunMain([&] {
    io::SetMaxImagePixels(max_pixels);
    opt.matcher = stereo::PresetOptions(preset);
    stereo::NccOptions& m = opt.matcher;
    auto given_option = [&](const char* name) { return app.get_option(name)->count() > 0; };
    if (given_option("--aggregation")) {
      m.aggregation = aggregation == "window" ? stereo::Aggregation::kWindow : stereo::Aggregation::kSemiGlobal;
    }
    if (given_option("--sigma-min")) m.min_sigma = given.min_sigma;
    if (given_option("--c-min")) m.min_correlation = given.min_correlation;
    if (given_option("--ambiguity")) m.ambiguity = given.ambiguity;
    if (given_option("--median")) m.median_size = given.median_size;
    if (given_option("--census")) {
      std::tie(m.semi_global.census_half_x_px, m.semi_global.census_half_y_px) =
          util::ParseIntPair(census, 'x', "--census");
    }
    if (given_option("--p1")) m.semi_global.penalty_small = given.semi_global.penalty_small;
    if (given_option("--p2")) m.semi_global.penalty_large = given.semi_global.penalty_large;
    if (given_option("--paths")) m.semi_global.num_paths = given.semi_global.num_paths;
    if (given_option("--p2-edge")) m.semi_global.edge_levels = given.semi_global.edge_levels;
    if (given_option("--uniqueness")) m.semi_global.uniqueness = given.semi_global.uniqueness;
    if (given_option("--lr-check")) m.semi_global.left_right_max_diff_px = given.semi_global.left_right_max_diff_px;
    if (given_option("--speckle-size")) m.semi_global.speckle_max_size_px = given.semi_global.speckle_max_size_px;
    if (given_option("--speckle-range")) m.semi_global.speckle_range_px = given.semi_global.speckle_range_px;
    if (given_option("--bit-depth")) m.bit_depth = given.bit_depth;
    if (given_option("--border-tolerance")) m.border_tolerance_px = given.border_tolerance_px;
    if (!given_option("--window")) {
      window = std::to_string(m.half_window_x_px) + "x" + std::to_string(m.half_window_y_px);
    }
    std::tie(opt.matcher.half_window_x_px, opt.matcher.half_window_y_px) =
        util::ParseIntPair(window, 'x', "--window");
    std::tie(opt.matcher.step_x_px, opt.matcher.step_y_px) = util::ParseIntPair(step, 'x', "--step");
    std::tie(opt.matcher.min_disparity_px, opt.matcher.max_disparity_px) =
        util::ParseIntPair(disparity, ':', "--disparity");
    if (!rows.empty()) {
      const auto [lo, hi] = util::ParseIntPair(rows, ':', "--rows");
      opt.matcher.min_row = lo;
      opt.matcher.max_row = hi;
    }
    util::ApplyShard(shard, &opt.shard_index, &opt.shard_count);
    opt.matcher.reference = stereo::ReferenceImageFromString(reference);
    opt.show_progress = !quiet;
    if (!rig_path.empty()) {
      opt.rig = calib::ReadStereoRig(rig_path);
      opt.rig_source = rig_path;
    }
    if (sigma_option->count() > 0) opt.xyz_sigma_px = xyz_sigma;
    calib::RegionOfInterest region;  // the paper's heights unless --z-range
    // With a rig and neither --disparity, --rows nor --range-y, the search is the ground the
    // rig sees (calib::SelectGroundWindow; the pairs --requests does not list use it too).
    const bool rig_default = opt.rig && opt.rig->rectified && !given_option("--disparity") && rows.empty() && range_y.empty();
    if (!z_range.empty()) {
      LN_CHECK_ARG(!range_y.empty() || !requests_path.empty() || rig_default)
          << "--z-range: needs --range-y, --requests, or --rig without --disparity and --rows";
      std::tie(region.z_min_m, region.z_max_m) = util::ParseDoublePair(z_range, ':', "--z-range");
    }
    if (rig_default) {
      calib::GroundWindowOptions ground;
      ground.z_min_m = region.z_min_m;
      ground.z_max_m = region.z_max_m;
      opt.ground = calib::SelectGroundWindow(*opt.rig, opt.matcher.reference, ground, opt.window_selection);
    }
    if (!range_y.empty()) {
      std::tie(region.y_min_m, region.y_max_m) = util::ParseDoublePair(range_y, ':', "--range-y");
      opt.region = region;
    }
    if (!requests_path.empty()) {
      opt.requests = stereo::ReadWindowRequests(requests_path);
      opt.requests_source = requests_path;
      opt.requests_region = region;  // its heights; each request gives Y
    }

    const stereo::BatchSummary summary =
        stereo::RunStereoBatch(opt, input_dir, output_dir, util::CommandLineJson(argc, argv));
    LN_LOG(Info) << "stereo-batch: " << summary.BriefReport();
    std::string dirs = "disparity,confidence,rejections";
    if (opt.rig) dirs += ",xyz";
    if (opt.write_ply) dirs += ",cloud";
    if (opt.xyz_sigma_px) dirs += ",xyz_sigma";
    if (opt.write_preview) dirs += ",preview";
    LN_LOG(Info) << "outputs in " << output_dir.string() << "/{" << dirs << "}, "
                 << "summary in " << summary.summary_path.string();
    return summary.pairs_failed > 0 ? kExitBatchPartial : kExitOk;
  });
}
