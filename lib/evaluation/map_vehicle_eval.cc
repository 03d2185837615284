#include "evaluation/map_vehicle_eval.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <unordered_map>

#include "evaluation/map_rasters.h"
#include "util/check.h"
#include "util/parallel.h"

namespace lunarnav::evaluation {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kDeg = M_PI / 180.0;
using internal::Number;
using internal::Ratio;
using internal::TrueWorldFromVehicle;

double WrapDeg(double rad) { return std::remainder(rad / kDeg, 360.0); }

// A raster's cell at world (x, y): column and row (may lie outside).
struct CellIndex {
  int col, row;
};
CellIndex IndexOf(const io::GeoRaster& r, double x, double y) {
  return {static_cast<int>(std::floor((x - r.x_west_m) / r.cell_m)),
          static_cast<int>(std::floor((r.y_north_m - y) / r.cell_m))};
}

// The truth's surface at (x, y): its cell heights (cell means) interpolated bilinearly
// between cell centres, the nearest cell where a neighbour is missing; NaN outside.
double SurfaceAt(const io::GeoRaster& r, const cv::Mat& h, double x, double y) {
  const double u = (x - r.x_west_m) / r.cell_m - 0.5, v = (r.y_north_m - y) / r.cell_m - 0.5;
  const int c0 = static_cast<int>(std::floor(u)), r0 = static_cast<int>(std::floor(v));
  const double fu = u - c0, fv = v - r0;
  double sum = 0, weight = 0;
  for (int dr = 0; dr <= 1; ++dr) {
    for (int dc = 0; dc <= 1; ++dc) {
      const double z = internal::ValueAt(h, c0 + dc, r0 + dr);
      if (!std::isfinite(z)) continue;
      const double w = (dc ? fu : 1 - fu) * (dr ? fv : 1 - fv);
      sum += w * z;
      weight += w;
    }
  }
  if (weight >= 0.999) return sum / weight;
  const CellIndex i = IndexOf(r, x, y);
  return internal::ValueAt(h, i.col, i.row);
}

// A world cell (i, j) as one key, and back (cells well within 32 bits: 1e6 m / 1 cm).
std::uint64_t Key(std::int64_t i, std::int64_t j) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(i)) << 32) | static_cast<std::uint32_t>(j);
}
std::int64_t KeyI(std::uint64_t key) { return static_cast<std::int32_t>(static_cast<std::uint32_t>(key >> 32)); }
std::int64_t KeyJ(std::uint64_t key) { return static_cast<std::int32_t>(static_cast<std::uint32_t>(key)); }

struct PairScore {
  std::vector<double> errors;
  long seen = 0, seen_mapped = 0, obstacle_samples = 0, obstacle_tp = 0;
  std::vector<int> rock_state;  // per rock: -1 not seen, 0 seen not found, 1 found
};

}  // namespace

nlohmann::json FramePoseErrors::ToJson() const {
  return {{"frames", frames},
          {"path_m", path_m},
          {"final_horizontal_m", Number(final_horizontal_m)},
          {"max_horizontal_m", Number(max_horizontal_m)},
          {"max_vertical_m", Number(max_vertical_m)},
          {"drift_pct", Number(drift_pct)},
          {"heading_rms_deg", Number(heading_rms_deg)},
          {"pitch_rms_deg", Number(pitch_rms_deg)},
          {"roll_rms_deg", Number(roll_rms_deg)},
          {"heading_max_deg", Number(heading_max_deg)},
          {"pitch_max_deg", Number(pitch_max_deg)},
          {"roll_max_deg", Number(roll_max_deg)}};
}

