#include "mapping/map_loop.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include "calib/vehicle.h"
#include "io/atomic_file.h"
#include "io/json_io.h"
#include "io/stereo_pairs.h"
#include "mapping/frame_poses.h"
#include "stereo/window_requests.h"
#include "util/check.h"
#include "util/errors.h"
#include "util/format.h"
#include "util/log.h"
#include "util/parse.h"
#include "util/progress.h"
#include "util/resources.h"
#include "util/summary.h"
#include "util/timer.h"

namespace lunarnav::mapping {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// A request's bounds as requests.csv holds them (4 decimals): the stereo window, the map's
// interval and a resumed loop all use the same numbers.
double AsWritten(double v) { return std::strtod(util::Format("%.4f", v).c_str(), nullptr); }

// The planner's values a loop's requests depend on: plan.csv records them, and a resumed loop
// keeps its recorded requests only when its own are the same.
constexpr const char* kPlannerLine = "# lunarnav map-loop planner: ";
json PlannerJson(const MapLoopOptions& options) {
  return {{"planner", options.planner.ToJson()},
          {"vehicle", calib::VehicleSpecToJson(options.vehicle)},
          {"open_loop", options.open_loop}};
}

// A plan.csv this loop wrote (a resumed loop's earlier pairs): its rows by stem, and the
// planner's values it records (null: a plan of an earlier version records none).
struct RecordedPlan {
  std::map<std::string, PlannedWindow> rows;
  json planner = nullptr;
};

RecordedPlan ReadPlanCsv(const fs::path& path) {
  RecordedPlan plan;
  std::map<std::string, PlannedWindow>& rows = plan.rows;
  std::map<std::string, long> line_of;
  std::ifstream in(path);
  LN_CHECK_INPUT(in) << path.string() << ": cannot read (a loop to resume has one)";
  std::string line;
  bool header = false;
  for (long number = 1; std::getline(in, line); ++number) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.rfind(kPlannerLine, 0) == 0) {
      try {
        plan.planner = json::parse(line.substr(std::string(kPlannerLine).size()));
      } catch (const json::exception& e) {
        throw InputError(path.string() + ":" + std::to_string(number) + ": the planner's record is not JSON (" +
                         e.what() + ")");
      }
      continue;
    }
    if (line.empty() || line[0] == '#') continue;
    if (!header) {
      LN_CHECK_INPUT(line.rfind("stem,t_s,speed_mps,cycle_s,", 0) == 0)
          << path.string() << ":" << number << ": not a plan.csv header";
      header = true;
      continue;
    }
    std::vector<std::string> cells;
    std::stringstream s(line);
    for (std::string cell; std::getline(s, cell, ',');) cells.push_back(cell);
    LN_CHECK_INPUT(cells.size() == 9) << path.string() << ":" << number << ": " << cells.size()
                                      << " cells, expected 9";
    PlannedWindow w;
    w.stem = cells[0];
    double* fields[] = {&w.t_s, &w.speed_mps, &w.cycle_s, &w.d_stop_m, &w.y_need_m, &w.covered_to_m, &w.y_min_m,
                        &w.y_max_m};
    for (int k = 0; k < 8; ++k) {
      try {
        *fields[k] = cells[k + 1] == "nan" ? std::nan("") : util::ParseDouble(cells[k + 1], "value");
      } catch (const std::invalid_argument&) {
        throw InputError(path.string() + ":" + std::to_string(number) + ": '" + cells[k + 1] + "' is not a number");
      }
    }
    LN_CHECK_INPUT(std::isfinite(w.y_min_m) && std::isfinite(w.y_max_m) && w.y_min_m < w.y_max_m)
        << path.string() << ":" << number << ": stem " << w.stem << ": the request " << w.y_min_m << ":" << w.y_max_m
        << " m is not an interval (finite, min < max)";
    const auto [at, fresh] = line_of.emplace(w.stem, number);
    LN_CHECK_INPUT(fresh) << path.string() << ":" << number << ": stem " << w.stem << " planned twice (line "
                          << at->second << " too)";
    rows[w.stem] = w;
  }
  return plan;
}

}  // namespace

