#include "evaluation/map_eval.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <iomanip>
#include <limits>
#include <map>
#include <set>
#include <mutex>
#include <optional>
#include <sstream>

#include "evaluation/map_rasters.h"
#include "evaluation/map_vehicle_eval.h"
#include "io/atomic_file.h"
#include "io/float_array_io.h"
#include "io/image_io.h"
#include "io/json_io.h"
#include "mapping/frame_poses.h"
#include "sim/vehicle_pose.h"
#include "util/check.h"
#include "util/errors.h"
#include "util/log.h"
#include "util/parallel.h"
#include "util/summary.h"
#include "util/timer.h"

namespace lunarnav::evaluation {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

using internal::LatticeOffset;
using internal::TrueWorldFromVehicle;
using internal::Number;
using internal::Ratio;
const cv::Mat& Band(const io::GeoRaster& r, const std::string& name, const std::string& what) {
  return internal::FloatBand(r, name, what);
}
float At(const cv::Mat& m, int col, int row) { return internal::ValueAt(m, col, row); }

}  // namespace

void MapEvalOptions::Validate() const {
  LN_CHECK_ARG(min_points >= 1) << "min points: must be >= 1";
  LN_CHECK_ARG(std::isfinite(rock_height_m) && rock_height_m >= 0) << "rock height: must be >= 0 m";
  LN_CHECK_ARG(std::isfinite(rock_near_m) && rock_near_m > 0) << "rock distance: must be > 0 m";
  LN_CHECK_ARG(tolerance_cells >= 0 && tolerance_cells <= 10) << "tolerance: must be in 0..10 cells";
  LN_CHECK_ARG(std::isfinite(relief_height_m) && relief_height_m > 0) << "relief height: must be > 0 m";
  LN_CHECK_ARG(relief_slope_deg > 0 && relief_slope_deg < 90) << "relief slope: must be in (0, 90) deg";
  LN_CHECK_ARG(std::isfinite(large_error_m) && large_error_m > 0) << "large error: must be > 0 m";
  LN_CHECK_ARG(std::isfinite(seen_min_y_m) && std::isfinite(seen_max_y_m) && seen_min_y_m < seen_max_y_m)
      << "seen range: need finite MIN < MAX, got " << seen_min_y_m << ":" << seen_max_y_m << " m";
  LN_CHECK_ARG(std::isfinite(corridor_width_m) && corridor_width_m > 0) << "corridor width: must be > 0 m";
}

json MapEvalOptions::ToJson() const {
  return {{"min_points", min_points},
          {"rock_height_m", rock_height_m},
          {"rock_near_m", rock_near_m},
          {"tolerance_cells", tolerance_cells},
          {"relief_height_m", relief_height_m},
          {"relief_slope_deg", relief_slope_deg},
          {"large_error_m", large_error_m},
          {"seen_y_m", {seen_min_y_m, seen_max_y_m}},
          {"requested_pairs", requested_y_m.size()},
          {"corridor_width_m", corridor_width_m}};
}


namespace {
// The largest rock a truth may list, metres (the simulator's are under a metre).
constexpr double kMaxRockAxisM = 100.0;
}  // namespace

bool TrueRock::InUpperHalf(double x, double y) const {
  const double a = angle_deg * M_PI / 180.0, dx = x - x_m, dy = y - y_m;
  const double u = (std::cos(a) * dx + std::sin(a) * dy) / semi_major_m;
  const double v = (-std::sin(a) * dx + std::cos(a) * dy) / semi_minor_m;
  return u * u + v * v <= 1.0 - std::sqrt(0.5);  // h (1 - q)^2 >= h / 2
}

