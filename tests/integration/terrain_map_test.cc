// terrain-map and plan-windows end to end on synthetic stereo-batch outputs (a plane with a box,
// seen from known poses).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/paper_rig.h"
#include "calib/rectified_rig.h"
#include "calib/rectify.h"
#include "calib/stereo_rig_io.h"
#include "integration/run_tool.h"
#include "io/atomic_file.h"
#include "io/float_array_io.h"
#include "io/geotiff_io.h"
#include "io/image_io.h"
#include "io/json_io.h"
#include "io/ply_io.h"
#include "mapping/elevation_error.h"
#include "mapping/frame_poses.h"
#include "mapping/synthetic_frames.h"
#include "mapping/window_planner.h"
#include "positioning/trajectory_io.h"
#include "sim/layered_scene.h"
#include "stereo/window_requests.h"
#include "util/format.h"
#include "util/testing.h"

namespace lunarnav {
namespace {
namespace fs = std::filesystem;
using testing::RunTool;

constexpr double kGround = 0.3;  // m, arbitrary

// Frame k of a run north at 0.48 m per frame (the paper's 0.15 m/s every 3.2 s).
mapping::FramePose PoseOf(int k) {
  mapping::FramePose p;
  char stem[16];
  std::snprintf(stem, sizeof stem, "%06d", k);
  p.stem = stem;
  p.t_s = 3.2 * k;
  p.y_m = 0.48 * k;
  p.z_m = kGround;
  return p;
}

// A stereo-batch-like directory with frames [first, last): xyz/ and xyz_sigma/.
void WriteStereoDir(const fs::path& dir, int first, int last) {
  const auto surface = mapping::testing::BoxOnPlane(kGround, 1.0, 1.5, 6.0, 6.5, 0.3);
  for (int k = first; k < last; ++k) {
    const mapping::FramePose p = PoseOf(k);
    const cv::Mat xyz = mapping::testing::SurfaceXyz(surface, p, 240, 160);
    io::WriteExrAtomic(dir / "xyz" / (p.stem + ".exr"), xyz);
    io::WriteExrAtomic(dir / "xyz_sigma" / (p.stem + ".exr"), cv::Mat(xyz.size(), CV_32FC3, cv::Scalar::all(0.02)));
  }
}

// Rectified pairs 0..n-1 (PoseOf's stems) of a sloping plane for a 160 x 120 rig, in
// DIR/left and DIR/right: what stereo-batch then matches.
void WriteSlopingPlanePairs(const fs::path& dir, int n) {
  for (const char* side : {"left", "right"}) fs::create_directories(dir / side);
  sim::LayeredSceneOptions scene;
  scene.width = 160;
  scene.height = 120;
  sim::PlaneLayer plane;
  plane.d0_px = 20;
  plane.slope_y = 0.3;
  scene.layers = {plane};
  const sim::RenderedPair pair = sim::RenderLayeredPair(scene);
  for (int k = 0; k < n; ++k) {
    const std::string stem = PoseOf(k).stem;
    cv::imwrite((dir / "left" / (stem + ".png")).string(), pair.left);
    cv::imwrite((dir / "right" / (stem + ".png")).string(), pair.right);
  }
}

void WritePoses(const fs::path& path, int n, int nan_at = -1, int missing = -1) {
  std::string s = "stem,t_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg,fault\n";
  for (int k = 0; k < n; ++k) {
    if (k == missing) continue;
    const mapping::FramePose p = PoseOf(k);
    s += p.stem + "," + std::to_string(p.t_s) + ",0," + (k == nan_at ? std::string("nan") : std::to_string(p.y_m)) +
         "," + std::to_string(p.z_m) + ",0,0,0,none\n";
  }
  io::WriteFileAtomic(path, s);
}

// posfilter's trajectory.csv at 10 Hz along PoseOf's straight line (DIR/trajectory.csv) and
// the frame times of pairs 0..n-1 (DIR/times.csv); with `nosed_up_pair`, the trajectory's
// pitch is 1.5 deg around that pair's time (inclinometers reading an acceleration).
void WriteTrajectoryAndTimes(const fs::path& dir, int n, int nosed_up_pair = -1) {
  std::vector<positioning::TrajectorySample> samples;
  for (int k = 0; k <= 100; ++k) {
    positioning::TrajectorySample s;
    s.t_s = 0.1 * k;
    s.y_m = 0.15 * s.t_s;
    s.z_m = kGround;
    if (nosed_up_pair >= 0 && std::abs(s.t_s - PoseOf(nosed_up_pair).t_s) < 0.45) s.pitch_rad = 1.5 * M_PI / 180;
    samples.push_back(s);
  }
  positioning::WriteTrajectoryCsv(dir / "trajectory.csv", samples);
  std::string times = "stem,t_s\n";
  for (int k = 0; k < n; ++k) times += PoseOf(k).stem + "," + std::to_string(PoseOf(k).t_s) + "\n";
  io::WriteFileAtomic(dir / "times.csv", times);
}

cv::Mat Band(const io::GeoRaster& r, const std::string& name) {
  const int i = r.BandIndex(name);
  EXPECT_GE(i, 0) << name;
  return i >= 0 ? r.bands[i].pixels : cv::Mat();
}

TEST(TerrainMapTool, AtItsDefaultsWithTheRigABoxSeenWithItsFacesIsTheOnlyObstacle) {
  // What a user runs: the rig, every rule at its default (support, visibility, gate, carving,
  // hidden observations). Four pairs of the paper's rig rendered with what stands in front
  // hiding what lies behind (the box's faces seen), the box 0.3 m tall at x 1-1.5, y 6-6.5.
  util::ScopedTempDir tmp;
  const calib::StereoRig rig = calib::RectifyRig(calib::testing::PaperRig(), 0.0);
  const fs::path rig_file = tmp.path() / "rig.json";
  calib::WriteStereoRig(rig_file, rig);
  const Eigen::Vector3d camera =
      mapping::ElevationErrorModel(rig, calib::ReferenceImage::kRight, 1.0).ReferenceCamera();
  const auto surface = mapping::testing::BoxOnPlane(kGround, 1.0, 1.5, 6.0, 6.5, 0.3);
  for (int k = 0; k < 4; ++k) {
    const mapping::FramePose p = PoseOf(k);
    io::WriteExrAtomic(tmp.path() / "stereo" / "xyz" / (p.stem + ".exr"),
                       mapping::testing::RenderedXyz(surface, p, camera, 160, 240));
  }
  WritePoses(tmp.path() / "poses.csv", 4);
  const fs::path out = tmp.path() / "map";
  const auto run = RunTool("terrain-map",
                           {(tmp.path() / "stereo").string(), "--poses", (tmp.path() / "poses.csv").string(), "--rig",
                            rig_file.string(), "-o", out.string(), "-q"},
                           tmp.path());
  ASSERT_EQ(run.exit_code, 0) << run.stderr_text;
  const io::GeoRaster map = io::ReadGeoTiff(out / "elevation.tif");
  const cv::Mat elevation = Band(map, "elevation_m"), obstacle = Band(map, "obstacle");
  int on_box = 0, elsewhere = 0;
  for (int r = 0; r < elevation.rows; ++r) {
    for (int c = 0; c < elevation.cols; ++c) {
      if (!(obstacle.at<float>(r, c) > 0)) continue;
      const double x = map.CellCentreX(c), y = map.CellCentreY(r);
      if (x > 1.0 && x < 1.5 && y > 6.0 && y < 6.5) {
        ++on_box;
      } else if (!(x > 0.75 && x < 1.75 && y > 5.75 && y < 6.75)) {  // (its faces lie on cell edges)
        ++elsewhere;
      }
    }
  }
  EXPECT_GE(on_box, 2);  // its front row at least (the ground behind it is hidden)
  EXPECT_EQ(elsewhere, 0);
  const mapping::MapLayers layers = mapping::ReadMapElevation(out, false);
  int col = 0, row = 0;
  ASSERT_TRUE(layers.CellOf(1.125, 6.375, &col, &row));  // a cell of its top (the front one holds its face too)
  EXPECT_NEAR(layers.elevation_m.at<float>(row, col), kGround + 0.3, 0.02);
  const nlohmann::json summary = io::ReadJson(out / "summary.json");
  EXPECT_EQ(summary["counts"]["carving"]["observations_carved"], 0);  // nothing true is carved
  // Where the time went (docs/performance.md's profile): every stage, in the order it ran.
  std::vector<std::string> stages;
  double seconds = 0;
  for (const nlohmann::json& st : summary["timings_s"]["stages"]) {
    stages.push_back(st["stage"]);
    EXPECT_GE(st["seconds"].get<double>(), 0.0) << stages.back();
    seconds += st["seconds"].get<double>();
  }
  const std::vector<std::string> expected = {"read and check the inputs",
                                             "read the points (CPU)",
                                             "transform, bin and the per-pair rules (CPU)",
                                             "add to the grid",
                                             "layers (carving, obstacles)",
                                             "write elevation.tif",
                                             "write state.tif",
                                             "write frames.csv and preview.png"};
  EXPECT_EQ(stages, expected);
  EXPECT_GT(seconds, 0.0);
}

TEST(TerrainMapTool, WritesAGeoTiffOfThePlaneWithTheBoxAsTheOnlyObstacle) {
  util::ScopedTempDir tmp;
  WriteStereoDir(tmp.path() / "stereo", 0, 4);
  WritePoses(tmp.path() / "poses.csv", 4);
  const fs::path out = tmp.path() / "map";
  // The synthetic frames put their points on a ground grid, not on an image's rays: the box's
  // face is in none of them, so the support rule (which asks for it) is off here.
  const auto run = RunTool("terrain-map", {(tmp.path() / "stereo").string(), "--poses",
                                           (tmp.path() / "poses.csv").string(), "-o", out.string(), "-q",
                                           "--support-rise", "inf"},
                           tmp.path());
  ASSERT_EQ(run.exit_code, 0) << run.stderr_text;
  const io::GeoRaster map = io::ReadGeoTiff(out / "elevation.tif");
  EXPECT_DOUBLE_EQ(map.cell_m, 0.25);
  ASSERT_EQ(map.bands.size(), 9u);
  const cv::Mat elevation = Band(map, "elevation_m"), obstacle = Band(map, "obstacle");
  int mapped = 0, obstacles = 0;
  for (int r = 0; r < elevation.rows; ++r) {
    for (int c = 0; c < elevation.cols; ++c) {
      const float e = elevation.at<float>(r, c);
      if (!std::isfinite(e)) continue;
      ++mapped;
      const double x = map.CellCentreX(c), y = map.CellCentreY(r);
      const bool in_box = x > 1.0 && x < 1.5 && y > 6.0 && y < 6.5;
      EXPECT_NEAR(e, in_box ? kGround + 0.3 : kGround, 1e-4) << x << ", " << y;
      obstacles += obstacle.at<float>(r, c) > 0;
      if (obstacle.at<float>(r, c) > 0) {
        EXPECT_TRUE(in_box) << x << ", " << y;
      }
    }
  }
  EXPECT_EQ(obstacles, 4);  // 0.5 m x 0.5 m = 2 x 2 cells
  // 6 m wide; every cell a pair saw (--min-frames 1): from 2 m ahead of the first pose to 10 m
  // ahead of the last (1.44 m further).
  EXPECT_EQ(mapped, 24 * static_cast<int>(std::lround((8 + 1.44) / 0.25)));
  {
    // With --min-frames 2, the cells two pairs saw: from 2 m ahead of the second pose (0.48 m
    // after the first) to 10 m ahead of the third (0.96 m after the first).
    const fs::path two = tmp.path() / "map_two";
    const auto run = RunTool("terrain-map", {(tmp.path() / "stereo").string(), "--poses",
                                             (tmp.path() / "poses.csv").string(), "-o", two.string(), "-q",
                                             "--support-rise", "inf", "--min-frames", "2", "--no-preview"},
                             tmp.path());
    ASSERT_EQ(run.exit_code, 0) << run.stderr_text;
    const cv::Mat e2 = Band(io::ReadGeoTiff(two / "elevation.tif"), "elevation_m");
    EXPECT_EQ(cv::countNonZero(e2 == e2), 24 * static_cast<int>(std::lround((10 + 0.96 - (2 + 0.48)) / 0.25)));
  }
  {
    // The preview draws each obstacle cell as a square of scale x scale pixels in the
    // obstacle red, and the legend's swatch (20 x 12 px) in the same red: the box's 2 x 2
    // cells are the only red of the map, one square 2 scale wide.
    const cv::Mat preview = cv::imread((out / "preview.png").string(), cv::IMREAD_COLOR);
    ASSERT_FALSE(preview.empty());
    const cv::Mat red = [&] {
      cv::Mat m;
      cv::inRange(preview, cv::Scalar(30, 30, 230), cv::Scalar(30, 30, 230), m);
      return m;
    }();
    const int swatch = 20 * 12;
    const int box_px = cv::countNonZero(red) - swatch;
    const int scale = static_cast<int>(std::lround(std::sqrt(box_px / 4.0)));
    ASSERT_GE(scale, 1);
    EXPECT_EQ(box_px, 4 * scale * scale);
    // The legend lies right of the map: the red of the map is the square's bounding box.
    const cv::Mat map_red = red(cv::Rect(0, 0, preview.cols - 170, preview.rows));
    const cv::Rect box = cv::boundingRect(map_red);
    EXPECT_EQ(box.width, 2 * scale);
    EXPECT_EQ(box.height, 2 * scale);
  }
  const nlohmann::json summary = io::ReadJson(out / "summary.json");
  EXPECT_EQ(summary["tool"], "terrain-map");
  EXPECT_EQ(summary["counts"]["frames_fused"], 4);
  EXPECT_EQ(summary["counts"]["obstacle_cells"], 4);
  // GDAL's own tool reads it (gdal-bin is installed by scripts/setup: a missing gdalinfo is a
  // broken setup, not a reason to skip).
  const std::string cmd = "gdalinfo " + testing::ShellQuote((out / "elevation.tif").string()) + " > " +
                          testing::ShellQuote((tmp.path() / "gdalinfo.txt").string());
  ASSERT_EQ(std::system(cmd.c_str()), 0) << "gdalinfo failed or is missing (scripts/setup installs gdal-bin)";
  const std::string info = testing::ReadFileBytes(tmp.path() / "gdalinfo.txt");
  EXPECT_NE(info.find("Description = elevation_m"), std::string::npos) << info;
  EXPECT_NE(info.find("Pixel Size = (0.250000000000000,-0.250000000000000)"), std::string::npos) << info;
  EXPECT_NE(info.find("NoData Value=nan"), std::string::npos) << info;
}

struct BadCase {
  std::string name;
  int nan_at = -1, missing = -1;
  bool wrong_sigma = false;
  std::string stem;
};

TEST(TerrainMapTool, BadInputsNameTheStemExitThreeAndWriteNothing) {
  for (const BadCase& c : {BadCase{"missing pose", -1, 2, false, "000002"}, BadCase{"NaN pose", 1, -1, false, "000001"},
                           BadCase{"wrong-size sigma", -1, -1, true, "000003"}}) {
    util::ScopedTempDir tmp;
    WriteStereoDir(tmp.path() / "stereo", 0, 4);
    WritePoses(tmp.path() / "poses.csv", 4, c.nan_at, c.missing);
    if (c.wrong_sigma) {
      io::WriteExrAtomic(tmp.path() / "stereo" / "xyz_sigma" / "000003.exr", cv::Mat(10, 10, CV_32FC3, cv::Scalar::all(0.02)));
    }
    const fs::path out = tmp.path() / "map";
    const auto run = RunTool("terrain-map", {(tmp.path() / "stereo").string(), "--poses",
                                             (tmp.path() / "poses.csv").string(), "-o", out.string(), "-q"},
                             tmp.path());
    EXPECT_EQ(run.exit_code, 3) << c.name << ": " << run.stderr_text;
    EXPECT_EQ(run.ErrorLines(), 1) << c.name << ": " << run.stderr_text;
    EXPECT_NE(run.stderr_text.find("stem " + c.stem), std::string::npos) << c.name << ": " << run.stderr_text;
    EXPECT_FALSE(fs::exists(out)) << c.name;
  }
}

// Giant grids: one pose 200 km from the others made a 2.2 GB raster (exit 0), one at 1e12 m
// left files under their final names. A pair that would make the map larger than its limit
// (2^22 cells, --max-map-cells) and a pose beyond 1,000 km of the origin are bad input naming
// the stem and the limit, refused before anything is written, in moments.
TEST(TerrainMapTool, APoseFarFromTheOthersIsRefusedBeforeAGiantMapIsMade) {
  util::ScopedTempDir tmp;
  WriteStereoDir(tmp.path() / "stereo", 0, 4);
  struct Far {
    const char* name;
    double x_m;
    std::vector<std::string> extra;
    std::string words;
  };
  for (const Far& c : {Far{"200 km east", 2e5, {}, "more than the largest map's 4194304 cells"},
                       Far{"1e12 m east", 1e12, {}, "beyond 1000 km of the world origin"},
                       Far{"a small limit", 0, {"--max-map-cells", "100"}, "more than the largest map's 100 cells"}}) {
    std::string poses = "stem,t_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg\n";
    for (int k = 0; k < 4; ++k) {
      const mapping::FramePose p = PoseOf(k);
      poses += p.stem + "," + std::to_string(p.t_s) + "," + (k == 2 ? util::Format("%.17g", c.x_m) : "0") + "," +
               std::to_string(p.y_m) + "," + std::to_string(p.z_m) + ",0,0,0\n";
    }
    io::WriteFileAtomic(tmp.path() / "poses.csv", poses);
    const fs::path out = tmp.path() / "map";
    std::vector<std::string> args = {(tmp.path() / "stereo").string(), "--poses", (tmp.path() / "poses.csv").string(),
                                     "-o", out.string(), "-q"};
    args.insert(args.end(), c.extra.begin(), c.extra.end());
    const auto run = RunTool("terrain-map", args, tmp.path());
    EXPECT_EQ(run.exit_code, 3) << c.name << ": " << run.stderr_text;
    EXPECT_EQ(run.ErrorLines(), 1) << c.name << ": " << run.stderr_text;
    EXPECT_NE(run.stderr_text.find(c.x_m > 0 ? "stem 000002" : "stem 00000"), std::string::npos)
        << c.name << ": " << run.stderr_text;
    EXPECT_NE(run.stderr_text.find(c.words), std::string::npos) << c.name << ": " << run.stderr_text;
    EXPECT_FALSE(fs::exists(out)) << c.name;
  }
}

// Silent acceptance: all-NaN XYZ arrays made an empty map with exit 0 and not a word, and a
// PNG named .exr was read as XYZ. Now the empty map is said (a warning, in summary.json too)
// and the PNG is bad input naming the file.
TEST(TerrainMapTool, SaysWhenNothingIsMappedAndRefusesAnotherFormatNamedExr) {
  util::ScopedTempDir tmp;
  WriteStereoDir(tmp.path() / "stereo", 0, 2);
  WritePoses(tmp.path() / "poses.csv", 2);
  for (const char* stem : {"000000", "000001"}) {
    io::WriteExrAtomic(tmp.path() / "stereo" / "xyz" / (std::string(stem) + ".exr"),
                       cv::Mat(160, 240, CV_32FC3, cv::Scalar::all(std::numeric_limits<float>::quiet_NaN())));
  }
  const fs::path out = tmp.path() / "map";
  const std::vector<std::string> args = {(tmp.path() / "stereo").string(), "--poses",
                                         (tmp.path() / "poses.csv").string(), "-o", out.string(), "-q"};
  const auto empty = RunTool("terrain-map", args, tmp.path());
  EXPECT_EQ(empty.exit_code, 0) << empty.stderr_text;
  EXPECT_NE(empty.stderr_text.find("warning: 2 of 2 pairs had no valid point"), std::string::npos) << empty.stderr_text;
  EXPECT_NE(empty.stderr_text.find("nothing was mapped"), std::string::npos) << empty.stderr_text;
  EXPECT_FALSE(fs::exists(out / "elevation.tif"));
  const nlohmann::json summary = io::ReadJson(out / "summary.json");
  EXPECT_EQ(summary["counts"]["frames_without_points"], 2);
  EXPECT_EQ(summary["warnings"].size(), 2u);
  // A PNG under an .exr name.
  fs::remove_all(out);
  cv::imwrite((tmp.path() / "stereo" / "xyz" / "000001.png").string(), cv::Mat(160, 240, CV_8UC3, cv::Scalar::all(9)));
  fs::rename(tmp.path() / "stereo" / "xyz" / "000001.png", tmp.path() / "stereo" / "xyz" / "000001.exr");
  const auto png = RunTool("terrain-map", args, tmp.path());
  EXPECT_EQ(png.exit_code, 3) << png.stderr_text;
  EXPECT_NE(png.stderr_text.find("000001.exr: not an OpenEXR file: no OpenEXR magic number, a PNG's"), std::string::npos)
      << png.stderr_text;
  EXPECT_FALSE(fs::exists(out));
}

// A window of no size is a usage error naming the option (it was taken for "no window").
TEST(TerrainMapTool, AWindowOfNoSizeIsAUsageError) {
  util::ScopedTempDir tmp;
  WriteStereoDir(tmp.path() / "stereo", 0, 2);
  WritePoses(tmp.path() / "poses.csv", 2);
  for (const char* size : {"0", "-5", "nan", "0.5"}) {
    const fs::path out = tmp.path() / "map";
    const auto run = RunTool("terrain-map", {(tmp.path() / "stereo").string(), "--poses",
                                             (tmp.path() / "poses.csv").string(), "--window-m", size, "-o",
                                             out.string(), "-q"},
                             tmp.path());
    EXPECT_EQ(run.exit_code, 2) << size << ": " << run.stderr_text;
    EXPECT_NE(run.stderr_text.find("window-m"), std::string::npos) << run.stderr_text;
    EXPECT_FALSE(fs::exists(out)) << size;
  }
}

// evaluate map: the simulated truth and LiDAR are two sources; an option of the one given
// with the other is a usage error naming it, not silently ignored.
TEST(EvaluateMapTool, OptionsOfTheOtherTruthAreUsageErrors) {
  util::ScopedTempDir tmp;
  const fs::path map = tmp.path() / "map", out = tmp.path() / "eval";
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"--truth", "sim", "--stereo", "stereo"}, {"--truth", "sim", "--lidar-calib", "c.txt"},
        {"--truth", "sim", "--band", "5:10"}, {"--truth", "sim", "--z-range", "-0.5:2"},
        {"--lidar", "velodyne", "--requests", "requests.csv"},
        {"--truth", "sim", "--lidar", "velodyne"}}) {
    std::vector<std::string> all = {"map", map.string()};
    all.insert(all.end(), args.begin(), args.end());
    all.insert(all.end(), {"-o", out.string(), "-q"});
    const auto run = RunTool("evaluate", all, tmp.path());
    EXPECT_EQ(run.exit_code, 2) << args[2] << ": " << run.stderr_text;
    EXPECT_NE(run.stderr_text.find(args[2] == "velodyne" ? "either --truth or --lidar" : args[2]), std::string::npos)
        << run.stderr_text;
    EXPECT_FALSE(fs::exists(out));
  }
}