void MapLoopOptions::Validate() const {
  LN_CHECK_ARG(stereo.rig.has_value()) << "the loop needs the rectified rig (--rig)";
  stereo.Validate();
  LN_CHECK_ARG(!stereo.region) << "the loop's windows are its requests: no fixed range";
  LN_CHECK_ARG(stereo.shard_count == 1) << "the loop runs its pairs in order: no shards";
  LN_CHECK_ARG(!map.poses_csv.empty() || !map.trajectory.empty()) << "give --poses or --trajectory with --frame-times";
  LN_CHECK_ARG(map.merge_maps.empty()) << "the loop makes one map: no --merge";
  LN_CHECK_ARG(map.shard_count == 1) << "the loop runs its pairs in order: no shards";
  map.map.Validate();
  planner.Validate();
}

std::string MapLoopSummary::BriefReport() const {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(3);
  const std::size_t n = pairs.size();
  s << n << " pairs (" << pairs_ok << " matched, " << pairs_resumed << " kept, " << pairs_failed << " failed); stereo "
    << (n > 0 ? stereo_seconds / n : 0.0) << " s a pair; " << map.mapped_cells << " cells, " << map.obstacle_cells
    << " obstacle cells; " << seconds << " s";
  return s.str();
}

std::string MapLoopCsv(const std::vector<MapLoopPair>& pairs) {
  std::string s =
      "# lunarnav map-loop: per pair in time order, the planner's request (from the past poses and the map of\n"
      "# the pairs before it; m, m/s, s), what stereo and the map did with it, and the times (s)\n"
      "stem,t_s,speed_mps,cycle_s,d_stop_m,y_need_m,covered_to_m,y_min_m,y_max_m,status,pixels_evaluated,"
      "pixels_accepted,points_fused,stereo_s,match_s,map_s\n";
  for (const MapLoopPair& p : pairs) {
    const PlannedWindow& w = p.plan;
    s += w.stem + util::Format(",%.3f,%.5f,%.3f,%.4f,%.4f,%.4f,%.4f,%.4f,%s,%ld,%ld,%ld,%.4f,%.4f,%.4f\n", w.t_s,
                               w.speed_mps, w.cycle_s, w.d_stop_m, w.y_need_m, w.covered_to_m, w.y_min_m, w.y_max_m,
                               p.status.c_str(), p.pixels_evaluated, p.pixels_accepted, p.points_fused,
                               p.stereo_seconds, p.match_seconds, p.map_seconds);
  }
  return s;
}

