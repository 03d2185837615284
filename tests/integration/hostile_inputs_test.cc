// The hostile-input corpus: each tool run on damaged, forged and malicious inputs, as a user
// or a broken disk hands them over. Every case asserts the promises of docs/reliability.md:
// the documented exit code; each failure as one `error:` line that names the file (or
// option) and stays short; the rest of a batch done; no temporary or partial file left in
// the output. The tools' own tests check their messages in detail; this is the one place
// that holds every tool to the same promises.
#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include <gdal_priv.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "integration/hostile_files.h"
#include "integration/run_tool.h"
#include "io/atomic_file.h"
#include "io/float_array_io.h"
#include "io/image_io.h"
#include "util/testing.h"

namespace lunarnav {
namespace {
namespace fs = std::filesystem;
using testing::ForgePngSize;
using testing::ReadFileBytes;
using testing::RunTool;
using testing::WriteForgedTiff;
using util::TestDataPath;

// The longest error line a tool may print (util's bounded messages: 2000 bytes, plus the
// prefix and the file's name).
constexpr std::size_t kMaxErrorLine = 2600;

void WriteText(const fs::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << text;
}

// Copies of the test data a case may damage: pairs/ (three 640 x 480 pairs), boxes/ (one
// 320 x 240 raw pair twice, with its rig), telemetry/ and a vehicle file.
struct Workspace {
  fs::path root, pairs, boxes, out;
  explicit Workspace(const fs::path& dir) : root(dir), pairs(dir / "pairs"), boxes(dir / "boxes"), out(dir / "out") {
    for (const char* side : {"left", "right"}) {
      fs::create_directories(pairs / side);
      for (const char* stem : {"frame0000", "frame0001", "frame0002"}) {
        const std::string name = std::string(stem) + ".png";
        fs::copy_file(TestDataPath("stereo_pairs") / side / name, pairs / side / name);
      }
      fs::create_directories(boxes / side);
      for (const char* stem : {"000000", "000001"}) {
        fs::copy_file(TestDataPath("boxes") / side / "000000.png", boxes / side / (std::string(stem) + ".png"));
      }
    }
    fs::copy_file(TestDataPath("boxes") / "rig.json", root / "rig.json");
    fs::copy_file(TestDataPath("telemetry") / "turning.csv", root / "log.csv");
    fs::copy_file(TestDataPath("telemetry") / "ratler_sensors.json", root / "sensors.json");
    fs::copy_file(TestDataPath("vehicles") / "ratler.json", root / "vehicle.json");
  }
  std::string Pairs() const { return pairs.string(); }
  std::string Out() const { return out.string(); }
  std::string At(const std::string& relative) const { return (root / relative).string(); }
};

// Replaces the first occurrence of `from` in a text file.
void Replace(const fs::path& path, const std::string& from, const std::string& to) {
  std::string text = ReadFileBytes(path);
  const std::size_t at = text.find(from);
  ASSERT_NE(at, std::string::npos) << path << ": no " << from;
  text.replace(at, from.size(), to);
  WriteText(path, text);
}

struct Case {
  const char* name;
  const char* tool;
  /// Damages the workspace and returns the tool's arguments.
  std::function<std::vector<std::string>(const Workspace&)> setup;
  int exit_code;
  std::vector<std::string> error_words;  ///< each in the error lines (the file, the reason)
  std::vector<std::string> done;         ///< outputs of the good items, relative to out/
};

// A GeoTIFF of width x height Float32 cells ("elevation_m") with the geotransform's origin
// (x_west, y_north), 25 cm cells; with `sparse` none of its blocks is written (GDAL's
// SPARSE_OK: a few hundred bytes declaring any size), else every cell 0.
void WriteGeoTiff(const fs::path& path, int width, int height, bool sparse, double x_west = 0, double y_north = 10) {
  GDALAllRegister();
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  char** options = nullptr;
  options = CSLSetNameValue(options, "TILED", "YES");
  options = CSLSetNameValue(options, "COMPRESS", "DEFLATE");
  options = CSLSetNameValue(options, "BIGTIFF", "YES");
  if (sparse) options = CSLSetNameValue(options, "SPARSE_OK", "TRUE");
  GDALDataset* ds = driver->Create(path.c_str(), width, height, 1, GDT_Float32, options);
  CSLDestroy(options);
  ASSERT_NE(ds, nullptr) << path;
  double t[6] = {x_west, 0.25, 0, y_north, 0, -0.25};
  ds->SetGeoTransform(t);
  GDALRasterBand* band = ds->GetRasterBand(1);
  band->SetDescription("elevation_m");
  if (!sparse) {
    std::vector<float> zeros(static_cast<std::size_t>(width) * height, 0.0f);
    ASSERT_EQ(band->RasterIO(GF_Write, 0, 0, width, height, zeros.data(), width, height, GDT_Float32, 0, 0), CE_None);
  }
  GDALClose(ds);
}

// The first shard summary of the fuzz corpus's seed (stereo-batch, shard 0 of 2, 3 pairs).
nlohmann::json FirstShardSummary() {
  const std::string both = ReadFileBytes(TestDataPath("fuzz") / "shard_summary" / "stereo-batch-two-shards.json");
  return nlohmann::json::parse(both.substr(0, both.find('\0')));
}

std::vector<Case> Cases() {
  const std::vector<std::string> kBatch = {"-q", "--preset", "paper"};
  auto batch = [kBatch](const Workspace& w) {
    std::vector<std::string> args = {w.Pairs(), "-o", w.Out()};
    args.insert(args.end(), kBatch.begin(), kBatch.end());
    return args;
  };
  return {
      // Images whose headers claim what their data cannot hold: refused from the header, by
      // name and size, before anything is allocated; the other pairs run.
      {"png claiming 10^12 pixels", "stereo-batch",
       [=](const Workspace& w) {
         ForgePngSize(w.pairs / "left" / "frame0001.png", 1000000, 1000000);
         return batch(w);
       },
       4, {"frame0001.png", "1000000 x 1000000"}, {"disparity/frame0000.pfm", "disparity/frame0002.pfm"}},
      {"png claiming 10^10 pixels", "stereo-batch",
       [=](const Workspace& w) {
         ForgePngSize(w.pairs / "right" / "frame0000.png", 100000, 100000);
         return batch(w);
       },
       4, {"frame0000.png", "100000 x 100000"}, {"disparity/frame0001.pfm", "disparity/frame0002.pfm"}},
      {"png claiming 0 x 0 pixels", "stereo-batch",
       [=](const Workspace& w) {
         ForgePngSize(w.pairs / "right" / "frame0002.png", 0, 0);
         return batch(w);
       },
       4, {"frame0002.png", "0 x 0"}, {"disparity/frame0000.pfm", "disparity/frame0001.pfm"}},
      // A directory where a pair's output file goes: that pair fails, named, the others run
      // (the rename's error was lost: "internal: ...: cannot rename temporary file: Success").
      {"a directory in the place of an output file", "stereo-batch",
       [=](const Workspace& w) {
         fs::create_directories(w.out / "disparity" / "frame0001.pfm");
         return batch(w);
       },
       4, {"frame0001.pfm: is a directory"}, {"disparity/frame0000.pfm", "disparity/frame0002.pfm"}},
      {"png cut short", "stereo-batch",
       [=](const Workspace& w) {
         const std::string bytes = ReadFileBytes(w.pairs / "left" / "frame0002.png");
         WriteText(w.pairs / "left" / "frame0002.png", bytes.substr(0, bytes.size() / 3));
         return batch(w);
       },
       4, {"frame0002"}, {"disparity/frame0000.pfm", "disparity/frame0001.pfm"}},
      {"62-byte tiff claiming 10^10 pixels", "stereo-batch",
       [=](const Workspace& w) {
         WriteForgedTiff(w.pairs / "left" / "big.tif", 100000, 100000);
         WriteForgedTiff(w.pairs / "right" / "big.tif", 100000, 100000);
         return batch(w);
       },
       4, {"big.tif", "100000 x 100000"},
       {"disparity/frame0000.pfm", "disparity/frame0001.pfm", "disparity/frame0002.pfm"}},
      {"tiff whose strip is short", "stereo-batch",
       [=](const Workspace& w) {
         WriteForgedTiff(w.pairs / "left" / "short.tif", 640, 480);
         WriteForgedTiff(w.pairs / "right" / "short.tif", 640, 480);
         return batch(w);
       },
       4, {"short.tif"}, {"disparity/frame0000.pfm", "disparity/frame0001.pfm", "disparity/frame0002.pfm"}},
      {"symbolic links pointing at each other", "stereo-batch",
       [=](const Workspace& w) {
         fs::create_symlink(w.pairs / "left" / "b.png", w.pairs / "left" / "a.png");
         fs::create_symlink(w.pairs / "left" / "a.png", w.pairs / "left" / "b.png");
         fs::copy_file(w.pairs / "right" / "frame0000.png", w.pairs / "right" / "a.png");
         return batch(w);
       },
       4, {"a.png", "symbolic link"},
       {"disparity/frame0000.pfm", "disparity/frame0001.pfm", "disparity/frame0002.pfm"}},
      {"symbolic link to itself", "stereo-batch",
       [=](const Workspace& w) {
         fs::create_symlink(w.pairs / "right" / "c.png", w.pairs / "right" / "c.png");
         fs::copy_file(w.pairs / "left" / "frame0000.png", w.pairs / "left" / "c.png");
         return batch(w);
       },
       4, {"c.png"}, {"disparity/frame0000.pfm", "disparity/frame0001.pfm", "disparity/frame0002.pfm"}},
      {"a pair without its partner and a stray file", "stereo-batch",
       [=](const Workspace& w) {
         fs::copy_file(w.pairs / "left" / "frame0000.png", w.pairs / "left" / "lonely.png");
         WriteText(w.pairs / "left" / "notes.txt", "not an image");
         return batch(w);
       },
       4, {"lonely", "missing"}, {"disparity/frame0000.pfm", "disparity/frame0002.pfm"}},
      // Options that cannot mean anything: usage errors, before any work.
      {"--rows outside the images", "stereo-batch",
       [=](const Workspace& w) {
         std::vector<std::string> args = batch(w);
         args.insert(args.end(), {"--rows", "1000:2000"});
         return args;
       },
       2, {"rows", "1000:2000"}, {}},
      {"--window 0x0", "stereo-batch",
       [=](const Workspace& w) {
         std::vector<std::string> args = batch(w);
         args.insert(args.end(), {"--window", "0x0"});
         return args;
       },
       2, {"window", "0x0"}, {}},
      {"an unknown option", "stereo-batch",
       [=](const Workspace& w) {
         std::vector<std::string> args = batch(w);
         args.push_back("--frobnicate");
         return args;
       },
       2, {"--frobnicate"}, {}},
      {"no input directory", "stereo-batch", [](const Workspace& w) { return std::vector<std::string>{"-o", w.Out()}; },
       2, {}, {}},
      {"an input directory that does not exist", "stereo-batch",
       [](const Workspace& w) { return std::vector<std::string>{w.At("nowhere"), "-o", w.Out(), "-q"}; }, 3,
       {"nowhere"}, {}},
      // Numbers beyond a double's range in JSON: bad input, naming the file.
      {"1e999 in a rig file", "stereo-batch",
       [=](const Workspace& w) {
         Replace(w.root / "rig.json", "370.0", "1e999");
         std::vector<std::string> args = batch(w);
         args.insert(args.end(), {"--rig", w.At("rig.json")});
         return args;
       },
       3, {"rig.json"}, {}},
      // rectify: the same damage in its batch.
      {"rectify: png claiming 10^12 pixels", "rectify",
       [](const Workspace& w) {
         ForgePngSize(w.boxes / "left" / "000001.png", 1000000, 1000000);
         return std::vector<std::string>{w.boxes.string(), "-o", w.Out(), "--rig", w.At("rig.json"), "-q"};
       },
       4, {"000001.png", "1000000 x 1000000"}, {"left/000000.png", "right/000000.png"}},
      {"rectify: symbolic links pointing at each other", "rectify",
       [](const Workspace& w) {
         fs::create_symlink(w.boxes / "left" / "y.png", w.boxes / "left" / "x.png");
         fs::create_symlink(w.boxes / "left" / "x.png", w.boxes / "left" / "y.png");
         fs::copy_file(w.boxes / "right" / "000000.png", w.boxes / "right" / "x.png");
         return std::vector<std::string>{w.boxes.string(), "-o", w.Out(), "--rig", w.At("rig.json"), "-q"};
       },
       4, {"x.png"}, {"left/000000.png", "left/000001.png"}},
      // posfilter's telemetry and sensor files.
      {"posfilter: a log starting with a UTF-8 byte-order mark", "posfilter",
       [](const Workspace& w) {
         WriteText(w.root / "log.csv", "\xEF\xBB\xBF" + ReadFileBytes(w.root / "log.csv"));
         return std::vector<std::string>{w.At("log.csv"), "--sensors", w.At("sensors.json"), "-o", w.Out(), "-q"};
       },
       0, {}, {"trajectory.csv", "trajectory.tum", "baseline.csv", "summary.json"}},
      {"posfilter: a NUL byte in a cell", "posfilter",
       [](const Workspace& w) {
         std::string text = ReadFileBytes(w.root / "log.csv");
         text.replace(text.find("\n0.1,") + 5, 1, std::string(1, '\0'));
         WriteText(w.root / "log.csv", text);
         return std::vector<std::string>{w.At("log.csv"), "--sensors", w.At("sensors.json"), "-o", w.Out(), "-q"};
       },
       // The reason after the NUL too (what() is a C string: the NUL is written \x00).
       3, {"log.csv:", "\\x00", "is not"}, {}},
      {"posfilter: a column named twice", "posfilter",
       [](const Workspace& w) {
         Replace(w.root / "log.csv", "roll,gyro_z", "compass,gyro_z");
         return std::vector<std::string>{w.At("log.csv"), "--sensors", w.At("sensors.json"), "-o", w.Out(), "-q"};
       },
       3, {"log.csv", "compass"}, {}},
      {"posfilter: --bits 0", "posfilter",
       [](const Workspace& w) {
         return std::vector<std::string>{w.At("log.csv"), "--sensors", w.At("sensors.json"), "-o", w.Out(), "-q",
                                         "--bits", "0"};
       },
       2, {"--bits"}, {}},
      {"posfilter: 1e999 in the sensor file", "posfilter",
       [](const Workspace& w) {
         Replace(w.root / "sensors.json", "\"scale\": ", "\"scale\": 1e999, \"x\": ");
         return std::vector<std::string>{w.At("log.csv"), "--sensors", w.At("sensors.json"), "-o", w.Out(), "-q"};
       },
       3, {"sensors.json"}, {}},
      {"posfilter: an empty log", "posfilter",
       [](const Workspace& w) {
         WriteText(w.root / "log.csv", "");
         return std::vector<std::string>{w.At("log.csv"), "--sensors", w.At("sensors.json"), "-o", w.Out(), "-q"};
       },
       3, {"log.csv"}, {}},
      // rig-check's vehicle file.
      {"rig-check: 1e999 in the vehicle file", "rig-check",
       [](const Workspace& w) {
         Replace(w.root / "vehicle.json", ": ", ": 1e999, \"x\": ");
         return std::vector<std::string>{"--rig", w.At("rig.json"), "--vehicle", w.At("vehicle.json")};
       },
       3, {"vehicle.json"}, {}},
      // shard-merge: a shard summary cut short (a full disk on the shared storage).
      {"shard-merge: a shard summary cut short", "shard-merge",
       [](const Workspace& w) {
         fs::create_directories(w.out);
         WriteText(w.out / "summary.shard-0-of-2.json", "{\n  \"counts\": {\n    \"pairs_in");
         return std::vector<std::string>{w.Out(), "-q"};
       },
       3, {"summary.shard-0-of-2.json"}, {}},
      // A shard summary of 4.5 million tiny values (9 MB here; 108 MB took 3.5 GB to refuse):
      // refused once it holds more values than a shard summary may, naming the file and limit.
      {"shard-merge: a shard summary of 4.5 million values", "shard-merge",
       [](const Workspace& w) {
         fs::create_directories(w.out);
         std::string text = "{\"pairs\": [0";
         text.reserve(9'100'000);
         for (int i = 0; i < 4'500'000; ++i) text += ",0";
         WriteText(w.out / "summary.shard-0-of-2.json", text + "]}");
         return std::vector<std::string>{w.Out(), "-q"};
       },
       3, {"summary.shard-0-of-2.json", "more than 4000000 JSON values"}, {}},
      // evaluate: damaged disparity maps are those items' failures.
      {"evaluate: a PFM with a negative size and one cut short", "evaluate",
       [](const Workspace& w) {
         const fs::path run = w.root / "run" / "disparity";
         fs::create_directories(run);
         io::WriteImageAtomic(run / "frame0000.pfm", cv::Mat(480, 640, CV_32FC1, cv::Scalar(30.0f)));
         WriteText(run / "frame0001.pfm", "Pf\n-5 -5\n-1.0\n" + std::string(64, '\0'));
         const std::string whole = ReadFileBytes(run / "frame0000.pfm");
         WriteText(run / "frame0002.pfm", whole.substr(0, 3000));
         return std::vector<std::string>{"disparity", (w.root / "run").string(), "--truth",
                                         (TestDataPath("stereo_pairs") / "truth").string(), "-o", w.Out(), "-q"};
       },
       4, {"frame0001.pfm", "-5 x -5", "frame0002.pfm"}, {"disparity.csv"}},
      {"evaluate: a PFM claiming 10^10 pixels", "evaluate",
       [](const Workspace& w) {
         const fs::path run = w.root / "run" / "disparity";
         fs::create_directories(run);
         io::WriteImageAtomic(run / "frame0000.pfm", cv::Mat(480, 640, CV_32FC1, cv::Scalar(30.0f)));
         WriteText(run / "frame0001.pfm", "Pf\n99999 99999\n-1.0\n" + std::string(64, '\0'));
         return std::vector<std::string>{"disparity", (w.root / "run").string(), "--truth",
                                         (TestDataPath("stereo_pairs") / "truth").string(), "-o", w.Out(), "-q"};
       },
       4, {"frame0001.pfm", "99999 x 99999"}, {"disparity.csv"}},
      {"evaluate: no subcommand", "evaluate", [](const Workspace&) { return std::vector<std::string>{}; }, 2, {}, {}},
      {"rectify: no rig", "rectify", [](const Workspace& w) { return std::vector<std::string>{w.boxes.string(), "-o", w.Out()}; },
       2, {"--rig"}, {}},
      {"calibrate: an unknown option", "calibrate",
       [](const Workspace& w) { return std::vector<std::string>{w.Pairs(), "-o", w.At("out/rig.json"), "--frobnicate"}; },
       2, {"--frobnicate"}, {}},
      // Signal deaths: a calibration nested 50,000 deep (100 KB) overflowed the stack of
      // OpenCV's recursive parser. Every importer bounds a file's size and nesting before
      // parsing it: bad input (exit 3) naming the file, the line and the limit.
      {"calibrate --from opencv: a YAML file nested 50,000 deep", "calibrate",
       [](const Workspace& w) {
         WriteText(w.root / "deep.yml",
                   "%YAML:1.0\n---\nM1: " + std::string(50000, '[') + std::string(50000, ']') + "\n");
         const std::string deep = (w.root / "deep.yml").string();
         return std::vector<std::string>{"--from", "opencv", deep, deep, "--image-size", "640x480",
                                         "--square", "0.01", "-o", w.At("out/rig.json")};
       },
       3, {"deep.yml", "line 3", "nested more than"}, {}},
      // Round three: texts the old scanner in front of OpenCV's parser read otherwise than the
      // parser did (a quote it took as a string's start, an attribute it took for a closing
      // tag): 60,000 levels reached OpenCV's recursion (SIGSEGV). No OpenCV parser now.
      {"calibrate --from opencv: 60,000 brackets after an unmatched quote", "calibrate",
       [](const Workspace& w) {
         WriteText(w.root / "quote.yml", "%YAML:1.0\n---\nX1: [ab \"c, " + std::string(60000, '[') + "\n");
         const std::string f = (w.root / "quote.yml").string();
         return std::vector<std::string>{"--from", "opencv", f, f, "--image-size", "640x480",
                                         "--square", "0.01", "-o", w.At("out/rig.json")};
       },
       3, {"quote.yml"}, {}},
      {"calibrate --from opencv: an XML element with a '/>' attribute, 60,000 deep", "calibrate",
       [](const Workspace& w) {
         std::string text = "<?xml version=\"1.0\"?>\n<opencv_storage>";
         for (int i = 0; i < 60000; ++i) text += "<a b=\"/>\">";
         WriteText(w.root / "nested.xml", text + "\n");
         const std::string f = (w.root / "nested.xml").string();
         return std::vector<std::string>{"--from", "opencv", f, f, "--image-size", "640x480",
                                         "--square", "0.01", "-o", w.At("out/rig.json")};
       },
       3, {"nested.xml", "nested more than 64"}, {}},
      {"calibrate --from opencv: a JSON file nested 60,000 deep", "calibrate",
       [](const Workspace& w) {
         WriteText(w.root / "deep.json", "{\"M1\": " + std::string(60000, '[') + std::string(60000, ']') + "}\n");
         const std::string f = (w.root / "deep.json").string();
         return std::vector<std::string>{"--from", "opencv", f, f, "--image-size", "640x480",
                                         "--square", "0.01", "-o", w.At("out/rig.json")};
       },
       3, {"deep.json", "nested more than 64"}, {}},
      {"calibrate --from ros: a YAML mapping nested 5,000 levels by indentation", "calibrate",
       [](const Workspace& w) {
         std::string text;
         for (int i = 0; i < 5000; ++i) text += std::string(static_cast<std::size_t>(i), ' ') + "k:\n";
         WriteText(w.root / "deep.yaml", text + std::string(5000, ' ') + "1\n");
         const std::string deep = (w.root / "deep.yaml").string();
         return std::vector<std::string>{"--from", "ros", deep, deep, "-o", w.At("out/rig.json")};
       },
       3, {"deep.yaml", "line 65", "nested deeper than 64"}, {}},
      // Values beyond any meaning: a stereo delay of 1e308 s made requests of 1e307 m, and two
      // poses 1e-300 s apart made an infinite one (rows stereo-batch then refused). The planner's
      // options are bounded (usage, exit 2, naming the option) and every request must reach less
      // than 1000 m (bad input, exit 3, naming the file and the stem).
      // Round three: a map file is read only when what it declares is what it holds.
      {"plan-windows --map: a sparse GeoTIFF declaring 10^10 cells", "plan-windows",
       [](const Workspace& w) {
         WriteText(w.root / "poses.csv",
                   "stem,t_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg\n000000,0,0,0,0,0,0,0\n000001,3.2,0,0.48,0,0,0,0\n");
         fs::create_directories(w.root / "map");
         WriteGeoTiff(w.root / "map" / "elevation.tif", 100000, 100000, true);
         return std::vector<std::string>{"--poses", w.At("poses.csv"), "--map", w.At("map"), "-o", w.Out(), "-q"};
       },
       3, {"elevation.tif", "declares 100000 x 100000"}, {}},
      {"plan-windows --map: a sparse GeoTIFF of a sensible size", "plan-windows",
       [](const Workspace& w) {
         WriteText(w.root / "poses.csv",
                   "stem,t_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg\n000000,0,0,0,0,0,0,0\n000001,3.2,0,0.48,0,0,0,0\n");
         fs::create_directories(w.root / "map");
         WriteGeoTiff(w.root / "map" / "elevation.tif", 1000, 1000, true);
         return std::vector<std::string>{"--poses", w.At("poses.csv"), "--map", w.At("map"), "-o", w.Out(), "-q"};
       },
       3, {"elevation.tif", "sparse"}, {}},
      {"plan-windows --map: a map whose origin is NaN", "plan-windows",
       [](const Workspace& w) {
         WriteText(w.root / "poses.csv",
                   "stem,t_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg\n000000,0,0,0,0,0,0,0\n000001,3.2,0,0.48,0,0,0,0\n");
         fs::create_directories(w.root / "map");
         WriteGeoTiff(w.root / "map" / "elevation.tif", 40, 40, false, std::nan(""));
         return std::vector<std::string>{"--poses", w.At("poses.csv"), "--map", w.At("map"), "-o", w.Out(), "-q"};
       },
       3, {"elevation.tif", "origin"}, {}},
      {"evaluate map: a VRT text declaring 10^10 cells as the map", "evaluate",
       [](const Workspace& w) {
         fs::create_directories(w.root / "map");
         WriteText(w.root / "map" / "elevation.tif",
                   "<VRTDataset rasterXSize=\"100000\" rasterYSize=\"100000\"><GeoTransform>0, 0.25, 0, 10, 0, "
                   "-0.25</GeoTransform><VRTRasterBand dataType=\"Float32\" band=\"1\"><Description>elevation_m"
                   "</Description></VRTRasterBand></VRTDataset>\n");
         return std::vector<std::string>{"map", w.At("map"), "--truth", w.At("sim"), "-o", w.Out(), "-q"};
       },
       3, {"elevation.tif", "not a readable GeoTIFF"}, {}},
      // One reader for every text file: a byte-order mark, CRLF and a trailing blank line are
      // what spreadsheets write, and are read.
      {"plan-windows: a trajectory with a byte-order mark, CRLF and a blank last line", "plan-windows",
       [](const Workspace& w) {
         WriteText(w.root / "trajectory.csv",
                   "\xEF\xBB\xBFt_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg,speed_mps\r\n0,0,0,0,0,0,0,0\r\n"
                   "10,0,1.5,0,0,0,0,0.15\r\n\r\n");
         WriteText(w.root / "times.csv", "\xEF\xBB\xBFstem,t_s\r\n000000,1\r\n000001,4.2\r\n\r\n");
         return std::vector<std::string>{"--trajectory", w.At("trajectory.csv"), "--frame-times", w.At("times.csv"),
                                         "-o", w.Out(), "-q"};
       },
       0, {}, {"requests.csv"}},
      // A KITTI pose file takes its times from times.txt: a time that goes back is that file's
      // fault, at its line (it was blamed on the pose file).
      {"plan-windows: KITTI poses whose times.txt goes back", "plan-windows",
       [](const Workspace& w) {
         WriteText(w.root / "poses.txt",
                   "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 0.5\n1 0 0 0 0 1 0 0 0 0 1 1\n");
         WriteText(w.root / "times.txt", "0\n0.1\n0.05\n");
         return std::vector<std::string>{"--trajectory", w.At("poses.txt"), "--frame-times", w.At("times.txt"),
                                         "--rig", w.At("rig.json"), "-o", w.Out(), "-q"};
       },
       3, {"times.txt:3", "not after the previous frame"}, {}},
      {"evaluate trajectory: a GPS track with a coordinate of 1e308", "evaluate",
       [](const Workspace& w) {
         WriteText(w.root / "gps.csv", "t,east,north\n0,0,0\n10,1e308,1\n20,2,2\n");
         return std::vector<std::string>{"trajectory",
                                         "gps=" + w.At("gps.csv"),
                                         "--truth",
                                         (TestDataPath("telemetry") / "trial-a" / "truth.csv").string(),
                                         "-o",
                                         w.Out(),
                                         "-q"};
       },
       3, {"gps.csv:3", "1e308"}, {}},
      // Round three: what a rig declares must agree with itself and with the images.
      {"stereo-batch: a rig declaring rectified images of 100000 x 100000", "stereo-batch",
       [](const Workspace& w) {
         nlohmann::json rig = nlohmann::json::parse(ReadFileBytes(w.root / "rig.json"));
         rig["rectified"]["size_px"] = {100000, 100000};
         WriteText(w.root / "rig.json", rig.dump());
         return std::vector<std::string>{w.boxes.string(), "-o", w.Out(), "--rig", w.At("rig.json"), "-q"};
       },
       3, {"rig.json", "rectified.size_px", "100000 x 100000"}, {}},
      {"stereo-batch: a rig of 640 x 480 rectified pixels for 320 x 240 pairs", "stereo-batch",
       [](const Workspace& w) {
         nlohmann::json rig = nlohmann::json::parse(ReadFileBytes(w.root / "rig.json"));
         rig["rectified"]["size_px"] = {640, 480};
         WriteText(w.root / "rig.json", rig.dump());
         return std::vector<std::string>{w.boxes.string(), "-o", w.Out(), "--rig", w.At("rig.json"), "-q"};
       },
       3, {"rig.json", "640x480", "000000.png", "320x240"}, {}},
      {"stereo-batch: a rectified baseline of 150 m for cameras 0.9 m apart", "stereo-batch",
       [](const Workspace& w) {
         nlohmann::json rig = nlohmann::json::parse(ReadFileBytes(w.root / "rig.json"));
         rig["rectified"]["P_right"][0][3] = -150 * rig["rectified"]["P_right"][0][0].get<double>();
         WriteText(w.root / "rig.json", rig.dump());
         return std::vector<std::string>{w.boxes.string(), "-o", w.Out(), "--rig", w.At("rig.json"), "-q"};
       },
       3, {"rig.json", "P_right", "150 m"}, {}},
      {"stereo-batch: a rig whose mast is 1.5 m below the ground", "stereo-batch",
       [](const Workspace& w) {
         nlohmann::json rig = nlohmann::json::parse(ReadFileBytes(w.root / "rig.json"));
         rig["mast"]["height_m"] = -1.5;
         WriteText(w.root / "rig.json", rig.dump());
         return std::vector<std::string>{w.boxes.string(), "-o", w.Out(), "--rig", w.At("rig.json"), "-q"};
       },
       3, {"rig.json", "mast.height_m"}, {}},
      {"evaluate map: a rock of 100 km", "evaluate",
       [](const Workspace& w) {
         fs::create_directories(w.root / "map");
         fs::create_directories(w.root / "sim" / "truth");
         WriteGeoTiff(w.root / "map" / "elevation.tif", 40, 40, false);
         WriteGeoTiff(w.root / "sim" / "truth" / "terrain.tif", 40, 40, false);
         WriteText(w.root / "sim" / "truth" / "rocks.csv",
                   "x_m,y_m,height_m,semi_major_m,semi_minor_m,angle_deg\n1,2,0.3,0.4,0.3,10\n3,4,0.3,100000,0.3,0\n");
         return std::vector<std::string>{"map", w.At("map"), "--truth", w.At("sim"), "-o", w.Out(), "-q"};
       },
       3, {"rocks.csv:3", "at most 100 m"}, {}},
      {"evaluate map: a truth without the simulator's layers", "evaluate",
       [](const Workspace& w) {
         fs::create_directories(w.root / "map");
         fs::create_directories(w.root / "sim" / "truth");
         WriteGeoTiff(w.root / "map" / "elevation.tif", 40, 40, false);
         WriteGeoTiff(w.root / "sim" / "truth" / "terrain.tif", 40, 40, false);  // elevation_m only
         WriteText(w.root / "sim" / "truth" / "rocks.csv", "x_m,y_m,height_m,semi_major_m,semi_minor_m,angle_deg\n");
         return std::vector<std::string>{"map", w.At("map"), "--truth", w.At("sim"), "-o", w.Out(), "-q"};
       },
       3, {"terrain.tif: no band 'obstacle'"}, {}},
      // A damaged sidecar is no record of a complete pair: --resume redoes that pair.
      {"stereo-batch --resume: sidecars of the wrong types", "stereo-batch",
       [=](const Workspace& w) {
         const auto first = RunTool("stereo-batch", batch(w), w.root);
         EXPECT_EQ(first.exit_code, 0) << first.stderr_text;
         nlohmann::json a = nlohmann::json::parse(ReadFileBytes(w.out / "disparity" / "frame0000.json"));
         a["format"] = 5;
         WriteText(w.out / "disparity" / "frame0000.json", a.dump());
         nlohmann::json b = nlohmann::json::parse(ReadFileBytes(w.out / "disparity" / "frame0001.json"));
         b["result"]["pixels_evaluated"] = "many";
         WriteText(w.out / "disparity" / "frame0001.json", b.dump());
         WriteText(w.out / "disparity" / "frame0002.json", "[1, 2, 3]");
         std::vector<std::string> args = batch(w);
         args.push_back("--resume");
         return args;
       },
       0, {}, {"disparity/frame0000.pfm", "disparity/frame0001.json", "disparity/frame0002.json", "summary.json"}},
      {"plan-windows: a stereo delay of 1e308 s", "plan-windows",
       [](const Workspace& w) {
         WriteText(w.root / "poses.csv",
                   "stem,t_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg\n000000,0,0,0,0,0,0,0\n000001,3.2,0,0.48,0,0,0,0\n");
         return std::vector<std::string>{"--poses", w.At("poses.csv"), "--stereo-delay", "1e308", "-o", w.Out()};
       },
       2, {"stereo delay", "3600"}, {}},
      {"plan-windows: two poses 1e-300 s apart", "plan-windows",
       [](const Workspace& w) {
         WriteText(w.root / "poses.csv",
                   "stem,t_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg\n000000,0,0,0,0,0,0,0\n000001,1e-300,0,0.48,0,0,0,0\n");
         return std::vector<std::string>{"--poses", w.At("poses.csv"), "-o", w.Out()};
       },
       3, {"poses.csv", "stem 000001", "1000 m"}, {}},
      // Signal deaths and endless loops of the first probe, kept: a thread count of 2^31 - 1
      // (SIGSEGV inside the thread library), shard numbers [0, 0] (SIGFPE), an RPE step of
      // 1e-17 m (a loop that never advanced). Each runs to its documented end.
      {"rectify: -j 2147483647", "rectify",
       [](const Workspace& w) {
         return std::vector<std::string>{w.boxes.string(), "-o", w.Out(), "--rig", w.At("rig.json"), "-q", "-j",
                                         "2147483647"};
       },
       0, {}, {"left/000000.png", "left/000001.png", "right/000001.png"}},
      {"shard-merge: summaries of shard [0, 0]", "shard-merge",
       [](const Workspace& w) {
         const std::string both = ReadFileBytes(TestDataPath("fuzz") / "shard_summary" / "regression-shard-zero-of-zero.json");
         fs::create_directories(w.out);
         WriteText(w.out / "summary.shard-0-of-2.json", both.substr(0, both.find('\0')));
         return std::vector<std::string>{w.Out(), "-q"};
       },
       3, {"summary.shard-0-of-2.json", "shard"}, {}},
      // Round three: what a shard summary declares is checked before it is used or quoted.
      {"shard-merge: a listing whose items are a text", "shard-merge",
       [](const Workspace& w) {
         nlohmann::json s = FirstShardSummary();
         s["listing"]["items"] = "three";
         fs::create_directories(w.out);
         WriteText(w.out / "summary.shard-0-of-2.json", s.dump());
         return std::vector<std::string>{w.Out(), "-q"};
       },
       3, {"summary.shard-0-of-2.json", "listing is malformed"}, {}},
      {"shard-merge: a listing whose digest is a number", "shard-merge",
       [](const Workspace& w) {
         nlohmann::json s = FirstShardSummary();
         s["listing"]["digest"] = 12345;
         fs::create_directories(w.out);
         WriteText(w.out / "summary.shard-0-of-2.json", s.dump());
         return std::vector<std::string>{w.Out(), "-q"};
       },
       3, {"summary.shard-0-of-2.json", "listing is malformed"}, {}},
      {"shard-merge: a listing of 10^12 items", "shard-merge",
       [](const Workspace& w) {
         nlohmann::json s = FirstShardSummary();
         s["listing"]["items"] = 1000000000000LL;
         fs::create_directories(w.out);
         WriteText(w.out / "summary.shard-0-of-2.json", s.dump());
         return std::vector<std::string>{w.Out(), "-q"};
       },
       3, {"summary.shard-0-of-2.json", "declares 1000000000000 items"}, {}},
      {"shard-merge: shard 0 of 2147483647", "shard-merge",
       [](const Workspace& w) {
         nlohmann::json s = FirstShardSummary();  // items 0 and 2 of 3 in shard 0/2
         s["shard"] = {0, 2147483647};
         s["pairs"] = nlohmann::json::array({s["pairs"][0]});
         fs::create_directories(w.out);
         WriteText(w.out / "summary.shard-0-of-2147483647.json", s.dump());
         return std::vector<std::string>{w.Out(), "-q"};
       },
       4, {"shard 1/2147483647 missing", "shard 2/2147483647 missing"}, {"summary.json"}},
      {"evaluate trajectory: an RPE step of 1e-17 m", "evaluate",
       [](const Workspace& w) {
         const std::string truth = (TestDataPath("telemetry") / "trial-a" / "truth.csv").string();
         return std::vector<std::string>{"trajectory", "same=" + truth, "--truth", truth, "--rpe-delta", "1e-17",
                                         "-o", w.Out(), "-q"};
       },
       0, {}, {"summary.json", "trajectory_errors.csv"}},
      // Giant grids: a pose 1e12 m away (an internal error from OpenCV that left files under
      // their final names; with --no-preview, every point in one overflowed cell).
      {"terrain-map: a pose 1e12 m away", "terrain-map",
       [](const Workspace& w) {
         const fs::path stereo = w.root / "stereo";
         cv::Mat xyz(30, 40, CV_32FC3);
         for (int r = 0; r < xyz.rows; ++r) {
           for (int c = 0; c < xyz.cols; ++c) xyz.at<cv::Vec3f>(r, c) = cv::Vec3f(0.1f * c - 2, 2 + 0.1f * r, 0);
         }
         io::WriteExrAtomic(stereo / "xyz" / "000000.exr", xyz);
         io::WriteExrAtomic(stereo / "xyz" / "000001.exr", xyz);
         WriteText(w.root / "poses.csv",
                   "stem,t_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg\n000000,0,0,0,0,0,0,0\n000001,3.2,1e12,0.48,0,0,0,0\n");
         return std::vector<std::string>{stereo.string(), "--poses", w.At("poses.csv"), "--no-preview", "-o", w.Out(), "-q"};
       },
       3, {"poses.csv", "stem 000001", "1000 km"}, {}},
      // Silent acceptance by the importers: a baseline of 1.8e299 m (Middlebury, in mm), the
      // right camera 0.3 m above the left (Kalibr), a projection of 1e305 px baseline (KITTI).
      {"calibrate --from middlebury: a baseline of 1.8e302 mm", "calibrate",
       [](const Workspace& w) {
         std::string text = ReadFileBytes(TestDataPath("fuzz") / "rig_import" / "middlebury").substr(1);
         text.replace(text.find("baseline=176.252"), 16, "baseline=1.8e302");
         WriteText(w.root / "calib.txt", text);
         return std::vector<std::string>{"--from", "middlebury", w.At("calib.txt"), "-o", w.At("out/rig.json")};
       },
       3, {"calib.txt", "100 m"}, {}},
      {"calibrate --from kalibr: the right camera above the left", "calibrate",
       [](const Workspace& w) {
         std::string text = ReadFileBytes(TestDataPath("fuzz") / "rig_import" / "kalibr").substr(1);
         text.replace(text.find("[1.0, 0.0, 0.0, -0.3]"), 21, "[1.0, 0.0, 0.0, 0.0]");
         text.replace(text.find("[0.0, 1.0, 0.0, 0.001]"), 22, "[0.0, 1.0, 0.0, -0.3]");
         WriteText(w.root / "camchain.yaml", text);
         return std::vector<std::string>{"--from", "kalibr", w.At("camchain.yaml"), "-o", w.At("out/rig.json")};
       },
       3, {"camchain.yaml", "not beside it"}, {}},
      {"calibrate --from kitti: a baseline term of 1e305", "calibrate",
       [](const Workspace& w) {
         std::string text = ReadFileBytes(TestDataPath("fuzz") / "rig_import" / "kitti").substr(1);
         text.replace(text.find("-3.395242e+02"), 13, "-3.395242e+305");
         WriteText(w.root / "calib_cam_to_cam.txt", text);
         return std::vector<std::string>{"--from", "kitti", w.At("calib_cam_to_cam.txt"), "-o", w.At("out/rig.json")};
       },
       3, {"calib_cam_to_cam.txt", "100 m"}, {}},
      {"simulate: an unknown preset", "simulate",
       [](const Workspace& w) {
         return std::vector<std::string>{"telemetry", "--preset", "mars", "-o", w.Out()};
       },
       2, {"mars"}, {}},
  };
}

// Every file under `dir` (none when it does not exist).
std::vector<fs::path> FilesUnder(const fs::path& dir) {
  std::vector<fs::path> files;
  if (!fs::exists(dir)) return files;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    if (!entry.is_directory()) files.push_back(entry.path());
  }
  return files;
}

TEST(HostileInputs, EveryToolKeepsItsPromises) {
  for (const Case& c : Cases()) {
    SCOPED_TRACE(c.name);
    util::ScopedTempDir tmp;
    const Workspace w(tmp.path() / "w");
    const std::vector<std::string> args = c.setup(w);
    const std::vector<fs::path> inputs_in_out = FilesUnder(w.out);  // shard-merge's inputs are there
    const testing::ToolRun run = RunTool(c.tool, args, tmp.path());
    EXPECT_EQ(run.exit_code, c.exit_code) << run.stderr_text;
    // Failures: error lines, each short; nothing unbounded on stderr.
    EXPECT_LT(run.stderr_text.size(), 16u * 1024u);
    std::istringstream lines(run.stderr_text);
    std::string errors;
    for (std::string line; std::getline(lines, line);) {
      if (line.rfind("error:", 0) != 0) continue;
      EXPECT_LE(line.size(), kMaxErrorLine) << line.substr(0, 200);
      errors += line + "\n";
    }
    if (c.exit_code != 0) {
      EXPECT_GE(run.ErrorLines(), 1) << run.stderr_text;
    } else {
      EXPECT_EQ(run.ErrorLines(), 0) << run.stderr_text;
    }
    for (const std::string& word : c.error_words) {
      EXPECT_NE(errors.find(word), std::string::npos) << "no '" << word << "' in:\n" << run.stderr_text;
    }
    // The good items are done; nothing temporary is left.
    for (const std::string& file : c.done) EXPECT_TRUE(fs::exists(w.out / file)) << file << "\n" << run.stderr_text;
    for (const fs::path& file : FilesUnder(w.out)) {
      EXPECT_FALSE(io::IsTempFileName(file)) << "left behind: " << file;
    }
    // A run refused as a whole (usage or bad input) writes no outputs at all.
    if (c.exit_code == 2 || c.exit_code == 3) {
      for (const fs::path& file : FilesUnder(w.out)) {
        if (std::find(inputs_in_out.begin(), inputs_in_out.end(), file) == inputs_in_out.end()) {
          ADD_FAILURE() << "written by a refused run: " << file;
        }
      }
    }
  }
}

}  // namespace
}  // namespace lunarnav