// The state band by band: equal within rounding of the sums.
void ExpectSameState(const fs::path& a, const fs::path& b) {
  const io::GeoRaster ra = io::ReadGeoTiff(a / "state.tif"), rb = io::ReadGeoTiff(b / "state.tif");
  ASSERT_EQ(ra.Width(), rb.Width());
  ASSERT_EQ(ra.Height(), rb.Height());
  EXPECT_DOUBLE_EQ(ra.x_west_m, rb.x_west_m);
  EXPECT_DOUBLE_EQ(ra.y_north_m, rb.y_north_m);
  for (std::size_t k = 0; k < ra.bands.size(); ++k) {
    cv::Mat diff;
    cv::absdiff(ra.bands[k].pixels, rb.bands[k].pixels, diff);
    double worst = 0, scale = 0;
    cv::minMaxLoc(diff, nullptr, &worst);
    cv::minMaxLoc(cv::abs(ra.bands[k].pixels), nullptr, &scale);
    EXPECT_LE(worst, 1e-12 * std::max(1.0, scale)) << ra.bands[k].description;
  }
}

TEST(TerrainMapTool, ResumeAndMergeOfDisjointFramesEqualFusingAtOnce) {
  util::ScopedTempDir tmp;
  const fs::path all = tmp.path() / "all", first = tmp.path() / "first", second = tmp.path() / "second";
  WriteStereoDir(all, 0, 6);
  WriteStereoDir(first, 0, 3);
  WriteStereoDir(second, 3, 6);
  const std::string poses = (tmp.path() / "poses.csv").string();
  WritePoses(poses, 6);
  auto map = [&](const std::vector<std::string>& args) {
    std::vector<std::string> a = args;
    a.insert(a.end(), {"--poses", poses, "-q", "--no-preview"});
    const auto run = RunTool("terrain-map", a, tmp.path());
    EXPECT_EQ(run.exit_code, 0) << run.stderr_text;
  };
  map({all.string(), "-o", (tmp.path() / "m_all").string()});
  map({first.string(), "-o", (tmp.path() / "m_first").string()});
  map({second.string(), "-o", (tmp.path() / "m_second").string()});
  map({"--merge", (tmp.path() / "m_first").string(), "--merge", (tmp.path() / "m_second").string(), "-o",
       (tmp.path() / "m_merged").string()});
  ExpectSameState(tmp.path() / "m_all", tmp.path() / "m_merged");
  // Shards of the frames (every second one, as a cluster's array tasks run them), each into
  // OUT_DIR/shard-K-of-N, merged: the same map again.
  for (const char* shard : {"0/2", "1/2"}) map({all.string(), "--shard", shard, "-o", (tmp.path() / "sharded").string()});
  EXPECT_EQ(io::ReadJson(tmp.path() / "sharded" / "shard-1-of-2" / "summary.json")["counts"]["frames_fused"], 3);
  map({"--merge", (tmp.path() / "sharded" / "shard-0-of-2").string(), "--merge",
       (tmp.path() / "sharded" / "shard-1-of-2").string(), "-o", (tmp.path() / "sharded" / "map").string()});
  ExpectSameState(tmp.path() / "m_all", tmp.path() / "sharded" / "map");
  // Resume: the first half's map continued over all frames.
  fs::copy(tmp.path() / "m_first", tmp.path() / "m_resumed");
  map({all.string(), "--resume", "-o", (tmp.path() / "m_resumed").string()});
  ExpectSameState(tmp.path() / "m_all", tmp.path() / "m_resumed");
  EXPECT_EQ(io::ReadJson(tmp.path() / "m_resumed" / "summary.json")["counts"]["frames_resumed"], 3);
  // Merging a map with itself fuses frames twice: refused.
  const auto twice = RunTool("terrain-map", {"--merge", (tmp.path() / "m_first").string(), "--merge",
                                             (tmp.path() / "m_first").string(), "-o", (tmp.path() / "m_bad").string()},
                             tmp.path());
  EXPECT_EQ(twice.exit_code, 3);
  EXPECT_NE(twice.stderr_text.find("fused twice"), std::string::npos) << twice.stderr_text;
}

