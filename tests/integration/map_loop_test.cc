// map-loop end to end on a small simulated traverse with one blank pair: the closed loop asks
// again for the ground the blank pair lost (the open loop does not), its map is terrain-map's
// map of its own stereo outputs and requests, and a resumed loop makes the same map.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "integration/run_tool.h"
#include "io/atomic_file.h"
#include "io/geotiff_io.h"
#include "io/json_io.h"
#include "util/testing.h"

namespace lunarnav {
namespace {
namespace fs = std::filesystem;
using testing::ReadFileBytes;
using testing::RunTool;

constexpr int kFrames = 8;
constexpr int kBlank = 4;

// A CSV with '#' comments and a header, as rows of named cells.
std::vector<std::map<std::string, std::string>> ReadCsv(const fs::path& path) {
  std::ifstream in(path);
  std::vector<std::string> header;
  std::vector<std::map<std::string, std::string>> rows;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> cells;
    std::stringstream s(line);
    for (std::string cell; std::getline(s, cell, ',');) cells.push_back(cell);
    if (header.empty()) {
      header = cells;
      continue;
    }
    std::map<std::string, std::string> row;
    for (std::size_t k = 0; k < cells.size() && k < header.size(); ++k) row[header[k]] = cells[k];
    rows.push_back(row);
  }
  return rows;
}

double Number(const std::map<std::string, std::string>& row, const std::string& key) {
  return std::stod(row.at(key));
}

cv::Mat Band(const fs::path& tif, const std::string& name) {
  const io::GeoRaster r = io::ReadGeoTiff(tif);
  const int i = r.BandIndex(name);
  EXPECT_GE(i, 0) << name;
  return i >= 0 ? r.bands[i].pixels : cv::Mat();
}

// Equal, NaN where the other is NaN.
bool SameLayer(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  for (int y = 0; y < a.rows; ++y) {
    for (int x = 0; x < a.cols; ++x) {
      const float u = a.at<float>(y, x), v = b.at<float>(y, x);
      if (!(u == v || (std::isnan(u) && std::isnan(v)))) return false;
    }
  }
  return true;
}

class MapLoopTool : public ::testing::Test {
 protected:
  // One small traverse for every test (rendering is the slow part): the paper's rig at half
  // size, a pair every 3.2 s at 0.15 m/s, pair kBlank blank; and the loop over it.
  static void SetUpTestSuite() {
    tmp_ = std::make_unique<util::ScopedTempDir>();
    const fs::path sim = Dir() / "sim", rect = Dir() / "rect";
    const auto simulate = RunTool("simulate",
                                  {"stereo", "--preset", "terrain", "--frames", std::to_string(kFrames), "--width", "320",
                                   "--height", "240", "--focal", "370", "--fault", std::to_string(kBlank) + ":blank",
                                   "-o", sim.string(), "-q"},
                                  Dir());
    ASSERT_EQ(simulate.exit_code, 0) << simulate.stderr_text;
    const auto rectify =
        RunTool("rectify", {sim.string(), "-o", rect.string(), "--rig", (sim / "rig.json").string(), "-q"}, Dir());
    ASSERT_EQ(rectify.exit_code, 0) << rectify.stderr_text;
    const auto loop = Loop(Dir() / "loop", {});
    ASSERT_EQ(loop.exit_code, 4) << loop.stderr_text;  // the blank pair failed, the others went on
  }
  static void TearDownTestSuite() { tmp_.reset(); }

  static fs::path Dir() { return tmp_->path(); }
  static testing::ToolRun Loop(const fs::path& out, std::vector<std::string> extra, const fs::path& rect = fs::path()) {
    std::vector<std::string> args = {(rect.empty() ? Dir() / "rect" : rect).string(),
                                     "--rig",
                                     (Dir() / "rect" / "rig.json").string(),
                                     "--poses",
                                     (Dir() / "sim" / "truth" / "poses.csv").string(),
                                     "--initial-speed",
                                     "0.15",
                                     "--initial-cycle",
                                     "3.2",
                                     "-o",
                                     out.string(),
                                     "-q"};
    args.insert(args.end(), extra.begin(), extra.end());
    return RunTool("map-loop", args, Dir());
  }