std::vector<TrueRock> ReadRocksCsv(const fs::path& path) {
  std::ifstream in(path);
  LN_CHECK_INPUT(in.good()) << path.string() << ": cannot open";
  std::vector<TrueRock> rocks;
  std::string line;
  bool header = false;
  for (long number = 1; std::getline(in, line); ++number) {
    if (line.empty() || line[0] == '#') continue;
    if (!header) {
      LN_CHECK_INPUT(line.rfind("x_m,y_m,height_m,semi_major_m,semi_minor_m,angle_deg", 0) == 0)
          << path.string() << ":" << number
          << ": expected the header x_m,y_m,height_m,semi_major_m,semi_minor_m,angle_deg";
      header = true;
      continue;
    }
    std::istringstream row(line);
    row.imbue(std::locale::classic());
    TrueRock r;
    char c1, c2, c3, c4, c5;
    row >> r.x_m >> c1 >> r.y_m >> c2 >> r.height_m >> c3 >> r.semi_major_m >> c4 >> r.semi_minor_m >> c5 >>
        r.angle_deg;
    LN_CHECK_INPUT(!row.fail() && c1 == ',' && c2 == ',' && c3 == ',' && c4 == ',' && c5 == ',' &&
                   r.semi_major_m > 0 && r.semi_minor_m > 0)
        << path.string() << ":" << number << ": malformed row";
    // Bounds before the work a rock sets (TrueRayCounts lists it in every 1 m square of its
    // ellipse's box: a semi-major axis of 1e5 m took 2.8 GB).
    LN_CHECK_INPUT(std::abs(r.x_m) <= mapping::kMaxWorldCoordinateM && std::abs(r.y_m) <= mapping::kMaxWorldCoordinateM &&
                   r.semi_major_m <= kMaxRockAxisM && r.semi_minor_m <= kMaxRockAxisM && std::isfinite(r.height_m) &&
                   std::abs(r.height_m) <= kMaxRockAxisM && std::isfinite(r.angle_deg))
        << path.string() << ":" << number << ": a rock at (" << r.x_m << ", " << r.y_m << ") m of semi-axes "
        << r.semi_major_m << " and " << r.semi_minor_m << " m and height " << r.height_m
        << " m; a rock lies within 1000 km of the origin, its axes and height at most " << kMaxRockAxisM << " m";
    rocks.push_back(r);
  }
  LN_CHECK_INPUT(header) << path.string() << ": no header";
  return rocks;
}