// The sums and the list of frames they hold are committed as one (state.tif): a run killed
// after state.tif's rename and before frames.csv's leaves a frames.csv that lists fewer frames,
// and --resume must still not fuse them twice. Maps made with other fusion values or other
// poses are refused, naming the difference.
std::string FileText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// A run killed at any moment leaves the old state or the new one: killed just before each of
// its commits in turn (every rename of an output file, LUNARNAV_TEST_EXIT_BEFORE_COMMIT), first
// while making a map of three pairs and then while continuing it with a fourth, and run again
// with --resume, the map directory is byte for byte the uninterrupted runs' (summary.json
// aside: timings), with no temporary file left.
TEST(TerrainMapTool, AKillAtEveryCommitPointThenResumeGivesTheUninterruptedMap) {
  util::ScopedTempDir tmp;
  // Pairs 0-2, then 0-3 (the same three and a fourth).
  const fs::path three = tmp.path() / "three", four = tmp.path() / "four";
  WriteStereoDir(three, 0, 3);
  WritePoses(three / "poses.csv", 3);
  WriteStereoDir(four, 0, 4);
  WritePoses(four / "poses.csv", 4);
  auto run = [&](const fs::path& stereo, const fs::path& out, long exit_before_commit) {
    if (exit_before_commit > 0) {
      ::setenv("LUNARNAV_TEST_EXIT_BEFORE_COMMIT", std::to_string(exit_before_commit).c_str(), 1);
    }
    const auto r = RunTool("terrain-map", {stereo.string(), "--poses", (stereo / "poses.csv").string(), "--resume",
                                           "-o", out.string(), "-q", "-j", "1"},
                           tmp.path());
    ::unsetenv("LUNARNAV_TEST_EXIT_BEFORE_COMMIT");
    return r;
  };
  // The uninterrupted runs: three pairs, then the fourth.
  const fs::path first = tmp.path() / "first", second = tmp.path() / "second";
  ASSERT_EQ(run(three, first, 0).exit_code, 0);
  fs::copy(first, second, fs::copy_options::recursive);
  ASSERT_EQ(run(four, second, 0).exit_code, 0);
  const std::vector<std::string> files = testing::DataFiles(second);
  ASSERT_EQ(files, (std::vector<std::string>{"elevation.tif", "frames.csv", "preview.png", "state.tif"}));
  for (const bool continuing : {false, true}) {
    const fs::path& expected = continuing ? second : first;
    int killed = 0;
    for (long k = 1; k < 20; ++k) {
      SCOPED_TRACE((continuing ? "continuing, killed before commit " : "first run, killed before commit ") +
                   std::to_string(k));
      const fs::path out = tmp.path() / ("killed-" + std::to_string(continuing) + "-" + std::to_string(k));
      if (continuing) fs::copy(first, out, fs::copy_options::recursive);
      const auto r = run(continuing ? four : three, out, k);
      if (r.exit_code == 0) break;  // fewer commits than k: done
      ASSERT_EQ(r.exit_code, io::kTestKilledExitCode) << r.stderr_text;
      ++killed;
      const auto resumed = run(continuing ? four : three, out, 0);
      ASSERT_EQ(resumed.exit_code, 0) << resumed.stderr_text;
      ASSERT_EQ(testing::DataFiles(out), files);
      for (const std::string& f : files) {
        EXPECT_TRUE(testing::ReadFileBytes(out / f) == testing::ReadFileBytes(expected / f)) << f;
      }
    }
    EXPECT_GE(killed, 5);  // elevation.tif, state.tif, frames.csv, preview.png, summary.json
  }
}