  static std::unique_ptr<util::ScopedTempDir> tmp_;
};
std::unique_ptr<util::ScopedTempDir> MapLoopTool::tmp_;

TEST_F(MapLoopTool, TheClosedLoopAsksAgainForTheGroundOfABlankPairAndTheOpenLoopDoesNot) {
  // No overlap between requests: only reading the map brings the lost ground back.
  const auto closed = Loop(Dir() / "closed", {"--overlap", "0"});
  ASSERT_EQ(closed.exit_code, 4) << closed.stderr_text;
  EXPECT_EQ(closed.ErrorLines(), 1) << closed.stderr_text;
  EXPECT_NE(closed.stderr_text.find("00000" + std::to_string(kBlank)), std::string::npos) << closed.stderr_text;
  const auto open = Loop(Dir() / "open", {"--overlap", "0", "--open-loop"});
  ASSERT_EQ(open.exit_code, 4) << open.stderr_text;

  const auto poses = ReadCsv(Dir() / "sim" / "truth" / "poses.csv");
  // The distance driven from the blank pair to the next one (a straight traverse).
  const double driven = std::hypot(Number(poses[kBlank + 1], "x_m") - Number(poses[kBlank], "x_m"),
                                   Number(poses[kBlank + 1], "y_m") - Number(poses[kBlank], "y_m"));
  ASSERT_GT(driven, 0.3);
  for (const char* mode : {"closed", "open"}) {
    const auto rows = ReadCsv(Dir() / mode / "loop.csv");
    ASSERT_EQ(rows.size(), static_cast<std::size_t>(kFrames)) << mode;
    EXPECT_EQ(rows[kBlank].at("status"), "failed") << mode;
    EXPECT_EQ(rows[kBlank + 1].at("status"), "ok") << mode;
  }
  const auto closed_rows = ReadCsv(Dir() / "closed" / "loop.csv");
  const auto open_rows = ReadCsv(Dir() / "open" / "loop.csv");
  // The lost ground in the next pair's frame: the blank pair's interval less the distance driven.
  auto lost = [&](const std::vector<std::map<std::string, std::string>>& rows) {
    return std::make_pair(Number(rows[kBlank], "y_min_m") - driven, Number(rows[kBlank], "y_max_m") - driven);
  };
  // Closed: the next request covers it (to the map's resolution, one cell).
  EXPECT_LE(Number(closed_rows[kBlank + 1], "y_min_m"), lost(closed_rows).first + 0.25);
  EXPECT_GE(Number(closed_rows[kBlank + 1], "y_max_m"), lost(closed_rows).second);
  // Open: it starts where the lost request ended, as if that pair had been mapped.
  EXPECT_GT(Number(open_rows[kBlank + 1], "y_min_m"), lost(open_rows).first + 0.3);

  // The closed loop's map against the truth over the requested ground: accurate, no gap in the
  // corridor longer than one cell.
  const fs::path eval = Dir() / "closed-eval";
  const auto evaluate = RunTool("evaluate",
                                {"map", (Dir() / "closed" / "map").string(), "--truth", (Dir() / "sim").string(),
                                 "--requests", (Dir() / "closed" / "requests.csv").string(), "-o", eval.string(), "-q"},
                                Dir());
  ASSERT_EQ(evaluate.exit_code, 0) << evaluate.stderr_text;
  const nlohmann::json r = io::ReadJson(eval / "summary.json").at("requested");
  // The requests are a second view: the score itself is over all the ground the truth's pairs
  // saw, as without them (the judged run does not choose its denominator).
  const auto plain = RunTool("evaluate",
                             {"map", (Dir() / "closed" / "map").string(), "--truth", (Dir() / "sim").string(), "-o",
                              (Dir() / "closed-eval-plain").string(), "-q"},
                             Dir());
  ASSERT_EQ(plain.exit_code, 0) << plain.stderr_text;
  const nlohmann::json all = io::ReadJson(eval / "summary.json").at("result");
  const nlohmann::json without = io::ReadJson(Dir() / "closed-eval-plain" / "summary.json").at("result");
  for (const char* count : {"cells_seen", "cells_seen_mapped", "cells_compared", "obstacle_cells_true"}) {
    EXPECT_EQ(all.at(count), without.at(count)) << count;
  }
  EXPECT_LT(r.at("cells_seen").get<long>(), all.at("cells_seen").get<long>());
  EXPECT_TRUE(fs::exists(eval / "requested.md"));
  EXPECT_LE(r.at("corridor_gap_m").get<double>(), 0.25);
  EXPECT_LT(r.at("elevation_rmse_m").get<double>(), 0.03);
  EXPECT_EQ(r.at("cells_large_error").get<long>(), 0);
  EXPECT_GT(r.at("coverage").get<double>(), 0.9);
}

TEST_F(MapLoopTool, ItsMapIsTerrainMapOfItsOwnStereoOutputsAndRequests) {
  const fs::path loop = Dir() / "loop";
  const auto requests = ReadCsv(loop / "requests.csv");
  ASSERT_EQ(requests.size(), static_cast<std::size_t>(kFrames));
  // Each pair was matched in its requested window.
  for (const auto& row : requests) {
    const fs::path sidecar = loop / "stereo" / "disparity" / (row.at("stem") + ".json");
    if (row.at("stem") == "00000" + std::to_string(kBlank)) {
      EXPECT_FALSE(fs::exists(sidecar));
      continue;
    }
    const nlohmann::json y = io::ReadJson(sidecar).at("result").at("window").at("region").at("y_m");
    EXPECT_DOUBLE_EQ(y.at(0).get<double>(), Number(row, "y_min_m")) << row.at("stem");
    EXPECT_DOUBLE_EQ(y.at(1).get<double>(), Number(row, "y_max_m")) << row.at("stem");
  }
  const nlohmann::json stereo = io::ReadJson(loop / "stereo" / "summary.json");
  EXPECT_EQ(stereo.at("counts").at("pairs_ok").get<int>(), kFrames - 1);
  EXPECT_EQ(stereo.at("counts").at("pairs_failed").get<int>(), 1);

  // terrain-map over the same outputs in one run: the same map as the loop's pair by pair.
  const fs::path remap = Dir() / "remap";
  const auto map = RunTool("terrain-map",
                           {(loop / "stereo").string(), "--poses", (Dir() / "sim" / "truth" / "poses.csv").string(),
                            "--rig", (Dir() / "rect" / "rig.json").string(), "--requests",
                            (loop / "requests.csv").string(), "-o", remap.string(), "-q"},
                           Dir());
  ASSERT_EQ(map.exit_code, 0) << map.stderr_text;
  for (const char* band : {"elevation_m", "count", "frames", "obstacle"}) {
    EXPECT_TRUE(SameLayer(Band(loop / "map" / "elevation.tif", band), Band(remap / "elevation.tif", band))) << band;
  }
  EXPECT_EQ(ReadFileBytes(loop / "map" / "frames.csv"), ReadFileBytes(remap / "frames.csv"));
}

TEST_F(MapLoopTool, EvaluateMapCountsTheTruthsGroundWhateverPairsTheMapDropped) {
  // terrain-map over the loop's stereo outputs, and over them less one pair's: evaluate map
  // scores both over the ground the truth's pairs saw (the same count), and the map without
  // the pair covers less of it.
  const fs::path loop = Dir() / "loop", less = Dir() / "stereo-less-one";
  fs::copy(loop / "stereo", less, fs::copy_options::recursive);
  const std::string dropped = "00000" + std::to_string(kBlank + 1);
  fs::remove(less / "xyz" / (dropped + ".exr"));
  fs::remove(less / "disparity" / (dropped + ".pfm"));
  auto map_and_score = [&](const fs::path& stereo, const std::string& name) {
    const fs::path map = Dir() / ("map-" + name), eval = Dir() / ("eval-" + name);
    const auto made = RunTool("terrain-map",
                              {stereo.string(), "--poses", (Dir() / "sim" / "truth" / "poses.csv").string(), "--rig",
                               (Dir() / "rect" / "rig.json").string(), "-o", map.string(), "-q"},
                              Dir());
    EXPECT_EQ(made.exit_code, 0) << made.stderr_text;
    const auto scored = RunTool(
        "evaluate", {"map", map.string(), "--truth", (Dir() / "sim").string(), "-o", eval.string(), "-q"}, Dir());
    EXPECT_EQ(scored.exit_code, 0) << scored.stderr_text;
    return io::ReadJson(eval / "summary.json");
  };
  const nlohmann::json all = map_and_score(loop / "stereo", "all"), some = map_and_score(less, "less");
  EXPECT_EQ(all["inputs"]["frames"], kFrames);
  EXPECT_EQ(some["inputs"]["frames"], kFrames);
  for (const char* count : {"cells_seen", "rocks"}) {
    EXPECT_EQ(all["result"][count], some["result"][count]) << count;
  }
  EXPECT_LT(some["result"]["cells_seen_mapped"].get<long>(), all["result"]["cells_seen_mapped"].get<long>());
}

TEST_F(MapLoopTool, AResumedLoopMakesTheMapOfAnUninterruptedOne) {
  // A loop stopped after the first pairs (only they were there), then resumed over all.
  const fs::path part = Dir() / "rect-part", out = Dir() / "resumed";
  for (const char* side : {"left", "right"}) {
    fs::create_directories(part / side);
    for (int k = 0; k <= kBlank; ++k) {
      const std::string name = "00000" + std::to_string(k) + ".png";
      fs::copy_file(Dir() / "rect" / side / name, part / side / name);
    }
  }
  ASSERT_EQ(Loop(out, {}, part).exit_code, 4);
  EXPECT_EQ(ReadCsv(out / "requests.csv").size(), static_cast<std::size_t>(kBlank + 1));
  const auto again = Loop(out, {});
  EXPECT_EQ(again.exit_code, 2) << "a map is there: continuing it needs --resume";
  const auto resumed = Loop(out, {"--resume"});
  ASSERT_EQ(resumed.exit_code, 4) << resumed.stderr_text;
  EXPECT_EQ(ReadFileBytes(out / "requests.csv"), ReadFileBytes(Dir() / "loop" / "requests.csv"));
  for (const char* band : {"elevation_m", "count", "frames"}) {
    EXPECT_TRUE(SameLayer(Band(out / "map" / "elevation.tif", band), Band(Dir() / "loop" / "map" / "elevation.tif", band)))
        << band;
  }
  // The resumed pairs were kept, not matched again.
  const auto rows = ReadCsv(out / "loop.csv");
  ASSERT_EQ(rows.size(), static_cast<std::size_t>(kFrames));
  EXPECT_EQ(rows[0].at("status"), "resumed");
  EXPECT_EQ(rows[kBlank + 1].at("status"), "ok");
}

TEST_F(MapLoopTool, AResumedLoopKeepsItsRequestsOnlyFromTheSamePlannerAndASoundPlan) {
  const fs::path out = Dir() / "replan";
  fs::copy(Dir() / "loop", out, fs::copy_options::recursive);
  // Another planner (a longer horizon): the recorded requests were not planned with it.
  const auto other = Loop(out, {"--resume", "--horizon", "3"});
  EXPECT_EQ(other.exit_code, 2) << other.stderr_text;
  EXPECT_NE(other.stderr_text.find("horizon"), std::string::npos) << other.stderr_text;
  EXPECT_EQ(ReadFileBytes(out / "plan.csv"), ReadFileBytes(Dir() / "loop" / "plan.csv"));  // nothing written
  const auto open = Loop(out, {"--resume", "--open-loop"});
  EXPECT_EQ(open.exit_code, 2) << open.stderr_text;
  EXPECT_NE(open.stderr_text.find("open_loop"), std::string::npos) << open.stderr_text;
  // A plan whose rows are unsound: a stem twice, a request that is no interval (exit 3, the line).
  const std::string plan = ReadFileBytes(out / "plan.csv");
  const std::size_t first = plan.find("\n000000,");
  ASSERT_NE(first, std::string::npos);
  const std::string row = plan.substr(first + 1, plan.find('\n', first + 1) - first);
  io::WriteFileAtomic(out / "plan.csv", plan + row);
  const auto twice = Loop(out, {"--resume"});
  EXPECT_EQ(twice.exit_code, 3) << twice.stderr_text;
  EXPECT_NE(twice.stderr_text.find("planned twice"), std::string::npos) << twice.stderr_text;
  std::string nan_row = row;
  nan_row.replace(nan_row.rfind(','), std::string::npos, ",nan\n");
  std::string broken = plan;
  broken.replace(first + 1, row.size(), nan_row);
  io::WriteFileAtomic(out / "plan.csv", broken);
  const auto nan = Loop(out, {"--resume"});
  EXPECT_EQ(nan.exit_code, 3) << nan.stderr_text;
  EXPECT_NE(nan.stderr_text.find("not an interval"), std::string::npos) << nan.stderr_text;
  // The sound plan, the same planner: resumed.
  io::WriteFileAtomic(out / "plan.csv", plan);
  EXPECT_EQ(Loop(out, {"--resume"}).exit_code, 4);  // the blank pair fails again; the others are kept
}

TEST_F(MapLoopTool, APairWhoseCamerasSeeNoneOfItsRequestFailsAloneAndTheLoopGoesOn) {
  // Pair 2 pitched 60 deg up: its cameras see none of the ground the planner asks for. As in
  // stereo-batch, that pair fails (named, with its attitude); the others are matched and mapped.
  const auto rows = ReadCsv(Dir() / "sim" / "truth" / "poses.csv");
  std::string text = "stem,t_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg\n";
  for (std::size_t k = 0; k < rows.size(); ++k) {
    text += rows[k].at("stem") + "," + rows[k].at("t_s") + "," + rows[k].at("x_m") + "," + rows[k].at("y_m") + "," +
            rows[k].at("z_m") + "," + rows[k].at("heading_deg") + "," + (k == 2 ? "60" : rows[k].at("pitch_deg")) +
            "," + rows[k].at("roll_deg") + "\n";
  }
  const fs::path poses = Dir() / "pitched.csv";
  io::WriteFileAtomic(poses, text);
  const auto run = RunTool("map-loop",
                           {(Dir() / "rect").string(), "--rig", (Dir() / "rect" / "rig.json").string(), "--poses",
                            poses.string(), "-o", (Dir() / "pitched").string(), "-q"},
                           Dir());
  EXPECT_EQ(run.exit_code, 4) << run.stderr_text;
  EXPECT_NE(run.stderr_text.find("pair 000002: at pitch 60 deg"), std::string::npos) << run.stderr_text;
  EXPECT_EQ(run.stderr_text.find("requests.csv"), std::string::npos) << run.stderr_text;  // not its own file's fault
  const auto loop = ReadCsv(Dir() / "pitched" / "loop.csv");
  ASSERT_EQ(loop.size(), static_cast<std::size_t>(kFrames));
  EXPECT_EQ(loop[2].at("status"), "failed");
  EXPECT_EQ(loop[3].at("status"), "ok");
  EXPECT_TRUE(fs::exists(Dir() / "pitched" / "map" / "elevation.tif"));
}

TEST_F(MapLoopTool, BadInputsHaveTheirExitCodesAndWriteNoMap) {
  EXPECT_EQ(RunTool("map-loop", {"--help"}, Dir()).exit_code, 0);
  const fs::path rect = Dir() / "rect", rig = rect / "rig.json";
  // Usage: no poses.
  const auto no_poses = RunTool("map-loop", {rect.string(), "--rig", rig.string(), "-o", (Dir() / "x").string()}, Dir());
  EXPECT_EQ(no_poses.exit_code, 2) << no_poses.stderr_text;
  // Bad input: a pair without a pose, named; nothing mapped.
  const fs::path poses = Dir() / "short-poses.csv";
  {
    std::ifstream in(Dir() / "sim" / "truth" / "poses.csv");
    std::ofstream out(poses);
    std::string line;
    for (int rows = 0; rows < 3 && std::getline(in, line);) {  // the comments, the header and pairs 0 and 1
      out << line << "\n";
      rows += !line.empty() && line[0] != '#';
    }
  }
  const fs::path out = Dir() / "short";
  const auto missing = RunTool("map-loop", {rect.string(), "--rig", rig.string(), "--poses", poses.string(), "-o",
                                            out.string()},
                               Dir());
  EXPECT_EQ(missing.exit_code, 3) << missing.stderr_text;
  EXPECT_EQ(missing.ErrorLines(), 1) << missing.stderr_text;
  EXPECT_NE(missing.stderr_text.find("no pose in"), std::string::npos) << missing.stderr_text;
  EXPECT_FALSE(fs::exists(out / "map"));
  const auto no_dir = RunTool("map-loop", {(Dir() / "nowhere").string(), "--rig", rig.string(), "--poses",
                                           (Dir() / "sim" / "truth" / "poses.csv").string(), "-o", out.string()},
                              Dir());
  EXPECT_EQ(no_dir.exit_code, 3) << no_dir.stderr_text;
  EXPECT_EQ(no_dir.ErrorLines(), 1) << no_dir.stderr_text;
}

}  // namespace
}  // namespace lunarnav