FramePoseErrors CompareFramePoses(const std::vector<mapping::FramePose>& estimated,
                                  const std::vector<mapping::FramePose>& truth) {
  const std::map<std::string, mapping::FramePose> est = mapping::IndexByStem(estimated);
  FramePoseErrors e;
  double h2 = 0, p2 = 0, r2 = 0;
  const mapping::FramePose* previous = nullptr;
  double final_h = kNaN;
  for (const mapping::FramePose& t : truth) {
    const auto it = est.find(t.stem);
    if (it == est.end()) continue;
    const mapping::FramePose& a = it->second;
    if (previous != nullptr) e.path_m += std::hypot(t.x_m - previous->x_m, t.y_m - previous->y_m);
    previous = &t;
    ++e.frames;
    final_h = std::hypot(a.x_m - t.x_m, a.y_m - t.y_m);
    e.max_horizontal_m = std::max(e.max_horizontal_m, final_h);
    e.max_vertical_m = std::max(e.max_vertical_m, std::abs(a.z_m - t.z_m));
    const double dh = WrapDeg(a.heading_rad - t.heading_rad), dp = WrapDeg(a.pitch_rad - t.pitch_rad),
                 dr = WrapDeg(a.roll_rad - t.roll_rad);
    h2 += dh * dh;
    p2 += dp * dp;
    r2 += dr * dr;
    e.heading_max_deg = std::max(e.heading_max_deg, std::abs(dh));
    e.pitch_max_deg = std::max(e.pitch_max_deg, std::abs(dp));
    e.roll_max_deg = std::max(e.roll_max_deg, std::abs(dr));
  }
  if (e.frames == 0) {
    e.final_horizontal_m = e.max_horizontal_m = e.max_vertical_m = e.drift_pct = kNaN;
    e.heading_rms_deg = e.pitch_rms_deg = e.roll_rms_deg = kNaN;
    e.heading_max_deg = e.pitch_max_deg = e.roll_max_deg = kNaN;
    return e;
  }
  const double n = static_cast<double>(e.frames);
  e.final_horizontal_m = final_h;
  e.drift_pct = e.path_m > 0 ? 100.0 * final_h / e.path_m : kNaN;
  e.heading_rms_deg = std::sqrt(h2 / n);
  e.pitch_rms_deg = std::sqrt(p2 / n);
  e.roll_rms_deg = std::sqrt(r2 / n);
  return e;
}

nlohmann::json VehicleFrameMapScore::ToJson() const {
  return {{"pairs", pairs},
          {"samples", samples},
          {"elevation_rmse_m", Number(rmse_m)},
          {"elevation_bias_m", Number(bias_m)},
          {"elevation_p90_abs_m", Number(p90_abs_m)},
          {"elevation_max_abs_m", Number(max_abs_m)},
          {"samples_large_error", large_error},
          {"seen", seen},
          {"seen_mapped", seen_mapped},
          {"coverage", Number(coverage)},
          {"obstacle_samples", obstacle_samples},
          {"obstacle_true_positive", obstacle_tp},
          {"obstacle_precision", Number(precision)},
          {"rocks", rocks},
          {"rocks_found_in_every_view", rocks_every_view},
          {"rock_views", rock_views},
          {"rock_views_found", rock_views_found},
          {"rock_view_recall", Number(rock_view_recall)},
          {"worst_stem", worst_stem}};
}