TEST(TerrainMapTool, ResumeAndMergeCannotDoubleCountOrMixFusions) {
  util::ScopedTempDir tmp;
  const fs::path all = tmp.path() / "all", first = tmp.path() / "first";
  WriteStereoDir(all, 0, 6);
  WriteStereoDir(first, 0, 3);
  const std::string poses = (tmp.path() / "poses.csv").string();
  WritePoses(poses, 6);
  auto run = [&](std::vector<std::string> args, const std::string& pose_file) {
    args.insert(args.end(), {"--poses", pose_file, "-q", "--no-preview"});
    return RunTool("terrain-map", args, tmp.path());
  };
  ASSERT_EQ(run({all.string(), "-o", (tmp.path() / "m_all").string()}, poses).exit_code, 0);
  ASSERT_EQ(run({first.string(), "-o", (tmp.path() / "m_first").string()}, poses).exit_code, 0);
  // The kill: the full map's state with the first half's frames.csv.
  fs::copy(tmp.path() / "m_all", tmp.path() / "m_killed");
  fs::copy_file(tmp.path() / "m_first" / "frames.csv", tmp.path() / "m_killed" / "frames.csv",
                fs::copy_options::overwrite_existing);
  const auto resumed = run({all.string(), "--resume", "-o", (tmp.path() / "m_killed").string()}, poses);
  ASSERT_EQ(resumed.exit_code, 0) << resumed.stderr_text;
  const nlohmann::json summary = io::ReadJson(tmp.path() / "m_killed" / "summary.json");
  EXPECT_EQ(summary["counts"]["frames_resumed"], 6);
  EXPECT_EQ(summary["counts"]["frames_fused"], 0);
  ExpectSameState(tmp.path() / "m_all", tmp.path() / "m_killed");
  // frames.csv, rewritten, keeps each carried frame's counts.
  const std::string frames = FileText(tmp.path() / "m_killed" / "frames.csv");
  EXPECT_EQ(frames, FileText(tmp.path() / "m_all" / "frames.csv"));

  // Another gate: refused naming it (exit 2), nothing written.
  fs::copy(tmp.path() / "m_first", tmp.path() / "m_gate");
  const auto gate = run({all.string(), "--resume", "--gate", "5", "-o", (tmp.path() / "m_gate").string()}, poses);
  EXPECT_EQ(gate.exit_code, 2);
  EXPECT_NE(gate.stderr_text.find("gate_k"), std::string::npos) << gate.stderr_text;
  EXPECT_EQ(io::ReadJson(tmp.path() / "m_gate" / "summary.json")["counts"]["frames_fused"], 3);
  // Another disparity error for --rig's error model: refused naming it (exit 2).
  const std::string rig = util::TestDataPath("boxes").string() + "/rig.json";
  const std::string m_rig = (tmp.path() / "m_rig").string();
  ASSERT_EQ(run({first.string(), "--rig", rig, "--sigma-d", "1", "-o", m_rig}, poses).exit_code, 0);
  const auto sigma = run({all.string(), "--rig", rig, "--sigma-d", "2", "--resume", "-o", m_rig}, poses);
  EXPECT_EQ(sigma.exit_code, 2) << sigma.stderr_text;
  EXPECT_NE(sigma.stderr_text.find("sigma_d 2"), std::string::npos) << sigma.stderr_text;
  EXPECT_EQ(io::ReadJson(fs::path(m_rig) / "summary.json")["counts"]["frames_fused"], 3);
  // Other poses for the frames a map holds: refused naming the stem (exit 3).
  const std::string moved = (tmp.path() / "moved.csv").string();
  std::string text = FileText(poses);
  const std::size_t at = text.find("000001,");
  ASSERT_NE(at, std::string::npos);
  text.replace(text.find(",0,", at), 3, ",0.5,");  // frame 1 half a metre east
  io::WriteFileAtomic(moved, text);
  const auto other = run({all.string(), "--merge", (tmp.path() / "m_first").string(), "--shard", "1/2", "-o",
                          (tmp.path() / "m_other").string()},
                         moved);
  EXPECT_EQ(other.exit_code, 3);
  EXPECT_NE(other.stderr_text.find("stem 000001"), std::string::npos) << other.stderr_text;
  EXPECT_NE(other.stderr_text.find("other poses"), std::string::npos) << other.stderr_text;
}

