// terrain-map: stereo-batch's vehicle-frame points and the vehicle's poses -> the terrain map
// of Krotkov & Hebert sec. 3 (25 cm cells, GeoTIFF layers, obstacles). docs/terrain-map.md.
#include <filesystem>
#include <string>
#include <vector>

#include "apps/mapping_cli.h"
#include "calib/triangulation.h"
#include "calib/vehicle.h"
#include "mapping/terrain_map_run.h"
#include "util/cli.h"
#include "util/errors.h"
#include "util/log.h"
#include "util/run_main.h"

namespace fs = std::filesystem;
using namespace lunarnav;

int main(int argc, char** argv) {
  CLI::App app{
      "Accumulates the 3-D points of a stereo-batch run (xyz/<stem>.exr, vehicle frame; weighted by\n"
      "xyz_sigma/<stem>.exr when present) into a terrain map on a grid of --cell metres (Krotkov & Hebert\n"
      "sec. 3, 3.4), with the vehicle's pose per pair. Writes OUT_DIR/elevation.tif (GeoTIFF: elevation, min,\n"
      "max, count, roughness, sigma, last time, obstacle), state.tif and frames.csv (for --resume and\n"
      "--merge), preview.png and summary.json.\n"
      "Exit codes: 0 ok, 1 internal error, 2 usage, 3 bad input (nothing written)."};
  mapping::TerrainMapRunOptions opt;  // defaults live in the library
  fs::path output_dir, vehicle;
  double window_m = 0;
  std::string reference;
  bool quiet = false, no_preview = false;
  app.add_option("STEREO_DIR", opt.stereo_dir, "stereo-batch output directory (with xyz/ from --rig)");
  app.add_option("-o,--output", output_dir, "output directory (created)")->required();
  app.add_option("--poses", opt.poses_csv, "poses per pair: stem,t_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg "
                                           "(simulate stereo's truth/poses.csv)");
  app.add_option("--trajectory", opt.trajectory,
                 "posfilter's trajectory.csv, a TUM file, a KITTI pose file or "
                 "KITTI oxts/ (with --rig), interpolated at --frame-times");
  app.add_option("--frame-times", opt.frame_times,
                 "stem,t_s per pair, or KITTI's times.txt or timestamps.txt (for --trajectory)");
  app.add_option("--rig", opt.rig, "rectified rig file: each point's predicted error from the rig's geometry "
                                   "(as xyz_sigma/ holds it) without reading xyz_sigma/");
  app.add_option("--sigma-d", opt.sigma_d_px, "disparity error for --rig's error model, px")->capture_default_str();
  app.add_option("--reference", reference,
                 "the image the disparity maps are referenced to (the rays of the depth-edge, hidden and carving "
                 "rules start at its camera; with --rig)")
      ->check(CLI::IsMember({"right", "left"}))
      ->default_str("as stereo-batch's summary.json records it, else right");
  app.add_option("--requests", opt.requests, "the requests the pairs were matched with (stereo-batch --requests): "
                                             "points outside a pair's Y interval are left out");
  apps::AddFusionOptions(&app, &opt.map);
  app.add_option("--window-m", window_m, "keep only a square window of this side centred at the vehicle, m "
                                         "(default: the whole traverse)");
  app.add_option("--vehicle", vehicle, "vehicle file: obstacle height (requirements.obstacle_height_m) and "
                                       "max_slope_deg (default: 0.2 m, 30 deg)");
  app.add_option("--merge", opt.merge_maps, "terrain-map output directory of other frames to merge in "
                                            "(repeatable)");
  std::string align = "auto";
  mapping::GroundAlignmentOptions align_options;
  apps::AddAlignmentOptions(&app, &align, &align_options);
  app.add_flag("--no-preview", no_preview, "do not write preview.png");
  app.add_flag("--resume", opt.resume, "continue the map in OUT_DIR: frames listed in its frames.csv are skipped");
  app.add_option("-j,--threads", opt.num_threads, "threads reading frames (0 = all cores)")->capture_default_str();
  std::string shard;
  app.add_option("--shard", shard,
                 "map shard K of N of the frames (K/N, or auto / auto/N from a Slurm job array or GNU parallel) "
                 "into OUT_DIR/shard-K-of-N; then --merge the shards (docs/cluster.md)");
  util::AddCommonFlags(&app, &quiet);
  if (const auto exit_code = util::ParseCommandLine(&app, argc, argv, quiet)) return *exit_code;

  return util::RunMain([&] {
    // Given, it is a window (0, a negative size or nan are refused by the options' check).
    if (app.get_option("--window-m")->count() > 0) opt.map.window_m = window_m;
    if (!reference.empty()) opt.reference = calib::ReferenceImageFromString(reference);
    if (!vehicle.empty()) {
      apps::ApplyVehicleLimits(calib::ReadVehicleSpec(vehicle), &opt.map);
    }
    util::ApplyShard(shard, &opt.shard_index, &opt.shard_count);
    if (opt.shard_count > 1) {
      output_dir /= "shard-" + std::to_string(opt.shard_index) + "-of-" + std::to_string(opt.shard_count);
    }
    opt.align = apps::ResolveAlignment(align, align_options, opt.trajectory);
    opt.write_preview = !no_preview;
    opt.show_progress = !quiet;
    const mapping::TerrainMapRunSummary s =
        mapping::RunTerrainMap(opt, output_dir, util::CommandLineJson(argc, argv));
    LN_LOG(Info) << "terrain-map: " << s.BriefReport() << "; outputs in " << output_dir.string();
    return kExitOk;
  });
}