MapLoopSummary RunMapLoop(const MapLoopOptions& options, const fs::path& rect_dir, const fs::path& out,
                          const json& invocation) {
  options.Validate();
  util::Timer total;
  LN_CHECK_ARG(options.resume || !fs::exists(out / "map") || fs::is_empty(out / "map"))
      << (out / "map").string() << ": a map is already there (--resume continues it)";
  const fs::path stereo_dir = out / "stereo", map_dir = out / "map";
  const fs::path requests_csv = out / "requests.csv", plan_csv = out / "plan.csv";

  // Everything is checked before anything is written: the pairs, a pose for each.
  stereo::BatchOptions stereo_options = options.stereo;
  stereo_options.resume = true;  // a pair matched in the same window is kept (a resumed loop)
  stereo_options.show_progress = false;
  stereo_options.requests.clear();
  stereo_options.requests_source = requests_csv.string();
  const TerrainMapRunOptions& mo = options.map;
  std::vector<std::string> stems;
  {
    const std::vector<io::PairFiles> pairs = io::ListStereoPairs(rect_dir);
    LN_CHECK_INPUT(!pairs.empty()) << rect_dir.string() << ": no image pairs in left/ and right/";
    for (const io::PairFiles& p : pairs) stems.push_back(p.stem);
  }
  const std::vector<FramePose> poses = PosesOfPairs(mo.poses_csv, mo.trajectory, mo.frame_times, stems,
                                                    options.stereo.rig->VehicleFromLeft());
  // Each pair searches where its vehicle's attitude puts the ground (stereo::BatchOptions::attitudes).
  for (const FramePose& p : poses) {
    stereo_options.attitudes[p.stem] = {p.pitch_rad * 180.0 / M_PI, p.roll_rad * 180.0 / M_PI};
  }
  stereo_options.attitudes_source = mo.poses_csv.empty() ? mo.trajectory.string() : mo.poses_csv.string();

  // A resumed loop keeps the requests it planned (from the map as it then was), when they were
  // planned with this loop's planner: another planner is refused, naming the first value that
  // differs (exit 2).
  std::map<std::string, PlannedWindow> recorded;
  std::vector<std::string> warnings;
  const json planner = PlannerJson(options);
  if (options.resume && fs::is_regular_file(plan_csv)) {
    RecordedPlan plan = ReadPlanCsv(plan_csv);
    if (plan.planner.is_null()) {
      warnings.push_back(plan_csv.string() +
                         " records no planner values (a loop of an earlier version): its requests "
                         "are kept as planned");
    } else {
      for (const auto& [key, value] : planner.items()) {
        const bool same = plan.planner.contains(key) && plan.planner.at(key) == value;
        LN_CHECK_ARG(same) << plan_csv.string() << ": planned with " << key << " "
                           << (plan.planner.contains(key) ? plan.planner.at(key).dump() : "(not recorded)")
                           << ", this loop's is " << value.dump()
                           << "; a loop can only be resumed with the same planner (or started afresh)";
      }
    }
    recorded = std::move(plan.rows);
  }
  for (const std::string& w : warnings) LN_LOG(Warning) << w;

  io::CreateOutputDirectory(out);
  io::RemoveStaleTempFiles(out);
  stereo::StereoBatchRun stereo_run(stereo_options, rect_dir, stereo_dir);
  std::map<std::string, std::size_t> pair_index;
  for (std::size_t k = 0; k < stereo_run.Pairs().size(); ++k) pair_index[stereo_run.Pairs()[k].stem] = k;

  TerrainMapRunOptions map_options = mo;
  map_options.stereo_dir = stereo_dir;
  map_options.requests = requests_csv;
  map_options.resume = true;
  map_options.show_progress = false;

  MapLoopSummary summary;
  std::vector<PlannedWindow> plan;
  util::ProgressBar progress(poses.size(), "map-loop pairs", options.show_progress);
  for (std::size_t k = 0; k < poses.size(); ++k) {
    const FramePose& pose = poses[k];
    MapLoopPair pair;
    // 1. Plan from the past poses and the map of the pairs before this one.
    util::Timer timer;
    if (const auto it = recorded.find(pose.stem); it != recorded.end()) {
      pair.plan = it->second;
      pair.replanned = false;
    } else {
      recorded.clear();  // past the recorded pairs, every request is planned afresh
      std::optional<MapLayers> map;
      if (!options.open_loop && fs::is_regular_file(map_dir / "elevation.tif"))
        map = ReadMapElevation(map_dir, false);  // it holds the pairs before this one only
      const std::vector<FramePose> past(poses.begin(), poses.begin() + static_cast<std::ptrdiff_t>(k) + 1);
      pair.plan = PlanWindows(past, options.vehicle, options.planner, map ? &*map : nullptr).back();
      pair.plan.y_min_m = AsWritten(pair.plan.y_min_m);
      pair.plan.y_max_m = AsWritten(pair.plan.y_max_m);
    }
    plan.push_back(pair.plan);
    // 2. Recorded before matching: a loop killed from here on resumes with this request.
    io::WriteFileAtomic(requests_csv, RequestsCsv(plan));
    io::WriteFileAtomic(plan_csv, kPlannerLine + planner.dump() + "\n" + PlanCsv(plan));
    summary.plan_seconds += timer.ElapsedSeconds();

    // 3. Stereo in the requested window. A pair whose cameras, at its attitude, see none of its
    // request (a vehicle pitched 60 deg up) is a failed pair, as stereo-batch fails one: the
    // loop goes on (exit 4 at the end).
    try {
      stereo_run.Request({pose.stem, pair.plan.y_min_m, pair.plan.y_max_m, static_cast<long>(k) + 2});
    } catch (const InputError&) {
      pair.status = "failed";
      ++summary.pairs_failed;
      pair.error = util::Format("at pitch %g deg, roll %g deg its cameras see none of its request (Y %g to %g m)",
                                pose.pitch_rad * 180 / M_PI, pose.roll_rad * 180 / M_PI, pair.plan.y_min_m,
                                pair.plan.y_max_m);
      LN_LOG(Error) << "pair " << pose.stem << ": " << pair.error;
      summary.pairs.push_back(pair);
      progress.Increment();
      continue;
    }
    const stereo::PairOutcome& outcome = stereo_run.Process(pair_index.at(pose.stem));
    pair.stereo_seconds = outcome.seconds;
    pair.match_seconds = outcome.match_seconds;
    summary.stereo_seconds += outcome.seconds;
    summary.match_seconds += outcome.match_seconds;
    switch (outcome.status) {
      case stereo::PairOutcome::Status::kOk: pair.status = "ok"; ++summary.pairs_ok; break;
      case stereo::PairOutcome::Status::kResumed: pair.status = "resumed"; ++summary.pairs_resumed; break;
      case stereo::PairOutcome::Status::kFailed: pair.status = "failed"; ++summary.pairs_failed; break;
    }
    pair.error = outcome.error;
    if (outcome.status != stereo::PairOutcome::Status::kFailed) {
      pair.pixels_evaluated = outcome.result.value("pixels_evaluated", 0L);
      pair.pixels_accepted = outcome.result.value("pixels_accepted", 0L);
      // 4. Into the map (terrain-map --resume: a pair already there is kept).
      timer.Restart();
      map_options.stems = {pose.stem};
      summary.map = RunTerrainMap(map_options, map_dir, invocation);
      pair.points_fused = summary.map.points_fused;
      pair.map_seconds = timer.ElapsedSeconds();
      summary.map_seconds += pair.map_seconds;
    }
    summary.pairs.push_back(pair);
    progress.Increment();
  }
  const stereo::BatchSummary stereo_summary = stereo_run.Finish(invocation);
  io::WriteFileAtomic(out / "loop.csv", MapLoopCsv(summary.pairs));
  summary.seconds = total.ElapsedSeconds();

  json j = util::SummaryHead("map-loop", invocation);
  j["loop"] = options.open_loop ? "open: requests from the past poses only" : "closed: requests from the map and the past poses";
  j["inputs"] = {{"rect_dir", rect_dir.string()},     {"poses", mo.poses_csv.string()},
                 {"trajectory", mo.trajectory.string()}, {"frame_times", mo.frame_times.string()},
                 {"rig", options.stereo.rig_source},  {"resume", options.resume}};
  j["vehicle"] = calib::VehicleSpecToJson(options.vehicle);
  j["options"] = {{"planner", options.planner.ToJson()},
                  {"stereo", stereo_options.ToJson()},
                  {"map", mo.map.ToJson()},
                  {"sigma_d_px", mo.sigma_d_px}};
  j["outputs"] = {{"stereo", stereo_dir.string()}, {"map", map_dir.string()}, {"requests", requests_csv.string()},
                  {"plan", plan_csv.string()},     {"loop", (out / "loop.csv").string()}};
  const std::size_t n = summary.pairs.size();
  j["counts"] = {{"pairs", n},
                 {"pairs_matched", summary.pairs_ok},
                 {"pairs_kept", summary.pairs_resumed},
                 {"pairs_failed", summary.pairs_failed},
                 {"pixels_evaluated", stereo_summary.pixels_evaluated},
                 {"pixels_accepted", stereo_summary.pixels_accepted},
                 {"mapped_cells", summary.map.mapped_cells},
                 {"obstacle_cells", summary.map.obstacle_cells}};
  j["timings_s"] = {{"total", summary.seconds},
                    {"plan_sum", summary.plan_seconds},
                    {"stereo_sum", summary.stereo_seconds},
                    {"match_sum", summary.match_seconds},
                    {"map_sum", summary.map_seconds},
                    {"stereo_per_pair", n > 0 ? summary.stereo_seconds / n : 0.0},
                    {"match_per_pair", n > 0 ? summary.match_seconds / n : 0.0}};
  j["failed"] = json::array();
  for (const MapLoopPair& p : summary.pairs) {
    if (p.status == "failed") j["failed"].push_back({{"stem", p.plan.stem}, {"error", p.error}});
  }
  j["peak_memory_mib"] = util::PeakResidentMemoryMiB();
  io::WriteJsonAtomic(out / "summary.json", j);
  return summary;
}

}  // namespace lunarnav::mapping
