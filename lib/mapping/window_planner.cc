#include "mapping/window_planner.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "io/geotiff_io.h"
#include "stereo/window_requests.h"
#include "util/check.h"
#include "util/errors.h"
#include "util/format.h"

namespace lunarnav::mapping {

// What plan-windows writes, stereo-batch and terrain-map read back.
static_assert(kMaxRequestDistanceM == stereo::kMaxRequestY);

void WindowPlannerOptions::Validate() const {
  // Finite, and within what a rover's planner can mean (docs/reliability.md): a delay of
  // 1e308 s made requests of 1e307 m.
  LN_CHECK_ARG(std::isfinite(stereo_delay_s) && stereo_delay_s >= 0 && stereo_delay_s <= kMaxPlannerTimeS)
      << "stereo delay: must be in [0, " << kMaxPlannerTimeS << "] s, got " << stereo_delay_s;
  LN_CHECK_ARG(std::isfinite(horizon_m) && horizon_m > 0 && horizon_m <= kMaxRequestDistanceM)
      << "horizon: must be in (0, " << kMaxRequestDistanceM << "] m, got " << horizon_m;
  LN_CHECK_ARG(std::isfinite(overlap_m) && overlap_m >= 0 && overlap_m <= kMaxRequestDistanceM)
      << "overlap: must be in [0, " << kMaxRequestDistanceM << "] m, got " << overlap_m;
  LN_CHECK_ARG(std::isfinite(initial_speed_mps) && initial_speed_mps >= 0 && initial_speed_mps <= kMaxPlannerSpeedMps)
      << "initial speed: must be in [0, " << kMaxPlannerSpeedMps << "] m/s, got " << initial_speed_mps;
  LN_CHECK_ARG(std::isfinite(initial_cycle_s) && initial_cycle_s >= 0 && initial_cycle_s <= kMaxPlannerTimeS)
      << "initial cycle: must be in [0, " << kMaxPlannerTimeS << "] s, got " << initial_cycle_s;
}

nlohmann::json WindowPlannerOptions::ToJson() const {
  return {{"stereo_delay_s", stereo_delay_s},
          {"horizon_m", horizon_m},
          {"overlap_m", overlap_m},
          {"initial_speed_mps", initial_speed_mps},
          {"initial_cycle_s", initial_cycle_s},
          {"gravity", calib::ToString(gravity)}};
}

double MappedReachAhead(const MapLayers& map, const FramePose& pose, double from_y_m, double to_y_m, double width_m,
                        double before_t_s) {
  const double step = 0.5 * map.cell_m, s = std::sin(pose.heading_rad), c = std::cos(pose.heading_rad);
  const int across = std::max(1, static_cast<int>(std::floor(width_m / step)));
  const bool timed = !map.last_t_exact_s.empty() && std::isfinite(before_t_s);
  auto mapped = [&](double x_m, double y_m) {
    int col = 0, row = 0;
    return map.CellOf(x_m, y_m, &col, &row) && std::isfinite(map.elevation_m.at<float>(row, col)) &&
           (!timed || map.last_t_exact_s.at<double>(row, col) < before_t_s);
  };
  for (double y = from_y_m; y < to_y_m; y += step) {
    int count = 0;
    for (int k = 0; k <= across; ++k) {
      const double x = -0.5 * width_m + width_m * k / across;  // vehicle X (right)
      count += mapped(pose.x_m + x * c + y * s, pose.y_m - x * s + y * c);
    }
    if (2 * count < across + 1) return y;
  }
  return to_y_m;
}

MapLayers ReadMapElevation(const std::filesystem::path& map_dir, bool exact_times) {
  const std::filesystem::path path = map_dir / "elevation.tif";
  const io::GeoRaster r = io::ReadGeoTiff(path);
  MapLayers l;
  l.x_west_m = r.x_west_m;
  l.y_north_m = r.y_north_m;
  l.cell_m = r.cell_m;
  for (const io::RasterBand& b : r.bands) {
    if (b.description == "elevation_m") b.pixels.convertTo(l.elevation_m, CV_32F);
  }
  LN_CHECK_INPUT(!l.elevation_m.empty()) << path.string() << ": no elevation_m band (not a terrain-map output)";
  // Each cell's last time, exactly, from the sums.
  const std::filesystem::path state_path = map_dir / "state.tif";
  if (exact_times && std::filesystem::is_regular_file(state_path)) {
    const TerrainGrid grid = TerrainGrid::FromStateRaster(io::ReadGeoTiff(state_path), state_path.string());
    const auto i0 = static_cast<std::int64_t>(std::llround(l.x_west_m / l.cell_m));
    const auto j1 = static_cast<std::int64_t>(std::llround(l.y_north_m / l.cell_m)) - 1;
    l.last_t_exact_s = cv::Mat(l.elevation_m.size(), CV_64FC1, cv::Scalar(std::numeric_limits<double>::infinity()));
    for (int row = 0; row < l.elevation_m.rows; ++row) {
      for (int col = 0; col < l.elevation_m.cols; ++col) {
        const std::optional<CellStats> c = grid.Find({i0 + col, j1 - row});
        if (c && c->count > 0) l.last_t_exact_s.at<double>(row, col) = c->last_t_s;
      }
    }
  }
  return l;
}

std::vector<PlannedWindow> PlanWindows(const std::vector<FramePose>& poses, const calib::VehicleSpec& vehicle,
                                       const WindowPlannerOptions& o, const MapLayers* map) {
  o.Validate();
  LN_CHECK_INPUT(!poses.empty()) << "no pairs to plan";
  for (std::size_t k = 0; k < poses.size(); ++k) {
    poses[k].Validate("");
    LN_CHECK_INPUT(k == 0 || poses[k].t_s > poses[k - 1].t_s)
        << "stem " << poses[k].stem << ": time " << poses[k].t_s << " s does not follow " << poses[k - 1].stem
        << "'s " << poses[k - 1].t_s << " s";
  }
  const double g = calib::GravityMps2(o.gravity);
  auto distance = [&](std::size_t a, std::size_t b) {
    return std::hypot(std::hypot(poses[b].x_m - poses[a].x_m, poses[b].y_m - poses[a].y_m), poses[b].z_m - poses[a].z_m);
  };
  std::vector<PlannedWindow> plan;
  const std::size_t n = poses.size();
  for (std::size_t k = 0; k < n; ++k) {
    // Causal: only poses 0..k are known when pair k is requested.
    const FramePose& p = poses[k];
    PlannedWindow w;
    w.stem = p.stem;
    w.t_s = p.t_s;
    w.cycle_s = k == 0 ? o.initial_cycle_s : p.t_s - poses[k - 1].t_s;
    w.speed_mps = k == 0 ? o.initial_speed_mps : distance(k - 1, k) / w.cycle_s;
    w.d_stop_m = w.speed_mps > 0  // standing still, the vehicle is stopped
                     ? calib::StoppingDistanceM(vehicle.stop_time_s, w.speed_mps, vehicle.sliding_friction, g)
                     : 0.0;
    w.y_need_m = vehicle.FrontOfWheelsY() + w.d_stop_m + w.speed_mps * o.stereo_delay_s;
    w.y_max_m = w.y_need_m + o.horizon_m + w.speed_mps * w.cycle_s;
    if (map != nullptr) {
      // The closed loop: what the map holds ahead, whatever was requested before.
      w.covered_to_m = MappedReachAhead(*map, p, w.y_need_m, w.y_max_m, vehicle.width_m, p.t_s);
      w.y_min_m = std::clamp(w.covered_to_m - o.overlap_m, w.y_need_m, std::max(w.y_need_m, w.y_max_m - o.overlap_m));
    } else if (k == 0) {
      w.covered_to_m = std::numeric_limits<double>::quiet_NaN();
      w.y_min_m = w.y_need_m;
    } else {
      // The previous far edge in this pair's vehicle frame: less the distance driven along
      // this pair's forward axis.
      const FramePose& q = poses[k - 1];
      const double forward = (p.x_m - q.x_m) * std::sin(p.heading_rad) + (p.y_m - q.y_m) * std::cos(p.heading_rad);
      w.covered_to_m = plan.back().y_max_m - forward;
      w.y_min_m = std::clamp(w.covered_to_m - o.overlap_m, w.y_need_m, std::max(w.y_need_m, w.y_max_m - o.overlap_m));
    }
    // A request stereo can serve: finite and within kMaxRequestDistanceM (poses far apart in
    // a short time made a speed, and a request, of any size).
    LN_CHECK_INPUT(std::isfinite(w.y_min_m) && std::isfinite(w.y_max_m) && w.y_max_m <= kMaxRequestDistanceM)
        << "stem " << p.stem << ": the request reaches " << w.y_max_m << " m (speed " << w.speed_mps
        << " m/s over the last " << w.cycle_s << " s), beyond the " << kMaxRequestDistanceM
        << " m a request may reach: poses far apart in a short time?";
    plan.push_back(w);
  }
  return plan;
}

std::string RequestsCsv(const std::vector<PlannedWindow>& plan) {
  std::string s = "stem,y_min_m,y_max_m\n";
  for (const PlannedWindow& w : plan) s += w.stem + util::Format(",%.4f,%.4f\n", w.y_min_m, w.y_max_m);
  return s;
}

std::string PlanCsv(const std::vector<PlannedWindow>& plan) {
  std::string s =
      "# lunarnav plan-windows: per pair, from that pair's pose and the earlier ones only: speed (m/s), the\n"
      "# last cycle (s), stopping distance, nearest distance needed, far edge of the previous request in\n"
      "# this pair's vehicle frame (nan for the first), and the request (m)\n"
      "stem,t_s,speed_mps,cycle_s,d_stop_m,y_need_m,covered_to_m,y_min_m,y_max_m\n";
  for (const PlannedWindow& w : plan) {
    s += w.stem + util::Format(",%.3f,%.5f,%.3f,%.4f,%.4f,%.4f,%.4f,%.4f\n", w.t_s, w.speed_mps, w.cycle_s, w.d_stop_m,
                               w.y_need_m, w.covered_to_m, w.y_min_m, w.y_max_m);
  }
  return s;
}

}  // namespace lunarnav::mapping