MapEvalResult EvaluateMap(const io::GeoRaster& map, const io::GeoRaster& truth, const io::GeoRaster& seen,
                          const std::vector<TrueRock>& rocks, const MapEvalOptions& o) {
  o.Validate();
  const cv::Mat& elevation = Band(map, "elevation_m", "map");
  const cv::Mat& count = Band(map, "count", "map");
  const cv::Mat& obstacle = Band(map, "obstacle", "map");
  const cv::Mat& true_elevation = Band(truth, "elevation_m", "truth");
  const cv::Mat& true_obstacle = Band(truth, "obstacle", "truth");
  const cv::Mat& true_relief = Band(truth, "relief_m", "truth");
  const cv::Mat& true_slope = Band(truth, "slope_deg", "truth");
  const cv::Mat& rays = Band(seen, "count", "seen cells");
  int tc = 0, tr = 0, sc = 0, sr = 0;
  LatticeOffset(map, truth, "truth", &tc, &tr);
  LatticeOffset(map, seen, "seen cells", &sc, &sr);
  // Map cell (col, row) is truth cell (col - tc, row - tr), seen cell (col - sc, row - sr).
  MapEvalResult r;
  const int tol = o.tolerance_cells;
  auto compared = [&](int col, int row) {
    return col >= 0 && row >= 0 && col < elevation.cols && row < elevation.rows &&
           count.at<float>(row, col) >= o.min_points && std::isfinite(At(true_elevation, col - tc, row - tr));
  };
  auto any_near = [&](int col, int row, int radius, auto pred) {
    for (int dr = -radius; dr <= radius; ++dr) {
      for (int dc = -radius; dc <= radius; ++dc) {
        if (pred(col + dc, row + dr)) return true;
      }
    }
    return false;
  };
  auto map_obstacle = [&](int col, int row) {
    return compared(col, row) && obstacle.at<float>(row, col) > 0;
  };
  auto true_obstacle_at = [&](int col, int row) { return At(true_obstacle, col - tc, row - tr) > 0; };
  auto real_relief_at = [&](int col, int row) {
    return At(true_relief, col - tc, row - tr) >= o.relief_height_m ||
           At(true_slope, col - tc, row - tr) > o.relief_slope_deg;
  };
  // The elevation error over the compared cells; precision over the map's obstacle cells.
  std::vector<double> errors;
  for (int row = 0; row < elevation.rows; ++row) {
    for (int col = 0; col < elevation.cols; ++col) {
      if (!compared(col, row)) continue;
      errors.push_back(elevation.at<float>(row, col) - At(true_elevation, col - tc, row - tr));
      if (obstacle.at<float>(row, col) > 0) {
        ++r.obstacle_map;
        (any_near(col, row, tol, real_relief_at) ? r.obstacle_tp : r.obstacle_fp)++;
      }
    }
  }
  r.cells_compared = static_cast<long>(errors.size());
  if (!errors.empty()) {
    double sum = 0, sum2 = 0;
    std::vector<double> abs_err;
    for (double e : errors) {
      r.cells_large_error += std::abs(e) > o.large_error_m;
      sum += e;
      sum2 += e * e;
      abs_err.push_back(std::abs(e));
    }
    const double n = static_cast<double>(errors.size());
    r.bias_m = sum / n;
    r.rmse_m = std::sqrt(sum2 / n);
    std::sort(abs_err.begin(), abs_err.end());
    double s = 0;
    for (double a : abs_err) s += a;
    r.mean_abs_m = s / n;
    r.p90_abs_m = abs_err[static_cast<std::size_t>(0.9 * (n - 1))];
    r.max_abs_m = abs_err.back();
  } else {
    r.bias_m = r.rmse_m = r.mean_abs_m = r.p90_abs_m = r.max_abs_m = kNaN;
  }
  r.precision = Ratio(r.obstacle_tp, r.obstacle_map);

  // The ground seen (in map coordinates: seen cell (col, row) is map cell (col + sc, row + sr)):
  // coverage and the recall of true obstacles, the cells the map left empty included.
  auto seen_at = [&](int col, int row) { return At(rays, col - sc, row - sr) >= o.min_points; };
  for (int row = 0; row < rays.rows; ++row) {
    for (int col = 0; col < rays.cols; ++col) {
      if (!(rays.at<float>(row, col) >= o.min_points)) continue;
      const int mc = col + sc, mr = row + sr;
      if (!std::isfinite(At(true_elevation, mc - tc, mr - tr))) continue;  // outside the truth
      ++r.cells_seen;
      r.cells_seen_mapped += At(count, mc, mr) >= o.min_points;
      if (true_obstacle_at(mc, mr)) {
        ++r.obstacle_true;
        r.obstacle_found += any_near(mc, mr, tol, map_obstacle);
      }
    }
  }
  r.coverage = Ratio(r.cells_seen_mapped, r.cells_seen);
  r.recall = Ratio(r.obstacle_found, r.obstacle_true);

  // Rocks of at least the limit whose upper half both cameras saw (a sliver of a rock's foot at
  // an image's edge tells no one its height), mapped or not: found when a map obstacle cell's
  // centre lies within rock_near_m of the rock's centre.
  for (const TrueRock& rock : rocks) {
    if (rock.height_m < o.rock_height_m) continue;
    const int col = static_cast<int>(std::floor((rock.x_m - map.x_west_m) / map.cell_m));
    const int row = static_cast<int>(std::floor((map.y_north_m - rock.y_m) / map.cell_m));
    MapEvalResult::Rock& listed = r.rock_list.emplace_back();
    listed.x_m = rock.x_m;
    listed.y_m = rock.y_m;
    listed.height_m = rock.height_m;
    listed.top_rays = rock.top_rays;
    if (rock.top_rays >= 0 ? rock.top_rays < o.min_points : !seen_at(col, row)) continue;
    listed.scored = true;
    ++r.rocks;
    const int radius = static_cast<int>(std::ceil(o.rock_near_m / map.cell_m)) + 1;
    listed.found = any_near(col, row, radius, [&](int c, int rr) {
      const double dx = map.x_west_m + (c + 0.5) * map.cell_m - rock.x_m;
      const double dy = map.y_north_m - (rr + 0.5) * map.cell_m - rock.y_m;
      return dx * dx + dy * dy <= o.rock_near_m * o.rock_near_m && map_obstacle(c, rr);
    });
    r.rocks_found += listed.found;
  }
  r.rock_recall = Ratio(r.rocks_found, r.rocks);
  return r;
}

