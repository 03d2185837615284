// Writes synthetic chessboard stereo views of a rig like the paper's, for trying `calibrate`
// (docs/calibrate.md) until `simulate chessboard` exists:
//   build/tests/tools/make_chessboard_views OUT_DIR [VIEWS [SEED]]
// OUT_DIR/left, OUT_DIR/right (view_000.png, ...), OUT_DIR/rig.json (the true rig) and
// OUT_DIR/truth.json (poses and exact corners); 640 x 480, 740 px focal length, 0.9 m
// baseline, k1 = -0.12, a 9x6 board of 0.1 m squares at 2-5 m, 1 grey level of noise.
#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include "calib/paper_rig.h"
#include "sim/chessboard_views.h"

using namespace lunarnav;

int main(int argc, char** argv) {
  if (argc < 2 || argc > 4) {
    std::fprintf(stderr, "usage: make_chessboard_views OUT_DIR [VIEWS [SEED]]\n");
    return 2;
  }
  sim::ChessboardViewsOptions options;
  options.num_views = argc > 2 ? std::atoi(argv[2]) : 12;
  options.seed = argc > 3 ? static_cast<std::uint32_t>(std::atoi(argv[3])) : 1;
  options.noise_sigma = 1.0;
  const calib::StereoRig rig = calib::testing::PaperRig();
  sim::WriteChessboardViews(argv[1], rig, options, sim::GenerateChessboardViews(rig, options));
  return 0;
}