TEST(TerrainMapTool, ATrajectoryInterpolatedAtTheFrameTimesGivesTheMapOfThePoses) {
  util::ScopedTempDir tmp;
  WriteStereoDir(tmp.path() / "stereo", 0, 4);
  const std::string poses = (tmp.path() / "poses.csv").string();
  WritePoses(poses, 4);
  // posfilter's trajectory.csv at 10 Hz along the same straight line, and the frame times.
  WriteTrajectoryAndTimes(tmp.path(), 4);
  const auto a = RunTool("terrain-map", {(tmp.path() / "stereo").string(), "--poses", poses, "-o",
                                         (tmp.path() / "by_poses").string(), "-q", "--no-preview"},
                         tmp.path());
  const auto b = RunTool("terrain-map", {(tmp.path() / "stereo").string(), "--trajectory",
                                         (tmp.path() / "trajectory.csv").string(), "--frame-times",
                                         (tmp.path() / "times.csv").string(), "-o", (tmp.path() / "by_trajectory").string(),
                                         "-q", "--no-preview", "--align-to-ground", "off"},
                         tmp.path());
  ASSERT_EQ(a.exit_code, 0) << a.stderr_text;
  ASSERT_EQ(b.exit_code, 0) << b.stderr_text;
  const cv::Mat ea = Band(io::ReadGeoTiff(tmp.path() / "by_poses" / "elevation.tif"), "elevation_m");
  const cv::Mat eb = Band(io::ReadGeoTiff(tmp.path() / "by_trajectory" / "elevation.tif"), "elevation_m");
  ASSERT_EQ(ea.size(), eb.size());
  cv::Mat diff;
  cv::absdiff(ea, eb, diff);
  double worst = 0;
  cv::minMaxLoc(diff, nullptr, &worst, nullptr, nullptr, ea == ea);
  EXPECT_LT(worst, 1e-4);  // the trajectory file's 0.1 mm positions
}