std::vector<io::GeoRaster> TrueRayCountViews(const fs::path& sim_dir, const std::vector<std::string>& stems,
                                             double cell_m, const std::vector<RayCountView>& views,
                                             int num_threads) {
  const std::size_t num_views = views.size();
  // Per view, the rocks by 1 m square (each listed in every square its ellipse's box touches).
  std::vector<std::map<std::pair<std::int64_t, std::int64_t>, std::vector<std::size_t>>> rocks_at(num_views);
  for (std::size_t v = 0; v < num_views; ++v) {
    if (views[v].rocks == nullptr) continue;
    for (std::size_t k = 0; k < views[v].rocks->size(); ++k) {
      TrueRock& rock = (*views[v].rocks)[k];
      rock.top_rays = 0;
      const double reach = rock.semi_major_m;
      for (auto i = static_cast<std::int64_t>(std::floor(rock.x_m - reach));
           i <= static_cast<std::int64_t>(std::floor(rock.x_m + reach)); ++i) {
        for (auto j = static_cast<std::int64_t>(std::floor(rock.y_m - reach));
             j <= static_cast<std::int64_t>(std::floor(rock.y_m + reach)); ++j) {
          rocks_at[v][{i, j}].push_back(k);
        }
      }
    }
  }
  const fs::path poses_path = sim_dir / "truth" / "poses.csv";
  const auto poses = mapping::IndexByStem(mapping::ReadPosesCsv(poses_path));
  for (const std::string& stem : stems) {
    LN_CHECK_INPUT(poses.count(stem) > 0) << "stem " << stem << ": no pose in " << poses_path.string();
  }
  for (const RayCountView& view : views) {
    if (view.stems == nullptr) continue;
    for (const std::string& stem : *view.stems) {
      LN_CHECK_INPUT(std::find(stems.begin(), stems.end(), stem) != stems.end())
          << "stem " << stem << ": no pose in " << poses_path.string();
    }
  }
  // Per view and frame, the world cells (i, j) = floor(x / cell), floor(y / cell) of its
  // points, and the rays on each rock's top. Each frame's truth is read once for every view.
  std::vector<std::vector<std::vector<std::pair<std::int64_t, std::int64_t>>>> cells(
      num_views, std::vector<std::vector<std::pair<std::int64_t, std::int64_t>>>(stems.size()));
  std::vector<std::vector<std::vector<long>>> top_rays(num_views, std::vector<std::vector<long>>(stems.size()));
  util::ParallelForEachItem(stems.size(), num_threads, [&](std::size_t k) {
    // The views that count this frame, and the range ahead each takes.
    std::vector<std::size_t> counting;
    std::vector<std::pair<double, double>> range(num_views);
    for (std::size_t v = 0; v < num_views; ++v) {
      if (views[v].stems != nullptr && views[v].stems->count(stems[k]) == 0) continue;
      counting.push_back(v);
      const MapEvalOptions& options = *views[v].options;
      double y_lo = options.seen_min_y_m, y_hi = options.seen_max_y_m;
      if (const auto it = options.requested_y_m.find(stems[k]); it != options.requested_y_m.end()) {
        y_lo = std::max(y_lo, it->second.first);
        y_hi = std::min(y_hi, it->second.second);
      }
      range[v] = {y_lo, y_hi};
      if (views[v].rocks != nullptr) top_rays[v][k].assign(views[v].rocks->size(), 0);
    }
    if (counting.empty()) return;
    const mapping::FramePose& p = poses.at(stems[k]);
    const Eigen::Isometry3d world_from_vehicle = TrueWorldFromVehicle(p);
    const fs::path xyz_path = sim_dir / "truth" / "xyz" / (stems[k] + ".exr");
    const fs::path disparity_path = sim_dir / "truth" / "disparity" / (stems[k] + ".pfm");
    const io::ExrImage xyz = io::ReadExr(xyz_path);
    LN_CHECK_INPUT(xyz.pixels.type() == CV_32FC3) << xyz_path.string() << ": truth XYZ is not 3 channels";
    const cv::Mat disparity = io::ReadPfm(disparity_path);
    LN_CHECK_INPUT(disparity.size() == xyz.pixels.size())
        << disparity_path.string() << ": not the size of " << xyz_path.string();
    // Distances ahead are horizontal (the level frame), as stereo-batch, the planner and
    // terrain-map take a requested interval.
    const Eigen::Vector2d heading = mapping::HeadingDirection(world_from_vehicle);
    const Eigen::Vector3d origin = world_from_vehicle.translation();
    for (int y = 0; y < xyz.pixels.rows; ++y) {
      const auto* pv = xyz.pixels.ptr<cv::Vec3f>(y);
      const auto* d = disparity.ptr<float>(y);
      for (int x = 0; x < xyz.pixels.cols; ++x) {
        // Both cameras see it (a finite true disparity), within the range ahead.
        if (!std::isfinite(d[x]) || !std::isfinite(pv[x][1])) continue;
        const Eigen::Vector3d w = world_from_vehicle * Eigen::Vector3d(pv[x][0], pv[x][1], pv[x][2]);
        const double ahead = heading.dot((w - origin).head<2>());
        const std::pair<std::int64_t, std::int64_t> cell(static_cast<std::int64_t>(std::floor(w.x() / cell_m)),
                                                         static_cast<std::int64_t>(std::floor(w.y() / cell_m)));
        for (const std::size_t v : counting) {
          if (ahead < range[v].first || ahead > range[v].second) continue;
          cells[v][k].push_back(cell);
          if (views[v].rocks == nullptr) continue;
          const auto near = rocks_at[v].find({static_cast<std::int64_t>(std::floor(w.x())),
                                              static_cast<std::int64_t>(std::floor(w.y()))});
          if (near == rocks_at[v].end()) continue;
          for (std::size_t r : near->second) top_rays[v][k][r] += (*views[v].rocks)[r].InUpperHalf(w.x(), w.y());
        }
      }
    }
  });
  std::vector<io::GeoRaster> counts;
  for (std::size_t v = 0; v < num_views; ++v) {
    if (views[v].rocks != nullptr) {
      for (const auto& frame : top_rays[v]) {
        for (std::size_t r = 0; r < frame.size(); ++r) (*views[v].rocks)[r].top_rays += frame[r];
      }
    }
    std::int64_t i_lo = 0, i_hi = -1, j_lo = 0, j_hi = -1;
    bool any = false;
    for (const auto& frame : cells[v]) {
      for (const auto& [i, j] : frame) {
        if (!any) {
          i_lo = i_hi = i;
          j_lo = j_hi = j;
          any = true;
        }
        i_lo = std::min(i_lo, i);
        i_hi = std::max(i_hi, i);
        j_lo = std::min(j_lo, j);
        j_hi = std::max(j_hi, j);
      }
    }
    LN_CHECK_INPUT(!any || (i_hi - i_lo < 100000 && j_hi - j_lo < 100000))
        << sim_dir.string() << ": the true points span more than 100000 cells";
    io::GeoRaster r;
    r.cell_m = cell_m;
    r.x_west_m = static_cast<double>(i_lo) * cell_m;
    r.y_north_m = static_cast<double>(j_hi + 1) * cell_m;
    io::RasterBand band;
    band.description = "count";
    band.pixels = cv::Mat(any ? static_cast<int>(j_hi - j_lo + 1) : 1, any ? static_cast<int>(i_hi - i_lo + 1) : 1,
                          CV_32FC1, cv::Scalar(0));
    for (const auto& frame : cells[v]) {
      for (const auto& [i, j] : frame) {
        band.pixels.at<float>(static_cast<int>(j_hi - j), static_cast<int>(i - i_lo)) += 1;
      }
    }
    r.bands.push_back(std::move(band));
    if (views[v].frame_cells != nullptr) *views[v].frame_cells = std::move(cells[v]);
    counts.push_back(std::move(r));
  }
  return counts;
}

