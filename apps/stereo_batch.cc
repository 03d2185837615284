// stereo-batch: the paper's correlation matcher over a directory of rectified image pairs.
// docs/stereo-batch.md describes every option and output.
#include <cmath>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <string>

#include "apps/matcher_cli.h"
#include "calib/stereo_rig_io.h"
#include "io/stereo_pairs.h"
#include "mapping/frame_poses.h"
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
  std::string disparity = "0:127", rows, shard;
  std::string rig_path, range_y, z_range, requests_path;
  fs::path poses_csv, trajectory, frame_times;
  double xyz_sigma = 1.0;
  bool quiet = false;
  app.add_option("INPUT_DIR", input_dir, "directory holding left/ and right/")->required();
  app.add_option("-o,--output", output_dir, "output directory (created)")->required();
  // The matcher's options: a preset, and every option given over it.
  apps::MatcherCommandLine matcher_cl;
  apps::AddMatcherOptions(&app, &matcher_cl, &opt.frame_check);
  CLI::Option* disparity_option =
      app.add_option("--disparity", disparity,
                     "disparity range MIN:MAX, pixels, inclusive (default with --rig: the ground the rig sees)")
          ->capture_default_str();
  CLI::Option* rows_option =
      app.add_option("--rows", rows, "row band MIN:MAX of the reference image (default: all rows)");
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
  double tall_guard_m = calib::GroundWindowOptions{}.tall_guard_m;
  app.add_option("--tall-guard", tall_guard_m,
                 "with --rig's default search: also search each row's disparities of objects up to M metres above the "
                 "heights (--z-range's top) at the search's distances, and reject what matches there (beyond_near): a post "
                 "taller than the heights is matched where it stands, not smeared into the band beside it (0 = off)")
      ->capture_default_str();
  CLI::Option* requests_option = app.add_option(
      "--requests", requests_path,
      "CSV stem,y_min_m,y_max_m: each listed pair's own distance interval (needs --rig)");
  CLI::Option* poses_option = app.add_option(
      "--poses", poses_csv,
      "poses per pair (stem,t_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg, as terrain-map reads them): each "
      "pair's search is taken level, at its vehicle's pitch and roll (needs --rig)");
  CLI::Option* trajectory_option =
      app.add_option("--trajectory", trajectory,
                     "posfilter's trajectory.csv, a TUM file, a KITTI pose file or KITTI oxts/ (camera poses placed by "
                     "--rig's mast), interpolated at --frame-times: as --poses");
  CLI::Option* frame_times_option = app.add_option(
      "--frame-times", frame_times, "stem,t_s per pair, or KITTI's times.txt or timestamps.txt (for --trajectory)");
  poses_option->needs(rig_option)->excludes(trajectory_option);
  trajectory_option->needs(rig_option)->needs(frame_times_option);
  frame_times_option->needs(trajectory_option);
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
    opt.matcher = apps::MatcherFromCommandLine(app, matcher_cl);
    auto given_option = [&](const char* name) { return app.get_option(name)->count() > 0; };
    std::tie(opt.matcher.min_disparity_px, opt.matcher.max_disparity_px) =
        util::ParseIntPair(disparity, ':', "--disparity");
    if (!rows.empty()) {
      const auto [lo, hi] = util::ParseIntPair(rows, ':', "--rows");
      opt.matcher.min_row = lo;
      opt.matcher.max_row = hi;
    }
    util::ApplyShard(shard, &opt.shard_index, &opt.shard_count);
    opt.show_progress = !quiet;
    if (!rig_path.empty()) {
      opt.rig = calib::ReadStereoRig(rig_path);
      opt.rig_source = rig_path;
      apps::ApplyMapPipelineDefaults(app, &opt.matcher);  // the points become a map
    }
    apps::ApplyVerticalAlignment(app, matcher_cl, opt.rig.has_value(), &opt);
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
    if (opt.rig) stereo::CheckRigAgainstPairs(*opt.rig, opt.rig_source, input_dir);
    LN_CHECK_ARG(rig_default || !given_option("--tall-guard"))
        << "--tall-guard: needs --rig's default search (no --disparity, --rows or --range-y)";
    if (rig_default) {
      calib::GroundWindowOptions ground;
      ground.z_min_m = region.z_min_m;
      ground.z_max_m = region.z_max_m;
      ground.tall_guard_m = tall_guard_m;
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

    if (!poses_csv.empty() || !trajectory.empty()) {
      std::vector<std::string> stems;
      for (const io::PairFiles& p : io::ListStereoPairs(input_dir)) stems.push_back(p.stem);
      opt.attitudes_source = poses_csv.empty() ? trajectory.string() : poses_csv.string();
      for (const mapping::FramePose& p : mapping::PosesOfPairs(poses_csv, trajectory, frame_times, stems,
                                                                       opt.rig->VehicleFromLeft())) {
        const stereo::VehicleAttitude a{p.pitch_rad * 180.0 / M_PI, p.roll_rad * 180.0 / M_PI};
        LN_CHECK_INPUT(std::abs(a.pitch_deg) < 90 && std::abs(a.roll_deg) < 90)
            << opt.attitudes_source << ": stem " << p.stem << ": pitch " << a.pitch_deg << " deg, roll " << a.roll_deg
            << " deg: the ground is searched at pitch and roll within (-90, 90) deg";
        opt.attitudes[p.stem] = a;
      }
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
