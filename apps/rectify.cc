// rectify: raw stereo image-pair sequences -> rectified pairs (epipolar lines = rows) and
// the rectified rig file. docs/rectify.md describes every option and output.
#include <filesystem>
#include <string>

#include "calib/rectify_batch.h"
#include "calib/stereo_rig_io.h"
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
      "Rectifies the raw stereo pairs of INPUT_DIR/left and INPUT_DIR/right (same file stems)\n"
      "with the rig's calibration: writes OUT_DIR/left/<stem>.png, OUT_DIR/right/<stem>.png,\n"
      "the rectified rig OUT_DIR/rig.json (for stereo-batch --rig) and summary.json.\n"
      "Exit codes: 0 ok, 1 internal error, 2 usage, 3 bad input, 4 some pairs failed."};
  calib::RectifyBatchOptions opt;
  fs::path input_dir, output_dir, rig_path;
  std::string shard;
  double alpha = -1.0;
  bool quiet = false;
  app.add_option("INPUT_DIR", input_dir, "directory holding left/ and right/")->required();
  app.add_option("-o,--output", output_dir, "output directory (created)")->required();
  app.add_option("--rig", rig_path, "rig file (lunarnav.rig/1 JSON, docs/formats.md)")->required();
  app.add_option("--alpha", alpha,
                 "rectify anew: 0 keeps only pixels seen by both cameras, 1 every raw pixel "
                 "(default: the rig's own rectification, or 0 when it has none)");
  app.add_option("--format", opt.image_format, "output image format (lossless)")
      ->check(CLI::IsMember({"png", "tif"}))
      ->capture_default_str();
  util::AddBatchFlags(&app, "skip pairs whose two outputs exist (same rectified rig)", &opt.resume, &shard,
                     &opt.num_threads);
  long long max_pixels = io::kDefaultMaxImagePixels;
  util::AddMaxPixelsFlag(&app, &max_pixels);
  util::AddCommonFlags(&app, &quiet);
  if (const auto exit_code = util::ParseCommandLine(&app, argc, argv, quiet)) return *exit_code;

  return util::RunMain([&] {
    io::SetMaxImagePixels(max_pixels);
    if (app.count("--alpha") > 0) opt.alpha = alpha;
    util::ApplyShard(shard, &opt.shard_index, &opt.shard_count);
    opt.show_progress = !quiet;
    const calib::StereoRig rig = calib::ReadStereoRig(rig_path);
    const calib::RectifyBatchSummary summary = calib::RunRectifyBatch(
        opt, rig, rig_path.string(), input_dir, output_dir, util::CommandLineJson(argc, argv));
    LN_LOG(Info) << "rectify: " << summary.BriefReport();
    LN_LOG(Info) << "outputs in " << output_dir.string() << "/{left,right}, rectified rig "
                 << summary.rig_path.string() << ", summary " << summary.summary_path.string();
    return summary.pairs_failed > 0 ? kExitBatchPartial : kExitOk;
  });
}