io::GeoRaster TrueRayCounts(const fs::path& sim_dir, const std::vector<std::string>& stems, double cell_m,
                            const MapEvalOptions& options, int num_threads, std::vector<TrueRock>* rocks,
                            std::vector<std::vector<std::pair<std::int64_t, std::int64_t>>>* frame_cells) {
  RayCountView view;
  view.options = &options;
  view.rocks = rocks;
  view.frame_cells = frame_cells;
  return std::move(TrueRayCountViews(sim_dir, stems, cell_m, {view}, num_threads).front());
}

json MapEvalResult::ToJson() const {
  return {{"cells_compared", cells_compared},
          {"elevation_rmse_m", Number(rmse_m)},
          {"elevation_bias_m", Number(bias_m)},
          {"elevation_mean_abs_m", Number(mean_abs_m)},
          {"elevation_p90_abs_m", Number(p90_abs_m)},
          {"elevation_max_abs_m", Number(max_abs_m)},
          {"cells_large_error", cells_large_error},
          {"cells_seen", cells_seen},
          {"cells_seen_mapped", cells_seen_mapped},
          {"coverage", Number(coverage)},
          {"obstacle_cells_map", obstacle_map},
          {"obstacle_cells_true", obstacle_true},
          {"obstacle_true_positive", obstacle_tp},
          {"obstacle_false_positive", obstacle_fp},
          {"obstacle_true_found", obstacle_found},
          {"obstacle_precision", Number(precision)},
          {"obstacle_recall", Number(recall)},
          {"rocks", rocks},
          {"rocks_found", rocks_found},
          {"rock_recall", Number(rock_recall)},
          {"corridor_gap_m", Number(corridor_gap_m)},
          {"corridor_gap_stem", corridor_gap_stem}};
}