TEST(TerrainMapTool, ADeadReckonedPairNosedUpIsBroughtOntoTheGroundTheOthersMapped) {
  // posfilter's trajectory with the inclinometers 1.5 deg off at pair 2 (an acceleration read
  // as tilt): by default (dead reckoning's poses) the pair is aligned to the map of pairs 0-1
  // and the map is the true poses' map; without the alignment the pair tilts its ground.
  util::ScopedTempDir tmp;
  WriteStereoDir(tmp.path() / "stereo", 0, 4);
  const std::string poses = (tmp.path() / "poses.csv").string();
  WritePoses(poses, 4);
  WriteTrajectoryAndTimes(tmp.path(), 4, /*nosed_up_pair=*/2);
  auto map = [&](const std::string& out, std::vector<std::string> extra) {
    std::vector<std::string> args = {(tmp.path() / "stereo").string(), "-o", (tmp.path() / out).string(), "-q",
                                     "--no-preview"};
    args.insert(args.end(), extra.begin(), extra.end());
    const auto run = RunTool("terrain-map", args, tmp.path());
    EXPECT_EQ(run.exit_code, 0) << run.stderr_text;
    return Band(io::ReadGeoTiff(tmp.path() / out / "elevation.tif"), "elevation_m");
  };
  const std::vector<std::string> trajectory = {"--trajectory", (tmp.path() / "trajectory.csv").string(),
                                               "--frame-times", (tmp.path() / "times.csv").string()};
  const cv::Mat truth = map("true", {"--poses", poses});
  const cv::Mat aligned = map("aligned", trajectory);
  std::vector<std::string> off = trajectory;
  off.insert(off.end(), {"--align-to-ground", "off"});
  const cv::Mat tilted = map("tilted", off);
  ASSERT_EQ(truth.size(), aligned.size());
  ASSERT_EQ(truth.size(), tilted.size());
  auto worst = [&](const cv::Mat& m) {
    cv::Mat diff;
    cv::absdiff(truth, m, diff);
    double w = 0;
    cv::minMaxLoc(diff, nullptr, &w, nullptr, nullptr, (truth == truth) & (m == m));
    return w;
  };
  EXPECT_GT(worst(tilted), 0.05);
  EXPECT_LT(worst(aligned), 0.01);
  const std::vector<mapping::FramePose> used = mapping::ReadPosesCsv(tmp.path() / "aligned" / "frames.csv");
  ASSERT_EQ(used.size(), 4u);
  EXPECT_NEAR(used[2].pitch_rad * 180 / M_PI, 0.0, 0.05);
  const nlohmann::json s = io::ReadJson(tmp.path() / "aligned" / "summary.json");
  EXPECT_EQ(s["alignment"]["applied"], 3);  // every pair but the first
  EXPECT_FALSE(io::ReadJson(tmp.path() / "tilted" / "summary.json").contains("alignment"));
}

TEST(PlanWindowsTool, WritesRequestsThatStereoBatchReads) {
  util::ScopedTempDir tmp;
  const std::string poses = (tmp.path() / "poses.csv").string();
  WritePoses(poses, 10);
  const auto run = RunTool("plan-windows", {"--poses", poses, "-o", (tmp.path() / "plan").string(), "-q"}, tmp.path());
  ASSERT_EQ(run.exit_code, 0) << run.stderr_text;
  const std::string csv = testing::ReadFileBytes(tmp.path() / "plan" / "requests.csv");
  EXPECT_EQ(csv.rfind("stem,y_min_m,y_max_m\n000000,", 0), 0u) << csv;
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 11);

  // stereo-batch reads them: ten rectified pairs of a quarter-size paper rig, each matched in
  // its own requested interval.
  const calib::StereoRig rig = calib::testing::IdealRectifiedRig(160, 120, 185);
  const fs::path pairs = tmp.path() / "pairs", rig_file = tmp.path() / "rig.json";
  calib::WriteStereoRig(rig_file, rig);
  WriteSlopingPlanePairs(pairs, 10);
  const fs::path out = tmp.path() / "stereo";
  const auto batch = RunTool("stereo-batch", {pairs.string(), "-o", out.string(), "-q", "--rig", rig_file.string(),
                                              "--requests", (tmp.path() / "plan" / "requests.csv").string()},
                             tmp.path());
  ASSERT_EQ(batch.exit_code, 0) << batch.stderr_text;
  for (const stereo::WindowRequest& r : stereo::ReadWindowRequests(tmp.path() / "plan" / "requests.csv")) {
    const nlohmann::json sidecar = io::ReadJson(out / "disparity" / (r.stem + ".json"));
    const nlohmann::json& window = sidecar["result"]["window"];
    EXPECT_EQ(window["source"], "requests") << r.stem;
    EXPECT_DOUBLE_EQ(window["region"]["y_m"][0].get<double>(), r.y_min_m) << r.stem;
    EXPECT_DOUBLE_EQ(window["region"]["y_m"][1].get<double>(), r.y_max_m) << r.stem;
  }
}

// stereo-batch with a quarter-size paper rig over four rectified pairs of a sloping plane
// (WriteSlopingPlanePairs), in DIR: the rig file, the poses and the run.
struct SlopingPlaneRun {
  calib::StereoRig rig = calib::testing::IdealRectifiedRig(160, 120, 185);
  fs::path pairs, rig_file, stereo;
  std::string poses;
  // terrain-map of INPUT (a stereo run's folder) with these poses and RIG into DIR/OUT; its
  // summary.json.
  nlohmann::json Map(const fs::path& input, const fs::path& rig_path, const fs::path& dir,
                     const std::string& out) const {
    const auto run = RunTool("terrain-map",
                             {input.string(), "--poses", poses, "--rig", rig_path.string(), "-o", (dir / out).string(),
                              "-q", "--no-preview"},
                             dir);
    EXPECT_EQ(run.exit_code, 0) << run.stderr_text;
    return io::ReadJson(dir / out / "summary.json");
  }
};
SlopingPlaneRun RunSlopingPlaneStereo(const fs::path& dir, const std::vector<std::string>& batch_options = {}) {
  SlopingPlaneRun run;
  run.pairs = dir / "pairs";
  run.rig_file = dir / "rig.json";
  run.stereo = dir / "stereo";
  run.poses = (dir / "poses.csv").string();
  calib::WriteStereoRig(run.rig_file, run.rig);
  WriteSlopingPlanePairs(run.pairs, 4);
  WritePoses(run.poses, 4);
  std::vector<std::string> args = {run.pairs.string(), "-o", run.stereo.string(), "-q", "--rig", run.rig_file.string()};
  args.insert(args.end(), batch_options.begin(), batch_options.end());
  const auto batch = RunTool("stereo-batch", args, dir);
  EXPECT_EQ(batch.exit_code, 0) << batch.stderr_text;
  return run;
}

// Every band of two maps' elevation.tif, bit for bit.
void ExpectSameElevationBands(const fs::path& a_dir, const fs::path& b_dir) {
  const io::GeoRaster a = io::ReadGeoTiff(a_dir / "elevation.tif");
  const io::GeoRaster b = io::ReadGeoTiff(b_dir / "elevation.tif");
  ASSERT_EQ(a.bands.size(), b.bands.size());
  for (std::size_t k = 0; k < a.bands.size(); ++k) {
    const cv::Mat& pa = a.bands[k].pixels;
    const cv::Mat& pb = b.bands[k].pixels;
    ASSERT_EQ(pa.size(), pb.size());
    EXPECT_EQ(std::memcmp(pa.ptr(), pb.ptr(), pa.total() * pa.elemSize()), 0) << a.bands[k].description;
  }
}

