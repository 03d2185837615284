#include "sim/chessboard_sim.h"

#include <sstream>
#include <vector>

#include <tbb/task_arena.h>

#include "io/atomic_file.h"
#include "io/json_io.h"
#include "sim/stereo_sim.h"
#include "util/check.h"
#include "util/log.h"
#include "util/parallel.h"
#include "util/summary.h"
#include "util/timer.h"

namespace lunarnav::sim {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// The stereo simulator's options carrying this session's rig, for MakeSimulatedRig.
StereoSimOptions RigOptions(const ChessboardSimOptions& o) {
  StereoSimOptions s;
  s.width_px = o.width_px;
  s.height_px = o.height_px;
  s.focal_px = o.focal_px;
  s.baseline_m = o.baseline_m;
  s.mast_height_m = o.mast_height_m;
  s.tilt_deg = o.tilt_deg;
  s.lens_distortion = o.lens_distortion;
  s.camera_rotation = o.camera_rotation;
  return s;
}

json RigSummary(const calib::StereoRig& rig) {
  auto camera = [](const calib::CameraIntrinsics& c) {
    return json{{"fx_px", c.K(0, 0)}, {"fy_px", c.K(1, 1)}, {"cx_px", c.K(0, 2)}, {"cy_px", c.K(1, 2)},
                {"distortion", c.distortion}};
  };
  return {{"size_px", {rig.width_px, rig.height_px}},
          {"left", camera(rig.left)},
          {"right", camera(rig.right)},
          {"baseline_m", rig.BaselineM()},
          {"mast_height_m", rig.mast.height_m},
          {"tilt_deg", rig.mast.tilt_deg}};
}

}  // namespace

ChessboardViewsOptions ChessboardSimOptions::DefaultViews() {
  ChessboardViewsOptions v;
  v.num_views = 15;
  v.noise_sigma = 1.0;
  return v;
}

void ChessboardSimOptions::Validate() const {
  RigOptions(*this).Validate();
  views.Validate();
  LN_CHECK_ARG(num_threads >= 0) << "threads: must be >= 0";
}

json ChessboardSimOptions::ToJson() const {
  return {{"size_px", {width_px, height_px}},
          {"focal_px", focal_px},
          {"baseline_m", baseline_m},
          {"mast_height_m", mast_height_m},
          {"tilt_deg", tilt_deg},
          {"lens_distortion", lens_distortion},
          {"camera_rotation", camera_rotation},
          {"views", views.ToJson()}};
}

calib::StereoRig MakeChessboardRig(const ChessboardSimOptions& options) {
  return MakeSimulatedRig(RigOptions(options));
}

std::string ChessboardSimSummary::BriefReport() const {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(2);
  s << views << " view" << (views == 1 ? "" : "s") << "; " << seconds << " s (rendering " << render_seconds << " s, writing " << write_seconds << " s)";
  return s.str();
}

ChessboardSimSummary RunChessboardSimulation(const ChessboardSimOptions& options, const fs::path& output_dir,
                                             const json& invocation) {
  options.Validate();
  util::Timer total;
  ChessboardSimSummary summary;
  const calib::StereoRig rig = MakeChessboardRig(options);

  io::CreateOutputDirectory(output_dir);  // before the work, not after it
  for (const fs::path& dir : {output_dir, output_dir / "left", output_dir / "right"}) {
    io::CreateOutputDirectory(dir);
    io::RemoveStaleTempFiles(dir);
  }

  const int threads = util::EffectiveThreadCount(options.num_threads);
  tbb::task_arena arena(threads);
  // The poses are all placed before any image is rendered, so a board too large for the
  // images fails fast.
  util::Timer timer;
  std::vector<ChessboardView> views;
  arena.execute([&] { views = GenerateChessboardViews(rig, options.views); });
  summary.render_seconds = timer.ElapsedSeconds();
  timer.Restart();
  WriteChessboardViews(output_dir, rig, options.views, views);
  summary.write_seconds = timer.ElapsedSeconds();
  summary.views = static_cast<int>(views.size());

  json stems = json::array();
  for (int k = 0; k < summary.views; ++k) stems.push_back(ChessboardViewStem(k));
  summary.seconds = total.ElapsedSeconds();
  summary.summary_path = output_dir / "summary.json";
  const calib::ChessboardSpec& board = options.views.board;
  nlohmann::json head = util::SummaryHead("simulate", invocation);
  head["subcommand"] = "chessboard";
  nlohmann::json body = {{"output_dir", output_dir.string()},
                       {"options", options.ToJson()},
                       {"seed", options.views.seed},
                       {"rig", RigSummary(rig)},
                       {"threads", threads},
                       {"outputs", {"left/", "right/", "rig.json", "truth.json"}},
                       {"counts", {{"views", summary.views},
                                   {"images", 2 * summary.views},
                                   {"corners_per_image", board.CornerCount()}}},
                       {"stems", stems},
                       {"timings_s", {{"render", summary.render_seconds},
                                      {"write", summary.write_seconds},
                                      {"total", summary.seconds}}}};
  head.update(body);
  io::WriteJsonAtomic(summary.summary_path, head);
  return summary;
}

}  // namespace lunarnav::sim