Table MapEvalResult::ToTable() const {
  Table t;
  t.title = "Terrain map against the true terrain";
  t.columns = {{"cells", "", "cells compared", 0},
               {"rmse", "cm", "elevation RMSE (cm)", 2},
               {"bias", "cm", "bias (cm)", 2},
               {"p90", "cm", "P90 abs. error (cm)", 2},
               {"coverage", "pct", "coverage of the ground seen (%)", 1},
               {"precision", "pct", "obstacle precision (%)", 1},
               {"recall", "pct", "obstacle recall (%)", 1},
               {"rocks", "", "rocks > limit", 0},
               {"rock_recall", "pct", "rock recall (%)", 1}};
  auto pct = [](double v, const std::string& why) { return Cell::NumberOr(100 * v, why); };
  t.AddRow({Cell::Number(static_cast<double>(cells_compared)), Cell::NumberOr(100 * rmse_m, "no cell"),
            Cell::NumberOr(100 * bias_m, "no cell"), Cell::NumberOr(100 * p90_abs_m, "no cell"),
            pct(coverage, "nothing seen"), pct(precision, "no obstacle mapped"), pct(recall, "no true obstacle"),
            Cell::Number(static_cast<double>(rocks)), pct(rock_recall, "no rock")});
  if (std::isfinite(corridor_gap_m)) {
    t.columns.push_back({"corridor_gap", "cm", "longest corridor gap (cm)", 1});
    t.rows.back().push_back(Cell::Number(100 * corridor_gap_m));
  }
  return t;
}

std::string MapEvalResult::BriefReport() const {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(1);
  s << "elevation RMSE " << 100 * rmse_m << " cm (bias " << 100 * bias_m << " cm) over " << cells_compared
    << " cells; coverage " << 100 * coverage << " %; obstacles precision " << 100 * precision << " %, recall "
    << 100 * recall << " %; rocks " << rocks_found << "/" << rocks;
  if (std::isfinite(corridor_gap_m)) s << "; longest corridor gap " << 100 * corridor_gap_m << " cm";
  return s.str();
}

namespace {

// A raster's band by name; nullptr when it has none.
const io::RasterBand* FindBand(const io::GeoRaster& r, const std::string& name) {
  for (const io::RasterBand& b : r.bands) {
    if (b.description == name) return &b;
  }
  return nullptr;
}

// The value of `band` at world (x, y), 0 outside or NaN.
double BandAt(const io::GeoRaster& r, const io::RasterBand& band, double x, double y) {
  const double col = std::floor((x - r.x_west_m) / r.cell_m), row = std::floor((r.y_north_m - y) / r.cell_m);
  if (col < 0 || row < 0 || col >= band.pixels.cols || row >= band.pixels.rows) return 0;
  cv::Mat v;
  band.pixels(cv::Rect(static_cast<int>(col), static_cast<int>(row), 1, 1)).convertTo(v, CV_64F);
  const double value = v.at<double>(0, 0);
  return std::isfinite(value) ? value : 0;
}

}  // namespace