TEST(TerrainMapTool, WithTheRigThePointsComeFromTheDisparityMapsAndAreTheXyzArrays) {
  // stereo-batch on four rectified pairs of a quarter-size paper rig (a sloping plane), then
  // terrain-map with that rig: it triangulates the disparity maps itself, and the map is the one
  // the XYZ arrays make, bit for bit; with another rig it says so and reads the arrays.
  util::ScopedTempDir tmp;
  const SlopingPlaneRun sloping = RunSlopingPlaneStereo(tmp.path());
  ASSERT_FALSE(::testing::Test::HasFailure());
  const calib::StereoRig& rig = sloping.rig;
  const fs::path& rig_file = sloping.rig_file;
  const fs::path& stereo = sloping.stereo;
  const std::string& poses = sloping.poses;
  auto map = [&](const fs::path& dir, const fs::path& rig_path, const std::string& out) {
    return sloping.Map(dir, rig_path, tmp.path(), out);
  };
  const nlohmann::json from_disparity = map(stereo, rig_file, "m_disparity");
  EXPECT_EQ(from_disparity["inputs"]["points"], "disparity maps triangulated with the rig");
  EXPECT_EQ(from_disparity["inputs"]["points_check"], "stereo-batch's summary.json records this rig and reference image");
  // stereo-batch's summary recording this rig is the check: the XYZ arrays are not read (the
  // first pair's, damaged, changes nothing). Without the summary the first pair's array is
  // compared with the triangulation: damaged, it is bad input naming the file.
  const fs::path damaged_dir = tmp.path() / "damaged_dir";
  fs::copy(stereo, damaged_dir, fs::copy_options::recursive);
  const fs::path first_xyz = damaged_dir / "xyz" / (PoseOf(0).stem + ".exr");
  ASSERT_TRUE(fs::exists(first_xyz));
  { std::ofstream(first_xyz, std::ios::binary | std::ios::trunc) << "not an EXR file"; }
  const nlohmann::json from_damaged = map(damaged_dir, rig_file, "m_damaged");
  EXPECT_EQ(from_damaged["inputs"]["points"], "disparity maps triangulated with the rig");
  EXPECT_EQ(from_damaged["counts"]["points_fused"], from_disparity["counts"]["points_fused"]);
  fs::remove(damaged_dir / "summary.json");
  const auto unchecked = RunTool("terrain-map",
                                 {damaged_dir.string(), "--poses", poses, "--rig", rig_file.string(), "-o",
                                  (tmp.path() / "m_unchecked").string(), "-q"},
                                 tmp.path());
  EXPECT_EQ(unchecked.exit_code, 3) << unchecked.stderr_text;
  EXPECT_EQ(unchecked.ErrorLines(), 1) << unchecked.stderr_text;
  EXPECT_NE(unchecked.stderr_text.find(first_xyz.filename().string()), std::string::npos) << unchecked.stderr_text;
  // The planner reads each cell's last time from state.tif exactly (the Float32 layer cannot
  // hold 3.2 s): one of the pairs' times.
  const mapping::MapLayers layers = mapping::ReadMapElevation(tmp.path() / "m_disparity");
  ASSERT_EQ(layers.last_t_exact_s.size(), layers.elevation_m.size());
  int timed = 0;
  for (int r = 0; r < layers.elevation_m.rows; ++r) {
    for (int c = 0; c < layers.elevation_m.cols; ++c) {
      if (!std::isfinite(layers.elevation_m.at<float>(r, c))) continue;
      const double t = layers.last_t_exact_s.at<double>(r, c);
      bool a_pairs = false;  // within 1e-9 s (a Float32 time is 4e-7 s off at 9.6 s)
      for (int k = 0; k < 4; ++k) a_pairs = a_pairs || std::abs(t - PoseOf(k).t_s) < 1e-9;
      EXPECT_TRUE(a_pairs) << t;
      ++timed;
    }
  }
  EXPECT_GT(timed, 10);
  EXPECT_GT(from_disparity["counts"]["points_fused"].get<long>(), 1000);
  // The same directory without its disparity maps: the XYZ arrays are read.
  const fs::path arrays = tmp.path() / "arrays";
  fs::create_directories(arrays);
  fs::copy(stereo / "xyz", arrays / "xyz");
  const nlohmann::json from_arrays = map(arrays, rig_file, "m_arrays");
  EXPECT_EQ(from_arrays["inputs"]["points"], "XYZ arrays");
  EXPECT_EQ(from_arrays["counts"]["points_fused"], from_disparity["counts"]["points_fused"]);
  ExpectSameElevationBands(tmp.path() / "m_disparity", tmp.path() / "m_arrays");
  // Another rig (a longer baseline): its triangulation is not stereo-batch's; the arrays are read.
  calib::StereoRig other = rig;
  other.right_from_left_t_m *= 1.1;
  other.rectified->P_right(0, 3) *= 1.1;
  const fs::path other_file = tmp.path() / "other_rig.json";
  calib::WriteStereoRig(other_file, other);
  const nlohmann::json from_other = map(stereo, other_file, "m_other");
  EXPECT_EQ(from_other["inputs"]["points"], "XYZ arrays");
  EXPECT_TRUE(from_other["inputs"]["points_check"].is_null());
  ASSERT_EQ(from_other["warnings"].size(), 1u);
  EXPECT_NE(from_other["warnings"][0].get<std::string>().find("another rig"), std::string::npos);
  // A disparity map of another size than the rig's images: bad input naming the file, no map.
  io::WriteImageAtomic(stereo / "disparity" / (PoseOf(2).stem + ".pfm"), cv::Mat(10, 10, CV_32FC1, cv::Scalar(5)));
  const auto bad = RunTool(
      "terrain-map",
      {stereo.string(), "--poses", poses, "--rig", rig_file.string(), "-o", (tmp.path() / "m_bad").string(), "-q"},
      tmp.path());
  EXPECT_EQ(bad.exit_code, 3) << bad.stderr_text;
  EXPECT_EQ(bad.ErrorLines(), 1) << bad.stderr_text;
  EXPECT_NE(bad.stderr_text.find(PoseOf(2).stem + ".pfm is 10x10"), std::string::npos) << bad.stderr_text;
  EXPECT_FALSE(fs::exists(tmp.path() / "m_bad" / "elevation.tif"));
  // One of the right size holding a disparity wider than the image (damage: it would put a
  // point on the camera): refused likewise, the pixel named.
  cv::Mat damaged(rig.rectified->height_px, rig.rectified->width_px, CV_32FC1,
                  cv::Scalar(std::numeric_limits<float>::infinity()));
  damaged.at<float>(7, 3) = 1e30f;
  io::WriteImageAtomic(stereo / "disparity" / (PoseOf(2).stem + ".pfm"), damaged);
  const auto wide = RunTool(
      "terrain-map",
      {stereo.string(), "--poses", poses, "--rig", rig_file.string(), "-o", (tmp.path() / "m_wide").string(), "-q"},
      tmp.path());
  EXPECT_EQ(wide.exit_code, 3) << wide.stderr_text;
  EXPECT_NE(wide.stderr_text.find(PoseOf(2).stem + ".pfm: pixel (3, 7) holds a disparity of 1e+30 px"),
            std::string::npos)
      << wide.stderr_text;
  EXPECT_FALSE(fs::exists(tmp.path() / "m_wide" / "elevation.tif"));
}

