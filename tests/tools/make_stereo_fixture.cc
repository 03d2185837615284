// Writes the small rectified pair set in testdata/stereo_pairs (see its README.md):
//   build/tests/tools/make_stereo_fixture testdata/stereo_pairs
// Each pair shows a textured ground plane whose disparity grows towards the bottom of the
// image, as for the paper's tilted mast cameras, and boxes with fronto-parallel faces that
// come nearer from pair to pair. Ground-truth disparity (right reference) goes to
// truth/disparity/<stem>.pfm.
#include <cstdio>
#include <filesystem>
#include <string>

#include <opencv2/core.hpp>

#include "io/image_io.h"
#include "sim/layered_scene.h"

namespace fs = std::filesystem;
using namespace lunarnav;

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_stereo_fixture OUT_DIR\n");
    return 2;
  }
  const fs::path out = argv[1];
  for (int frame = 0; frame < 3; ++frame) {
    sim::LayeredSceneOptions scene;
    scene.width = 640;
    scene.height = 480;
    sim::PlaneLayer ground;
    ground.d0_px = 8.0;
    ground.slope_y = 0.1;  // 8 px at the top row, 56 px at the bottom
    ground.texture_scale_px = 2.5;
    ground.contrast = 45;
    ground.seed = 11 + frame;
    // A box stands on the ground: its face ends at the row where the ground has its disparity.
    auto base_row = [&](double d) { return (d - ground.d0_px) / ground.slope_y; };
    sim::PlaneLayer near_box;
    near_box.d0_px = 36.3 + 4.0 * frame;
    near_box.support_right =
        cv::Rect2d(120 + 10 * frame, base_row(near_box.d0_px) - 110, 140, 110);
    near_box.seed = 40 + frame;
    near_box.mean = 110;
    sim::PlaneLayer far_box;
    far_box.d0_px = 24.6 + 2.0 * frame;
    far_box.support_right = cv::Rect2d(400 - 8 * frame, base_row(far_box.d0_px) - 70, 120, 70);
    far_box.seed = 60 + frame;
    far_box.mean = 150;
    scene.layers = {ground, near_box, far_box};
    scene.noise_sigma = 1.5;
    scene.left_gain = 1.06;  // the two auto-iris lenses never agree exactly
    scene.left_offset = -5.0;
    scene.noise_seed = 100 + frame;
    const sim::RenderedPair pair = sim::RenderLayeredPair(scene);
    char stem[32];
    std::snprintf(stem, sizeof(stem), "frame%04d", frame);
    io::WriteImageAtomic(out / "left" / (std::string(stem) + ".png"), pair.left);
    io::WriteImageAtomic(out / "right" / (std::string(stem) + ".png"), pair.right);
    cv::Mat truth16;
    pair.disparity_right_px.convertTo(truth16, CV_16U, 256.0);  // NaN -> 0 (invalid)
    io::WriteImageAtomic(out / "truth" / "disparity" / (std::string(stem) + ".png"), truth16);
  }
  return 0;
}
