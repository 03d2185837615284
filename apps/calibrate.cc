// calibrate: a stereo rig file from chessboard views. docs/calibrate.md describes every
// option and output.
#include <cstdint>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "calib/calibration.h"
#include "calib/rig_import.h"
#include "calib/stereo_rig_io.h"
#include "io/json_io.h"
#include "util/check.h"
#include "io/image_io.h"
#include "util/cli.h"
#include "util/errors.h"
#include "util/log.h"
#include "util/parse.h"
#include "util/run_main.h"
#include "util/summary.h"
#include "util/timer.h"

namespace fs = std::filesystem;
using namespace lunarnav;

int main(int argc, char** argv) {
  CLI::App app{
      "Calibrates a stereo rig from chessboard views: INPUT_DIR/left and INPUT_DIR/right hold\n"
      "the two images of each view with the same file stems. Writes the rig file (-o) and\n"
      "summary.json beside it; prints the per-view table on stdout.\n"
      "Exit codes: 0 ok, 1 internal error, 2 usage, 3 bad input (e.g. too few usable views),\n"
      "4 calibrated, but some views had unreadable or mismatched images.\n"
      "With --from FORMAT FILE..., imports an existing calibration instead (no views):\n"
      "opencv INTRINSICS.yml EXTRINSICS.yml, ros LEFT.yaml RIGHT.yaml, kalibr CAMCHAIN.yaml,\n"
      "middlebury calib.txt, kitti calib_cam_to_cam.txt (docs/formats.md)."};
  calib::CalibrationOptions opt;  // defaults live in the library
  std::vector<fs::path> inputs;
  fs::path rig_path, summary_path;
  calib::RigFormat from = calib::RigFormat::kOpenCv;
  std::string board = "9x6";
  bool quiet = false;
  std::vector<fs::path> opencv_files;
  std::string image_size;
  app.add_option("INPUT", inputs, "directory holding left/ and right/; with --from, the format's files");
  app.add_option("--from", from,
                 "import FORMAT's files instead of calibrating (opencv, ros, kalibr, middlebury, kitti)")
      ->transform(CLI::CheckedTransformer(calib::RigFormatNames(), CLI::ignore_case));
  app.add_option("--from-opencv", opencv_files,
                 "INTRINSICS.yml EXTRINSICS.yml: import OpenCV's stereo calibration (M1 D1 M2 D2; R T) as its "
                 "stereo_calib sample writes it, instead of calibrating; --square is then the metres per unit of T")
      ->expected(2);
  app.add_option("--image-size", image_size,
                 "WIDTHxHEIGHT of the calibrated images (with --from opencv; with --from kitti on an odometry "
                 "calib.txt, the default is the size of the sequence's first image)");
  calib::KittiPair kitti_pair = calib::KittiPair::kColour;
  app.add_option("--kitti-pair", kitti_pair,
                 "with --from kitti: the rectified pair, colour (cameras 2, 3) or grey (0, 1)")
      ->transform(CLI::CheckedTransformer(calib::KittiPairNames(), CLI::ignore_case))
      ->capture_default_str();
  app.add_option("-o,--output", rig_path, "rig file to write (JSON, lunarnav.rig/1)")->required();
  app.add_option("--board", board, "inner corners COLSxROWS of the chessboard")->capture_default_str();
  app.add_option("--square", opt.board.square_size_m,
                 "side of one square, metres (with --from opencv: metres per unit of T; 1 if T is in metres)");
  app.add_option("--mast-height", opt.mast.height_m, "height of the head centre above the mast base, m")
      ->capture_default_str();
  app.add_option("--tilt", opt.mast.tilt_deg, "downward pitch of the optical axes, degrees")->capture_default_str();
  app.add_option("--lateral", opt.mast.lateral_offset_m, "X of the head centre (right positive), m")
      ->capture_default_str();
  app.add_option("--forward", opt.mast.forward_offset_m, "Y of the head centre (forward positive), m")
      ->capture_default_str();
  app.add_option("--min-views", opt.min_views, "fewest views with the board found in both images")
      ->capture_default_str();
  app.add_flag("--k3", opt.estimate_k3, "estimate the radial coefficient k3 too (wide-angle lenses)");
  app.add_flag("--fix-intrinsics", opt.fix_intrinsics,
               "keep each camera's own calibration in the stereo step (default: refine jointly)");
  app.add_option("--flag-rms", opt.flag_view_rms_px, "flag views whose RMS reprojection error exceeds this, px")
      ->capture_default_str();
  app.add_flag("--keep-outliers", [&](std::int64_t) { opt.drop_outliers = false; },
               "use every view, however large its error (default: drop outliers and calibrate again)");
  app.add_option("--drop-k", opt.drop_mad_factor, "drop a view above median + K x 1.4826 x MAD of the views' errors")
      ->capture_default_str();
  app.add_option("--drop-min-rms", opt.drop_min_rms_px, "never drop a view whose RMS error is below this, px")
      ->capture_default_str();
  app.add_option("--max-rms", opt.max_rms_px, "a final stereo RMS above this is a calibration that diverged, px")
      ->capture_default_str();
  app.add_option("--order-ratio", opt.order_min_ratio,
                 "skip a view unless its best corner order is this many times better than the next")
      ->capture_default_str();
  app.add_option("--summary", summary_path, "summary file (default: summary.json beside the rig file)");
  app.add_option("-j,--threads", opt.num_threads, "corner detection threads (0 = all cores)")->capture_default_str();
  long long max_pixels = io::kDefaultMaxImagePixels;
  util::AddMaxPixelsFlag(&app, &max_pixels);
  util::AddCommonFlags(&app, &quiet);
  if (const auto exit_code = util::ParseCommandLine(&app, argc, argv, quiet)) return *exit_code;

  return util::RunMain([&] {
    io::SetMaxImagePixels(max_pixels);
    if (!opencv_files.empty()) {  // the older spelling of --from opencv
      LN_CHECK_ARG(app.count("--from") == 0 && inputs.empty())
          << "--from-opencv takes the two files itself: give no INPUT or --from";
      inputs = opencv_files;
    }
    const bool importing = app.count("--from") > 0 || !opencv_files.empty();
    if (summary_path.empty()) summary_path = rig_path.parent_path() / "summary.json";
    if (importing) {
      // Import: the rig file from the format's files, the mast pose from the command line.
      calib::RigImportOptions import;
      import.format = from;
      import.files = inputs;
      import.mast = opt.mast;
      import.kitti_pair = kitti_pair;
      LN_CHECK_ARG(app.count("--kitti-pair") == 0 || from == calib::RigFormat::kKitti)
          << "--kitti-pair: only with --from kitti";
      if (!image_size.empty()) import.image_size_px = util::ParseIntPair(image_size, 'x', "--image-size");
      if (from == calib::RigFormat::kOpenCv) {
        LN_CHECK_ARG(app.count("--square") > 0) << "--from opencv needs --square (metres per unit of T)";
        import.metres_per_unit = opt.board.square_size_m;
      }
      const calib::RigImportRun run =
          calib::RunRigImport(import, rig_path, summary_path, util::CommandLineJson(argc, argv));
      LN_LOG(Info) << "calibrate: imported " << calib::ToString(from) << " into " << rig_path.string() << ": "
                   << run.BriefReport();
      return kExitOk;
    }
    LN_CHECK_ARG(inputs.size() == 1) << "give one INPUT_DIR of views (or --from FORMAT FILE...)";
    LN_CHECK_ARG(app.count("--square") > 0) << "--square is required: the side of one square, metres";
    const fs::path& input_dir = inputs[0];
    std::tie(opt.board.cols, opt.board.rows) = util::ParseIntPair(board, 'x', "--board");
    opt.show_progress = !quiet;

    const calib::CalibrationRun run =
        calib::RunCalibration(opt, input_dir, rig_path, summary_path, util::CommandLineJson(argc, argv));
    if (!quiet) std::cout << run.result.Table() << std::flush;
    LN_LOG(Info) << "calibrate: " << run.result.BriefReport();
    LN_LOG(Info) << "rig in " << run.rig_path.string() << ", summary in " << run.summary_path.string();
    return run.result.views_failed > 0 ? kExitBatchPartial : kExitOk;
  });
}