TEST(EvaluateMapTool, LidarJudgesTheMapOfRenderedGroundAndSaysWhatItCannotMeasure) {
  // The whole of `evaluate map --lidar`: pairs rendered of the level ground the paper-like rig
  // stands on (160 x 120), stereo-batch and terrain-map with the rig, and LiDAR sweeps of that
  // ground (PLY, vehicle frame) at the pairs' poses. The map lies on the LiDAR's ground and the
  // pairs' disparity on the LiDAR's at the same instant. Without the stereo run's summary.json
  // (the disparity maps' reference image unknown) that comparison is not made, and a warning
  // says so: one line, in summary.json too.
  util::ScopedTempDir tmp;
  const calib::StereoRig rig = calib::testing::IdealRectifiedRig(160, 120, 185);
  const fs::path pairs = tmp.path() / "pairs", rig_file = tmp.path() / "rig.json";
  calib::WriteStereoRig(rig_file, rig);
  constexpr int kPairs = 4;
  {
    // Z = 0 in the vehicle frame: d = (B / h) (f sin(tilt) + (y - c_y) cos(tilt)), y the row.
    const double b_over_h = 0.9 / 1.5, tilt = 25.0 * M_PI / 180, cy = 0.5 * (120 - 1);
    sim::LayeredSceneOptions scene;
    scene.width = 160;
    scene.height = 120;
    sim::PlaneLayer ground;
    ground.d0_px = b_over_h * (185 * std::sin(tilt) - cy * std::cos(tilt));
    ground.slope_y = b_over_h * std::cos(tilt);
    scene.layers = {ground};
    const sim::RenderedPair pair = sim::RenderLayeredPair(scene);
    for (const char* side : {"left", "right"}) fs::create_directories(pairs / side);
    for (int k = 0; k < kPairs; ++k) {
      const std::string stem = PoseOf(k).stem;
      cv::imwrite((pairs / "left" / (stem + ".png")).string(), pair.left);
      cv::imwrite((pairs / "right" / (stem + ".png")).string(), pair.right);
    }
  }
  const std::string poses = (tmp.path() / "poses.csv").string();
  WritePoses(poses, kPairs);
  const fs::path lidar = tmp.path() / "velodyne";
  fs::create_directories(lidar);
  cv::Mat sweep(1, 121 * 201, CV_32FC3);
  for (int i = 0; i < 121; ++i) {
    for (int j = 0; j < 201; ++j) sweep.at<cv::Vec3f>(0, i * 201 + j) = cv::Vec3f(-3.0f + 0.05f * i, 2.0f + 0.05f * j, 0);
  }
  for (int k = 0; k < kPairs; ++k) io::WritePlyAtomic(lidar / (PoseOf(k).stem + ".ply"), sweep);
  const fs::path stereo = tmp.path() / "stereo", map = tmp.path() / "map";
  const auto batch =
      RunTool("stereo-batch", {pairs.string(), "-o", stereo.string(), "-q", "--rig", rig_file.string()}, tmp.path());
  ASSERT_EQ(batch.exit_code, 0) << batch.stderr_text;
  const auto mapped = RunTool("terrain-map", {stereo.string(), "--poses", poses, "--rig", rig_file.string(), "-o",
                                              map.string(), "-q", "--no-preview"},
                              tmp.path());
  ASSERT_EQ(mapped.exit_code, 0) << mapped.stderr_text;
  auto judge = [&](const std::string& out) {
    const auto run = RunTool("evaluate", {"map", map.string(), "--lidar", lidar.string(), "--rig", rig_file.string(),
                                          "--poses", poses, "--pairs", pairs.string(), "--stereo", stereo.string(),
                                          "-o", (tmp.path() / out).string(), "-q"},
                             tmp.path());
    EXPECT_EQ(run.exit_code, 0) << run.stderr_text;
    return std::pair(run, io::ReadJson(tmp.path() / out / "summary.json"));
  };
  const auto [run, judged] = judge("eval");
  const nlohmann::json& r = judged["result"];
  EXPECT_GT(r["cells_compared"].get<long>(), 50) << r;
  EXPECT_LT(r["elevation_rmse_m"].get<double>(), 0.03) << r;
  EXPECT_EQ(r["cells_large_error"], 0) << r;
  EXPECT_EQ(r["pairs_disparity_measured"], kPairs) << r;
  EXPECT_NEAR(r["pair_disparity_offset_px"].get<double>(), 0.0, 0.1) << r;
  EXPECT_TRUE(judged["warnings"].empty()) << judged["warnings"];
  EXPECT_EQ(run.stderr_text.find("warning"), std::string::npos) << run.stderr_text;
  fs::remove(stereo / "summary.json");
  const auto [blind_run, blind] = judge("eval_blind");
  EXPECT_TRUE(blind["result"]["pair_disparity_offset_px"].is_null()) << blind["result"];
  EXPECT_EQ(blind["result"]["cells_compared"], r["cells_compared"]);
  ASSERT_EQ(blind["warnings"].size(), 1u) << blind["warnings"];
  EXPECT_NE(blind["warnings"][0].get<std::string>().find("summary.json: no such file"), std::string::npos)
      << blind["warnings"];
  EXPECT_EQ(blind_run.ErrorLines(), 0) << blind_run.stderr_text;
  EXPECT_NE(blind_run.stderr_text.find("warning"), std::string::npos) << blind_run.stderr_text;
}

TEST(TerrainMapTool, ALeftReferencedRunIsTriangulatedAndItsRaysCastFromTheLeftCamera) {
  // stereo-batch --reference left: terrain-map takes the reference image from the run's
  // summary.json, triangulates the disparity maps with it (the map the XYZ arrays make, bit
  // for bit) and starts the rays of its carving, hidden and depth-edge rules at the left camera;
  // without the summary it takes the right image, stereo-batch's default, and says so.
  util::ScopedTempDir tmp;
  const SlopingPlaneRun sloping = RunSlopingPlaneStereo(tmp.path(), {"--reference", "left"});
  ASSERT_FALSE(::testing::Test::HasFailure());
  const fs::path& rig_file = sloping.rig_file;
  const fs::path& stereo = sloping.stereo;
  const std::string& poses = sloping.poses;
  auto map = [&](const fs::path& dir, const std::string& out) { return sloping.Map(dir, rig_file, tmp.path(), out); };
  const nlohmann::json left = map(stereo, "m_left");
  EXPECT_EQ(left["inputs"]["reference"], "left");
  EXPECT_EQ(left["inputs"]["points"], "disparity maps triangulated with the rig");
  EXPECT_TRUE(left["warnings"].empty()) << left["warnings"];
  EXPECT_GT(left["counts"]["points_fused"].get<long>(), 1000);
  // The XYZ arrays alone, with the run's summary: the same map.
  const fs::path arrays = tmp.path() / "arrays";
  fs::create_directories(arrays);
  fs::copy(stereo / "xyz", arrays / "xyz");
  fs::copy(stereo / "summary.json", arrays / "summary.json");
  const nlohmann::json from_arrays = map(arrays, "m_arrays");
  EXPECT_EQ(from_arrays["inputs"]["points"], "XYZ arrays");
  EXPECT_EQ(from_arrays["inputs"]["reference"], "left");
  ExpectSameElevationBands(tmp.path() / "m_left", tmp.path() / "m_arrays");
  // Without the summary: the right image, whose triangulation is not this run's (a warning; the
  // arrays are read).
  fs::remove(stereo / "summary.json");
  const nlohmann::json unknown = map(stereo, "m_unknown");
  EXPECT_EQ(unknown["inputs"]["reference"], "right");
  EXPECT_EQ(unknown["inputs"]["points"], "XYZ arrays");
  ASSERT_EQ(unknown["warnings"].size(), 1u);
  // ... unless told: --reference left, checked against the first pair's array.
  const auto told = RunTool("terrain-map",
                            {stereo.string(), "--poses", poses, "--rig", rig_file.string(), "--reference", "left", "-o",
                             (tmp.path() / "m_told").string(), "-q", "--no-preview"},
                            tmp.path());
  ASSERT_EQ(told.exit_code, 0) << told.stderr_text;
  const nlohmann::json told_summary = io::ReadJson(tmp.path() / "m_told" / "summary.json");
  EXPECT_EQ(told_summary["inputs"]["reference"], "left");
  EXPECT_EQ(told_summary["inputs"]["points"], "disparity maps triangulated with the rig");
  EXPECT_EQ(told_summary["inputs"]["points_check"], "the first pair's XYZ array, bit for bit");
  EXPECT_TRUE(told_summary["warnings"].empty()) << told_summary["warnings"];
}

}  // namespace
}  // namespace lunarnav