VehicleFrameMapScore EvaluateMapInVehicleFrames(
    const io::GeoRaster& map, const io::GeoRaster& truth, const std::vector<mapping::FramePose>& estimated,
    const std::vector<mapping::FramePose>& truth_poses, const std::vector<std::string>& truth_stems,
    const std::vector<std::vector<std::pair<std::int64_t, std::int64_t>>>& frame_cells,
    const std::vector<TrueRock>& rocks, const MapEvalOptions& o, int num_threads) {
  o.Validate();
  LN_CHECK(frame_cells.size() == truth_stems.size()) << "one list of true cells per truth stem";
  const cv::Mat& elevation = internal::FloatBand(map, "elevation_m", "map");
  const cv::Mat& count = internal::FloatBand(map, "count", "map");
  const cv::Mat& obstacle = internal::FloatBand(map, "obstacle", "map");
  const cv::Mat& true_elevation = internal::FloatBand(truth, "elevation_m", "truth");
  const cv::Mat& true_relief = internal::FloatBand(truth, "relief_m", "truth");
  const cv::Mat& true_slope = internal::FloatBand(truth, "slope_deg", "truth");
  const std::map<std::string, mapping::FramePose> est = mapping::IndexByStem(estimated);
  const std::map<std::string, mapping::FramePose> tru = mapping::IndexByStem(truth_poses);
  const double cell = truth.cell_m;
  auto mapped = [&](CellIndex i) {
    const float n = internal::ValueAt(count, i.col, i.row);
    return std::isfinite(n) && n >= o.min_points && std::isfinite(internal::ValueAt(elevation, i.col, i.row));
  };
  auto near_relief = [&](double x, double y) {
    const CellIndex c = IndexOf(truth, x, y);
    for (int dr = -o.tolerance_cells; dr <= o.tolerance_cells; ++dr) {
      for (int dc = -o.tolerance_cells; dc <= o.tolerance_cells; ++dc) {
        const float relief = internal::ValueAt(true_relief, c.col + dc, c.row + dr);
        const float slope = internal::ValueAt(true_slope, c.col + dc, c.row + dr);
        if ((std::isfinite(relief) && relief >= o.relief_height_m) || (std::isfinite(slope) && slope > o.relief_slope_deg)) {
          return true;
        }
      }
    }
    return false;
  };
  // The rocks scored as the global score scores them.
  std::vector<std::size_t> scored;
  for (std::size_t r = 0; r < rocks.size(); ++r) {
    if (rocks[r].height_m >= o.rock_height_m && rocks[r].top_rays >= o.min_points) scored.push_back(r);
  }

  std::vector<std::size_t> pairs;
  for (std::size_t k = 0; k < truth_stems.size(); ++k) {
    const auto e = est.find(truth_stems[k]);
    const auto t = tru.find(truth_stems[k]);
    // A pose that is not finite places nothing (RunMapEvaluation refuses it first, by name).
    if (e != est.end() && t != tru.end() && e->second.IsFinite() && t->second.IsFinite()) pairs.push_back(k);
  }
  std::vector<PairScore> scores(pairs.size());
  util::ParallelForEachItem(pairs.size(), num_threads, [&](std::size_t n) {
    const std::size_t k = pairs[n];
    const Eigen::Isometry3d estimated_pose = TrueWorldFromVehicle(est.at(truth_stems[k]));
    const Eigen::Isometry3d true_pose = TrueWorldFromVehicle(tru.at(truth_stems[k]));
    // True world -> where the pair believes it is, and back.
    const Eigen::Isometry3d believed_from_true = estimated_pose * true_pose.inverse();
    const Eigen::Isometry3d true_from_believed = believed_from_true.inverse();
    std::unordered_map<std::uint64_t, int> rays;
    for (const auto& [i, j] : frame_cells[k]) ++rays[Key(i, j)];
    PairScore& s = scores[n];
    std::set<std::pair<int, int>> obstacle_cells;
    for (const auto& [key, n_rays] : rays) {
      if (n_rays < o.min_points) continue;
      const std::int64_t i = KeyI(key), j = KeyJ(key);
      const double x = (static_cast<double>(i) + 0.5) * cell, y = (static_cast<double>(j) + 0.5) * cell;
      const double z = SurfaceAt(truth, true_elevation, x, y);
      if (!std::isfinite(z)) continue;
      ++s.seen;
      const Eigen::Vector3d believed = believed_from_true * Eigen::Vector3d(x, y, z);
      const CellIndex m = IndexOf(map, believed.x(), believed.y());
      if (!mapped(m)) continue;
      ++s.seen_mapped;
      // What the map says there, in the true world as this pair would take it.
      const Eigen::Vector3d said(map.CellCentreX(m.col), map.CellCentreY(m.row), elevation.at<float>(m.row, m.col));
      const Eigen::Vector3d q = true_from_believed * said;
      const double truth_z = SurfaceAt(truth, true_elevation, q.x(), q.y());
      if (!std::isfinite(truth_z)) continue;
      s.errors.push_back(q.z() - truth_z);
      if (obstacle.at<float>(m.row, m.col) > 0 && obstacle_cells.insert({m.col, m.row}).second) {
        ++s.obstacle_samples;
        s.obstacle_tp += near_relief(q.x(), q.y());
      }
    }
    s.rock_state.assign(scored.size(), -1);
    for (std::size_t r = 0; r < scored.size(); ++r) {
      const TrueRock& rock = rocks[scored[r]];
      const std::int64_t i = static_cast<std::int64_t>(std::floor(rock.x_m / cell));
      const std::int64_t j = static_cast<std::int64_t>(std::floor(rock.y_m / cell));
      const auto it = rays.find(Key(i, j));
      if (it == rays.end() || it->second < o.min_points) continue;
      const double z = SurfaceAt(truth, true_elevation, rock.x_m, rock.y_m);
      const Eigen::Vector3d believed = believed_from_true * Eigen::Vector3d(rock.x_m, rock.y_m, std::isfinite(z) ? z : 0);
      s.rock_state[r] = 0;
      const int reach = static_cast<int>(std::ceil(o.rock_near_m / map.cell_m));
      const CellIndex c = IndexOf(map, believed.x(), believed.y());
      for (int dr = -reach; dr <= reach && s.rock_state[r] == 0; ++dr) {
        for (int dc = -reach; dc <= reach; ++dc) {
          const float ob = internal::ValueAt(obstacle, c.col + dc, c.row + dr);
          if (!(ob > 0) || !mapped({c.col + dc, c.row + dr})) continue;
          if (std::hypot(map.CellCentreX(c.col + dc) - believed.x(), map.CellCentreY(c.row + dr) - believed.y()) <=
              o.rock_near_m) {
            s.rock_state[r] = 1;
            break;
          }
        }
      }
    }
  });

  VehicleFrameMapScore v;
  v.pairs = static_cast<long>(pairs.size());
  std::vector<double> abs_errors;
  double sum = 0, sum2 = 0, worst = -1;
  std::vector<int> rock_seen(scored.size(), 0), rock_found(scored.size(), 0);
  for (std::size_t n = 0; n < pairs.size(); ++n) {
    const PairScore& s = scores[n];
    for (double e : s.errors) {
      sum += e;
      sum2 += e * e;
      abs_errors.push_back(std::abs(e));
      v.large_error += std::abs(e) > o.large_error_m;
      if (std::abs(e) > worst) {
        worst = std::abs(e);
        v.worst_stem = truth_stems[pairs[n]];
      }
    }
    v.seen += s.seen;
    v.seen_mapped += s.seen_mapped;
    v.obstacle_samples += s.obstacle_samples;
    v.obstacle_tp += s.obstacle_tp;
    for (std::size_t r = 0; r < scored.size(); ++r) {
      if (s.rock_state[r] < 0) continue;
      ++rock_seen[r];
      rock_found[r] += s.rock_state[r];
    }
  }
  v.samples = static_cast<long>(abs_errors.size());
  if (v.samples > 0) {
    const double n = static_cast<double>(v.samples);
    v.rmse_m = std::sqrt(sum2 / n);
    v.bias_m = sum / n;
    std::sort(abs_errors.begin(), abs_errors.end());
    v.p90_abs_m = abs_errors[static_cast<std::size_t>(std::floor(0.9 * (n - 1)))];
    v.max_abs_m = abs_errors.back();
  } else {
    v.rmse_m = v.bias_m = v.p90_abs_m = v.max_abs_m = kNaN;
  }
  v.coverage = Ratio(v.seen_mapped, v.seen);
  v.precision = Ratio(v.obstacle_tp, v.obstacle_samples);
  for (std::size_t r = 0; r < scored.size(); ++r) {
    if (rock_seen[r] == 0) continue;
    ++v.rocks;
    v.rocks_every_view += rock_found[r] == rock_seen[r];
    v.rock_views += rock_seen[r];
    v.rock_views_found += rock_found[r];
  }
  v.rock_view_recall = Ratio(v.rock_views_found, v.rock_views);
  return v;
}

