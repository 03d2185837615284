// opencv_stereo_run: OpenCV's StereoSGBM in stereo-batch's place, for the map benchmarks
// (scripts/bench-map-real): the disparity maps and XYZ arrays of a pair sequence as
// `stereo-batch --rig` writes them, so that terrain-map and `evaluate map --lidar` read them
// unchanged and the map made from OpenCV's matcher stands beside the project's in one table.
//
//   opencv_stereo_run --rig RIG.json --like STEREO_DIR [--threads N] INPUT_DIR OUT_DIR
//
// INPUT_DIR is a pair sequence as stereo-batch reads it (left/ and right/, or KITTI's layouts);
// STEREO_DIR a stereo-batch run of it with that rig, whose summary.json gives the search to
// match: the disparity range (StereoSGBM's numDisparities, rounded up to a multiple of 16) and
// the rig's default search (options.window_selection.from_rig: the distances ahead y_m and
// heights z_m). StereoSGBM is set as stereo_realdata_benchmark measures it (MODE_HH, block 5,
// P1 8 x 25, P2 32 x 25, uniqueness 10, speckle window 100 and range 2) on 8-bit grey images,
// left image the reference. Its disparity is triangulated with the rig
// (calib::TriangulateDisparity) and every point outside the search's distances and heights
// (vehicle frame) is dropped, as stereo-batch's window selection never matches there; the
// points the project's matcher would reject for the vehicle's own pitch and roll are kept (a
// degree on KITTI's cars). Writes OUT_DIR/disparity/<stem>.pfm (+inf: none), xyz/<stem>.exr
// and summary.json (the rig, reference "left", the matcher's settings).
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "calib/stereo_rig_io.h"
#include "calib/triangulation.h"
#include "evaluation/disparity_eval.h"
#include "io/float_array_io.h"
#include "io/image_io.h"
#include "io/json_io.h"
#include "io/stereo_pairs.h"
#include "util/parallel.h"

namespace fs = std::filesystem;
using nlohmann::json;
using namespace lunarnav;

namespace {

constexpr int kBlock = 5;

cv::Mat Grey8(const fs::path& path) {
  const cv::Mat image = io::ReadGreyImage(path);
  cv::Mat grey8;
  image.convertTo(grey8, CV_8U, image.depth() == CV_8U ? 1.0 : 255.0 / 65535.0);
  return grey8;
}

int Run(int argc, char** argv) {
  fs::path rig_path, like, input_dir, output_dir;
  int threads = 2;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--rig" && i + 1 < argc) {
      rig_path = argv[++i];
    } else if (a == "--like" && i + 1 < argc) {
      like = argv[++i];
    } else if (a == "--threads" && i + 1 < argc) {
      threads = std::max(1, std::atoi(argv[++i]));
    } else if (!a.empty() && a[0] == '-') {
      std::cerr << "error: unknown option " << a << "\n";
      return 2;
    } else if (input_dir.empty()) {
      input_dir = a;
    } else if (output_dir.empty()) {
      output_dir = a;
    } else {
      std::cerr << "error: unexpected argument " << a << "\n";
      return 2;
    }
  }
  if (rig_path.empty() || like.empty() || output_dir.empty()) {
    std::cerr << "usage: opencv_stereo_run --rig RIG.json --like STEREO_DIR [--threads N] INPUT_DIR OUT_DIR\n";
    return 2;
  }
  const calib::StereoRig rig = calib::ReadStereoRig(rig_path);
  const json like_options = io::ReadJson(like / "summary.json").at("options");
  const int max_disparity = like_options.at("disparity_range_px").at(1).get<int>();
  const int num_disparities = (max_disparity + 1 + 15) / 16 * 16;
  double y_min = -std::numeric_limits<double>::infinity(), y_max = -y_min, z_min = y_min, z_max = y_max;
  const json& from_rig = like_options.at("window_selection").at("from_rig");
  if (from_rig.is_object()) {
    y_min = from_rig.at("y_m").at(0).get<double>();
    y_max = from_rig.at("y_m").at(1).get<double>();
    z_min = from_rig.at("z_m").at(0).get<double>();
    z_max = from_rig.at("z_m").at(1).get<double>();
  }

  const std::vector<io::PairFiles> pairs = io::ListStereoPairs(input_dir);
  fs::create_directories(output_dir / "disparity");
  fs::create_directories(output_dir / "xyz");
  std::vector<long> points(pairs.size(), 0);
  util::ParallelForEachItem(pairs.size(), threads, [&](std::size_t k) {
    const io::PairFiles& pair = pairs[k];
    if (!pair.problem.empty()) throw std::runtime_error(pair.stem + ": " + pair.problem);
    const cv::Ptr<cv::StereoSGBM> sgbm = cv::StereoSGBM::create(
        0, num_disparities, kBlock, 8 * kBlock * kBlock, 32 * kBlock * kBlock, 0, 0, 10, 100, 2, cv::StereoSGBM::MODE_HH);
    cv::Mat fixed16;
    sgbm->compute(Grey8(pair.left), Grey8(pair.right), fixed16);
    cv::Mat disparity = evaluation::DisparityFromOpenCv(fixed16);
    cv::Mat xyz = calib::TriangulateDisparity(rig, disparity, calib::ReferenceImage::kLeft);
    constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
    for (int y = 0; y < xyz.rows; ++y) {
      auto* p = xyz.ptr<cv::Vec3f>(y);
      auto* d = disparity.ptr<float>(y);
      for (int x = 0; x < xyz.cols; ++x) {
        const bool inside = std::isfinite(p[x][0]) && p[x][1] >= y_min && p[x][1] <= y_max && p[x][2] >= z_min &&
                            p[x][2] <= z_max;
        if (!inside) {
          p[x] = cv::Vec3f(kNaN, kNaN, kNaN);
          d[x] = std::numeric_limits<float>::infinity();
        } else {
          ++points[k];
        }
      }
    }
    io::WriteImageAtomic(output_dir / "disparity" / (pair.stem + ".pfm"), disparity);
    io::WriteExrAtomic(output_dir / "xyz" / (pair.stem + ".exr"), xyz, {}, {{"lunarnav:units", "m"}});
  });
  long total = 0;
  for (long n : points) total += n;
  const json summary = {
      {"tool", "opencv_stereo_run"},
      {"input_dir", input_dir.string()},
      {"like", like.string()},
      {"pairs", pairs.size()},
      {"points", total},
      {"options",
       {{"matcher", "OpenCV StereoSGBM"},
        {"mode", "HH"},
        {"block_size", kBlock},
        {"p1", 8 * kBlock * kBlock},
        {"p2", 32 * kBlock * kBlock},
        {"uniqueness_ratio", 10},
        {"speckle_window_size", 100},
        {"speckle_range", 2},
        {"num_disparities", num_disparities},
        {"search_y_m", {y_min, y_max}},
        {"search_z_m", {z_min, z_max}},
        {"reference", calib::ToString(calib::ReferenceImage::kLeft)},
        {"geometry", {{"rig", calib::StereoRigToJson(rig)}}}}}};
  io::WriteJsonAtomic(output_dir / "summary.json", summary);
  std::cerr << "opencv_stereo_run: " << pairs.size() << " pairs, " << total << " points\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return Run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 3;
  }
}