void MeasureCorridorGaps(const io::GeoRaster& map, const io::GeoRaster& seen, const fs::path& sim_dir,
                         const MapEvalOptions& options, MapEvalResult* result) {
  result->corridor_gap_m = std::numeric_limits<double>::quiet_NaN();
  result->corridor_gap_stem.clear();
  if (options.requested_y_m.empty()) return;
  const io::RasterBand* count = FindBand(map, "count");
  LN_CHECK_INPUT(count != nullptr) << "the map has no count band (not a terrain-map elevation.tif)";
  const io::RasterBand& rays = seen.bands.at(0);
  const fs::path poses_path = sim_dir / "truth" / "poses.csv";
  const auto poses = mapping::IndexByStem(mapping::ReadPosesCsv(poses_path));
  const double step = 0.5 * map.cell_m;
  const int across = std::max(1, static_cast<int>(std::floor(options.corridor_width_m / step)));
  result->corridor_gap_m = 0;
  for (const auto& [stem, interval] : options.requested_y_m) {
    const auto it = poses.find(stem);
    LN_CHECK_INPUT(it != poses.end()) << "stem " << stem << ": no pose in " << poses_path.string();
    const mapping::FramePose& p = it->second;
    const Eigen::Isometry3d world_from_vehicle = TrueWorldFromVehicle(p);
    // The corridor on the level: y ahead along the heading, x to its right.
    const Eigen::Vector2d ahead = mapping::HeadingDirection(world_from_vehicle), right(ahead.y(), -ahead.x());
    const Eigen::Vector2d origin = world_from_vehicle.translation().head<2>();
    const double y_lo = std::max(options.seen_min_y_m, interval.first);
    const double y_hi = std::min(options.seen_max_y_m, interval.second);
    int run = 0;
    for (double y = y_lo; y <= y_hi; y += step) {
      int seen_samples = 0, mapped_samples = 0;
      for (int k = 0; k <= across; ++k) {
        const double x = -0.5 * options.corridor_width_m + options.corridor_width_m * k / across;
        const Eigen::Vector2d w = origin + y * ahead + x * right;
        seen_samples += BandAt(seen, rays, w.x(), w.y()) >= options.min_points;
        mapped_samples += BandAt(map, *count, w.x(), w.y()) >= options.min_points;
      }
      const bool seen_step = 2 * seen_samples >= across + 1, mapped_step = 2 * mapped_samples >= across + 1;
      run = seen_step && !mapped_step ? run + 1 : 0;
      if (run * step > result->corridor_gap_m) {
        result->corridor_gap_m = run * step;
        result->corridor_gap_stem = stem;
      }
    }
  }
}