Table MapScoresTable(const MapEvalResult& g, const VehicleFrameMapScore& v, const FramePoseErrors& p) {
  Table t;
  t.title = "Terrain map against the true terrain: globally and in each pair's frame";
  t.columns = {{"score", "", "score", 0},
               {"rmse", "cm", "RMSE (cm)", 2},
               {"bias", "cm", "bias (cm)", 2},
               {"max", "cm", "largest (cm)", 1},
               {"large", "", "> 30 cm", 0},
               {"coverage", "pct", "coverage (%)", 1},
               {"precision", "pct", "obstacle precision (%)", 1},
               {"rocks", "", "rocks found", 0},
               {"drift", "cm", "drift at the last pair (cm)", 1}};
  auto pct = [](double x, const std::string& why) { return Cell::NumberOr(100 * x, why); };
  const double drift = 100 * p.final_horizontal_m;
  t.AddRow({Cell::Text("global"), Cell::NumberOr(100 * g.rmse_m, "no cell"), Cell::NumberOr(100 * g.bias_m, "no cell"),
            Cell::NumberOr(100 * g.max_abs_m, "no cell"), Cell::Number(static_cast<double>(g.cells_large_error)),
            pct(g.coverage, "nothing seen"), pct(g.precision, "no obstacle mapped"),
            Cell::Text(std::to_string(g.rocks_found) + "/" + std::to_string(g.rocks)),
            Cell::NumberOr(drift, "no frame in both")});
  t.AddRow({Cell::Text("vehicle frame"), Cell::NumberOr(100 * v.rmse_m, "no sample"),
            Cell::NumberOr(100 * v.bias_m, "no sample"), Cell::NumberOr(100 * v.max_abs_m, "no sample"),
            Cell::Number(static_cast<double>(v.large_error)), pct(v.coverage, "nothing seen"),
            pct(v.precision, "no obstacle mapped"),
            Cell::Text(std::to_string(v.rocks_every_view) + "/" + std::to_string(v.rocks)),
            Cell::NumberOr(drift, "no frame in both")});
  t.notes.push_back(
      "vehicle frame: each pair's seen ground 2-10 m ahead where the pair believes it is, the map's height there "
      "against the true ground seen from its true pose, pooled over pairs; rocks: found in every pair that saw them");
  return t;
}

}  // namespace lunarnav::evaluation