MapEvalResult RunMapEvaluation(const fs::path& map_dir, const fs::path& sim_dir, const MapEvalOptions& options,
                               const fs::path& output_dir, int num_threads, const json& invocation) {
  options.Validate();
  util::Timer timer;
  const io::GeoRaster map = io::ReadGeoTiff(map_dir / "elevation.tif");
  const fs::path truth_path = sim_dir / "truth" / "terrain.tif";
  const io::GeoRaster truth = io::ReadGeoTiff(truth_path);
  const std::vector<TrueRock> true_rocks = ReadRocksCsv(sim_dir / "truth" / "rocks.csv");
  // The truth's layers, named with its file (a map's elevation.tif given as the truth said
  // only "truth: no band").
  for (const char* band : {"elevation_m", "obstacle", "relief_m", "slope_deg"}) {
    LN_CHECK_INPUT(truth.BandIndex(band) >= 0)
        << truth_path.string() << ": no band '" << band << "' (not simulate stereo's truth/terrain.tif)";
  }
  // The score: the ground the truth's pairs saw, whichever the map holds (a map that dropped a
  // pair is scored on that pair's ground too), whatever the pairs were asked for.
  std::vector<std::string> stems;
  for (const mapping::FramePose& p : mapping::ReadPosesCsv(sim_dir / "truth" / "poses.csv")) stems.push_back(p.stem);
  MapEvalOptions all_ground = options;
  all_ground.requested_y_m.clear();
  std::vector<TrueRock> rocks = true_rocks;
  std::vector<std::vector<std::pair<std::int64_t, std::int64_t>>> frame_cells;
  // With the requests the pairs were matched with, a second, labelled view, over the ground
  // each listed pair was asked for (mapped or not), with the corridor's gaps: counted in the
  // same reading of the truth.
  std::vector<RayCountView> views(1);
  views[0].options = &all_ground;
  views[0].rocks = &rocks;
  views[0].frame_cells = &frame_cells;
  std::set<std::string> listed;
  std::vector<TrueRock> requested_rocks = true_rocks;
  if (!options.requested_y_m.empty()) {
    for (const auto& entry : options.requested_y_m) listed.insert(entry.first);
    RayCountView view;
    view.options = &options;
    view.stems = &listed;
    view.rocks = &requested_rocks;
    views.push_back(view);
  }
  std::vector<io::GeoRaster> counts = TrueRayCountViews(sim_dir, stems, map.cell_m, views, num_threads);
  const io::GeoRaster& seen = counts[0];
  MapEvalResult result = EvaluateMap(map, truth, seen, rocks, all_ground);
  std::optional<MapEvalResult> requested;
  if (!options.requested_y_m.empty()) {
    const io::GeoRaster& requested_seen = counts[1];
    requested = EvaluateMap(map, truth, requested_seen, requested_rocks, options);
    MeasureCorridorGaps(map, requested_seen, sim_dir, options, &*requested);
  }
  // In the pairs' frames, with the poses the map was made with (its frames.csv).
  std::optional<VehicleFrameMapScore> local;
  FramePoseErrors pose_errors;
  const fs::path frames_path = map_dir / "frames.csv";
  if (fs::exists(frames_path)) {
    const std::vector<mapping::FramePose> used = mapping::ReadPosesCsv(frames_path);
    const std::vector<mapping::FramePose> true_poses = mapping::ReadPosesCsv(sim_dir / "truth" / "poses.csv");
    // Every pose finite and in the world before a cell is computed from it.
    for (const mapping::FramePose& p : used) p.Validate(frames_path.string());
    for (const mapping::FramePose& p : true_poses) p.Validate((sim_dir / "truth" / "poses.csv").string());
    pose_errors = CompareFramePoses(used, true_poses);
    local = EvaluateMapInVehicleFrames(map, truth, used, true_poses, stems, frame_cells, rocks, options, num_threads);
  }

  io::CreateOutputDirectory(output_dir);
  const Table table = result.ToTable();
  WriteTable(output_dir, "map", table);
  {
    std::ostringstream csv;
    csv.imbue(std::locale::classic());
    csv << "# lunarnav evaluate map: the rocks at least " << options.rock_height_m
        << " m tall; top_rays: true rays both cameras saw on the rock's upper half (-1: not counted); scored: "
           "top_rays >= min points; found: a map obstacle cell within "
        << options.rock_near_m << " m\n";
    csv << "x_m,y_m,height_m,top_rays,scored,found\n";
    csv << std::fixed << std::setprecision(4);
    for (const MapEvalResult::Rock& k : result.rock_list) {
      csv << k.x_m << "," << k.y_m << "," << k.height_m << "," << k.top_rays << "," << int{k.scored} << ","
          << int{k.found} << "\n";
    }
    io::WriteFileAtomic(output_dir / "rocks.csv", csv.str());
  }
  json j = util::SummaryHead("evaluate", invocation);
  j["subcommand"] = "map";
  j["inputs"] = {{"map", map_dir.string()}, {"truth", sim_dir.string()}, {"frames", stems.size()}};
  j["options"] = options.ToJson();
  j["result"] = result.ToJson();
  j["table"] = table.ToJson();
  if (requested) {
    Table view = requested->ToTable();
    view.title += " over the requested ground";
    WriteTable(output_dir, "requested", view);
    j["requested"] = requested->ToJson();
    j["requested_table"] = view.ToJson();
    LN_LOG(Info) << "over the requested ground: " << requested->BriefReport();
  }
  if (local) {
    const Table scores = MapScoresTable(result, *local, pose_errors);
    WriteTable(output_dir, "scores", scores);
    j["vehicle_frame"] = local->ToJson();
    j["poses_at_frames"] = pose_errors.ToJson();
    j["scores_table"] = scores.ToJson();
    LN_LOG(Info) << "in the pairs' frames: elevation RMSE " << 100 * local->rmse_m << " cm, largest "
                 << 100 * local->max_abs_m << " cm, coverage " << 100 * local->coverage << " %, precision "
                 << 100 * local->precision << " %, rocks " << local->rocks_every_view << "/" << local->rocks
                 << "; the poses: " << 100 * pose_errors.final_horizontal_m << " cm off at the last pair";
  }
  j["timings_s"] = {{"total", timer.ElapsedSeconds()}};
  io::WriteJsonAtomic(output_dir / "summary.json", j);
  return result;
}

}  // namespace lunarnav::evaluation
