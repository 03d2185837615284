#include "mapping/terrain_grid.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include <algorithm>
#include <array>
#include <cmath>
#include <tuple>

#include "mapping/frame_poses.h"
#include "mapping/robust_plane.h"
#include "util/check.h"
#include "util/errors.h"

namespace lunarnav::mapping {

namespace {

constexpr int kTileShift = 6;  // tiles of 64 x 64 cells
constexpr int kTileSize = 1 << kTileShift;
constexpr double kMadToSigma = 1.4826;  // MAD of a normal distribution -> its standard deviation
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// The state raster of earlier versions: one set of sums per cell, these bands in order.
const std::array<const char*, 11> kStateBandsV1 = {"sum_w",    "sum_wz",   "sum_wzz", "z_min",  "z_max", "count",
                                                   "rejected", "last_t_s", "frames",  "z_min2", "z_max2"};
// The state raster now: the cell's bands, then for each height-bin slot k (1, 2, ...) these
// bands named "bin<k>_<name>" (count 0: the slot is empty).
const std::array<const char*, 4> kStateCellBands = {"ceiling", "ceiling2", "rejected", "bin_level"};
// The pairs' own steps (step1, step2, step_pairs) and the second last time came on
// 2026-12-07: a state without them (its bins of the first kStateBinBandsV2 bands) reads as one
// no pair measured a step in, each bin's second last time unknown (-infinity).
constexpr std::array<const char*, 15> kStateBinBands = {"index",  "sum_w",  "sum_wz",   "sum_wzz",    "z_min",
                                                        "z_max",  "count",  "last_t_s", "frames",     "z_min2",
                                                        "z_max2", "step1",  "step2",    "step_pairs", "last_t2_s"};
constexpr std::size_t kStateBinBandsV2 = 11;
constexpr float kInfF = std::numeric_limits<float>::infinity();
constexpr float kNaNF = std::numeric_limits<float>::quiet_NaN();

// The element at floor(q (n - 1)) of `values` in order (n > 0): its q-quantile; reorders them.
float QuantileInPlace(std::vector<float>& values, double q) {
  const auto at = values.begin() + static_cast<std::ptrdiff_t>(q * static_cast<double>(values.size() - 1));
  std::nth_element(values.begin(), at, values.end());
  return *at;
}

// The depth-edge rule's ground of a cell: this quantile of the pair's other points there;
// where the cell has too few, the lowest such ground of the cells within this many cells.
constexpr double kEdgeGroundQuantile = 0.1;
constexpr int kEdgeGroundReachCells = 2;

// floor(v) for |v| < 2^31 (a world coordinate within kMaxWorldCoordinateM, in cells): the
// truncation less one below zero, without the library call std::floor is on plain x86-64.
std::int32_t FloorToInt32(double v) {
  const auto t = static_cast<std::int32_t>(v);
  return t - (v < static_cast<double>(t) ? 1 : 0);
}

// The two lowest of {a1 <= a2} and {b1 <= b2}, into a1, a2.
void TwoLowest(float* a1, float* a2, float b1, float b2) {
  *a2 = std::min(std::max(*a1, b1), std::min(*a2, b2));
  *a1 = std::min(*a1, b1);
}

std::uint64_t TileKey(std::int64_t ti, std::int64_t tj) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(ti)) << 32) |
         static_cast<std::uint32_t>(tj);
}

std::int64_t FloorDiv(std::int64_t a, int shift) { return a >> shift; }  // arithmetic shift floors

// The support rule's steepest rise left unquestioned: 30 deg (its cotangent).
constexpr double kSupportCot = 1.7320508075688772;

// What the walk up an image column remembers (BinFrame): the lower bounds r - k s of the last
// three rays, the reach L (the largest of their least so far), and the last point kept.
struct ColumnWalk {
  std::array<float, 3> bound = {-std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity(),
                                -std::numeric_limits<float>::infinity()};
  float reach = -std::numeric_limits<float>::infinity();
  float last_range = std::numeric_limits<float>::infinity();
  float last_z = std::numeric_limits<float>::infinity();
};

// A point's ray for carving: its world position and its predicted horizontal error.
struct Ray {
  double x = 0, y = 0;
  float z = 0, sigma_h = 0;
  std::uint32_t point = 0;  // its index in the frame's binned points
};
// One point in this many casts its ray (the ceiling is the kCeilingSupport-th lowest of many).
constexpr std::size_t kRayStride = 8;

// One point in this many samples the pair's ground plane (for the ground-only points).
constexpr std::size_t kPlaneStride = 32;
// The plane needs this many samples; their largest flat part is the ground (within
// kPlaneInlierM of the plane, its slope at most kPlaneMaxSlope), the robust scale of the fit
// at least kPlaneScaleM.
constexpr std::size_t kPlaneMinSamples = 50;
constexpr double kPlaneInlierM = 0.05;
constexpr double kPlaneMaxSlope = 0.5;
constexpr double kPlaneScaleM = 0.03;
// The plane is the ground only where it passes within this of the vehicle's own ground point
// (the vehicle frame's origin): a view filled by a car's flank fits the car, metres.
constexpr double kPlaneOriginToleranceM = 0.3;
// Lone objects: the reach, in cells, within which a standing point the pair placed makes the
// pair's uncertain standing points its spill (TerrainMapOptions::lone_object_height_m).
constexpr std::int64_t kLoneObjectReachCells = 2;
// The most cells a frame's points may span (its box's per-cell arrays), beyond which they lie
// implausibly far (bad input: a maximum range keeps them out).
constexpr std::int64_t kMaxFrameBoxCells = 50'000'000;

// The pair's ground: the dominant plane of a sample of its points (about their mean place).
struct GroundPlaneFit {
  double x0 = 0, y0 = 0;
  Eigen::Vector3d p = Eigen::Vector3d::Zero();  // height, slope along x, slope along y
  double At(double x, double y) const { return p[0] + p[1] * (x - x0) + p[2] * (y - y0); }
};

std::optional<GroundPlaneFit> FitGround(std::vector<PlaneSample>& samples) {
  if (samples.size() < kPlaneMinSamples) return std::nullopt;
  GroundPlaneFit g;
  for (const PlaneSample& s : samples) {
    g.x0 += s.dx;
    g.y0 += s.dy;
  }
  g.x0 /= static_cast<double>(samples.size());
  g.y0 /= static_cast<double>(samples.size());
  for (PlaneSample& s : samples) s = {s.dx - g.x0, s.dy - g.y0, s.z};
  const std::optional<Eigen::Vector3d> p = FitDominantPlane(samples, kPlaneInlierM, kPlaneMaxSlope, kPlaneScaleM);
  if (!p) return std::nullopt;
  g.p = *p;
  return g;
}

// Walks the ray from `camera` to the point (x, y, z) cell by cell (2-D, over the lattice of
// cells of `cell_m`) along its stretch [s0, s1] of horizontal distance from the camera, and
// calls visit(i, j, h_in, h_out) with each cell's index and the ray's heights where it enters
// and leaves the cell (or the stretch), until visit returns false.
template <typename Visit>
void WalkRay(const Eigen::Vector3d& camera, double x, double y, double z, double s0, double s1, double cell_m,
             Visit visit) {
  const double dx = x - camera.x(), dy = y - camera.y();
  const double length = std::sqrt(dx * dx + dy * dy);
  if (!(length > 0) || !(s1 > s0)) return;
  const double ux = dx / length, uy = dy / length, c = cell_m, inv_cell = 1.0 / c;
  std::int64_t i = static_cast<std::int64_t>(std::floor((camera.x() + ux * s0) * inv_cell));
  std::int64_t j = static_cast<std::int64_t>(std::floor((camera.y() + uy * s0) * inv_cell));
  const int step_i = ux > 0 ? 1 : -1, step_j = uy > 0 ? 1 : -1;
  const double inf = std::numeric_limits<double>::infinity();
  // The ray's distance from the camera where it next crosses a column (row) boundary.
  double next_x = ux != 0 ? ((ux > 0 ? i + 1 : i) * c - camera.x()) / ux : inf;
  double next_y = uy != 0 ? ((uy > 0 ? j + 1 : j) * c - camera.y()) / uy : inf;
  const double delta_x = ux != 0 ? c / std::abs(ux) : inf, delta_y = uy != 0 ? c / std::abs(uy) : inf;
  const double slope = (z - camera.z()) / length;
  double s_in = s0;
  for (int guard = 0; guard < 100000; ++guard) {
    const double s_out = std::min({next_x, next_y, s1});
    if (!visit(i, j, camera.z() + slope * s_in, camera.z() + slope * s_out) || s_out >= s1) break;
    s_in = s_out;
    if (next_x < next_y) {
      i += step_i;
      next_x += delta_x;
    } else {
      j += step_j;
      next_y += delta_y;
    }
  }
}

// The stretch of a ray that says something about the cells it crosses: the last `reach_m`
// before its point, less twice the point's horizontal error and half a cell, where the point
// may lie in truth. {s0, s1} in horizontal distance from the camera.
std::pair<double, double> RayStretch(const Eigen::Vector3d& camera, double x, double y, double sigma_h, double reach_m,
                                     double cell_m) {
  const double length = std::hypot(x - camera.x(), y - camera.y());
  return {std::max(0.0, length - reach_m), length - 2.0 * sigma_h - 0.5 * cell_m};
}

// Walks `ray` over its stretch; in each cell it crosses, the lowest height of the ray there
// (where it leaves the cell: the ray descends) joins the cell's kCeilingSupport lowest in
// `ceilings` (box i0, j0, nx x ny). Returns 1 when the ray crossed a cell, else 0.
int CastRay(const Eigen::Vector3d& camera, const Ray& ray, const TerrainMapOptions& o, std::int32_t i0, std::int32_t j0,
            std::int64_t nx, std::int64_t ny, float* ceilings) {
  if (!(ray.z < camera.z())) return 0;
  const auto [s0, s1] = RayStretch(camera, ray.x, ray.y, ray.sigma_h, o.carve_reach_m, o.cell_m);
  if (!(s1 > s0)) return 0;
  WalkRay(camera, ray.x, ray.y, ray.z, s0, s1, o.cell_m, [&](std::int64_t i, std::int64_t j, double, double h_out) {
    const std::int64_t li = i - i0, lj = j - j0;
    if (li >= 0 && lj >= 0 && li < nx && lj < ny) {
      float h = static_cast<float>(h_out);
      for (float* t = ceilings + (lj * nx + li) * kCeilingSupport; t != ceilings + (lj * nx + li + 1) * kCeilingSupport;
           ++t) {
        if (h < *t) std::swap(h, *t);
      }
    }
    return true;
  });
  return 1;
}

// The smaller of two one-sided differences when they agree in sign, else 0 (minmod).
double MinMod(double a, double b) {
  if (a * b <= 0) return 0.0;
  return std::abs(a) < std::abs(b) ? a : b;
}

// What the obstacle rules read of a cell: judged (enough points), its elevation, and the top
// and the low its step rule takes.
struct StepCell {
  bool judged = false;
  double elevation = 0, top = 0, low = 0;
};

// The step rule at a judged cell from its 3 x 3 neighbourhood, at(dx, dy) the cell dx east
// and dy north of it (at(0, 0) the cell): the cell's top over the lowest of the
// neighbourhood's lows, each neighbour's carried to the cell along the local ground slope (the
// minmod of the one-sided slopes, so that an even slope is no step and at a step the slope is
// 0). Sets the slope (dz/dx east, dz/dy north) and how many neighbours were judged.
template <typename At>
double StepAt(const At& at, double cell_m, double* gx, double* gy, int* neighbours) {
  const StepCell self = at(0, 0);
  auto slope = [&](int dx0, int dy0, int dx1, int dy1) {
    const StepCell a = at(dx0, dy0), b = at(dx1, dy1);
    if (!a.judged || !b.judged) return 0.0;
    return MinMod((self.elevation - a.elevation) / cell_m, (b.elevation - self.elevation) / cell_m);
  };
  *gx = slope(-1, 0, 1, 0);
  *gy = slope(0, -1, 0, 1);
  double lowest = self.low;
  *neighbours = 0;
  for (int dy = -1; dy <= 1; ++dy) {
    for (int dx = -1; dx <= 1; ++dx) {
      if (dx == 0 && dy == 0) continue;
      const StepCell c = at(dx, dy);
      if (!c.judged) continue;
      lowest = std::min(lowest, c.low - *gx * dx * cell_m - *gy * dy * cell_m);
      ++*neighbours;
    }
  }
  return self.top - lowest;
}

// A cell's top and low for the step rule: its highest and lowest points, trimmed to within
// extreme_k and low_extreme_k roughnesses of its mean (ObstacleOptions).
double TrimmedTop(double raw, double mean, double roughness, const ObstacleOptions& o) {
  if (!std::isfinite(roughness) || !std::isfinite(o.extreme_k)) return raw;
  return std::min(raw, mean + o.extreme_k * roughness);
}
double TrimmedLow(double raw, double mean, double roughness, const ObstacleOptions& o) {
  if (!std::isfinite(roughness) || !std::isfinite(o.low_extreme_k)) return raw;
  return std::max(raw, mean - o.low_extreme_k * roughness);
}

}  // namespace

void ObstacleOptions::Validate() const {
  LN_CHECK_ARG(std::isfinite(step_height_m) && step_height_m > 0) << "obstacle height: must be > 0 m";
  LN_CHECK_ARG(max_slope_deg > 0 && max_slope_deg < 90) << "slope limit: must be in (0, 90) deg";
  LN_CHECK_ARG(min_points >= 1) << "obstacle min points: must be >= 1";
  LN_CHECK_ARG(extreme_k > 0) << "obstacle extremes: must be > 0 roughnesses (inf: raw)";
  LN_CHECK_ARG(low_extreme_k > 0) << "obstacle low extremes: must be > 0 roughnesses (inf: raw)";
  LN_CHECK_ARG(std::isfinite(step_tolerance_m) && step_tolerance_m >= 0 && step_tolerance_m < step_height_m)
      << "step tolerance: must be in [0, obstacle height)";
  LN_CHECK_ARG(pair_step_support >= 0 && pair_step_support <= 2) << "pair step support: must be 0, 1 or 2 pairs";
}

nlohmann::json ObstacleOptions::ToJson() const {
  auto number = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json("inf"); };
  return {{"step_height_m", step_height_m},
          {"max_slope_deg", max_slope_deg},
          {"min_points", min_points},
          {"extreme_k", number(extreme_k)},
          {"low_extreme_k", number(low_extreme_k)},
          {"step_tolerance_m", step_tolerance_m},
          {"pair_step_support", pair_step_support}};
}

void TerrainMapOptions::Validate() const {
  LN_CHECK_ARG(cell_m >= 0.01 && cell_m <= 10) << "cell: must be in [0.01, 10] m, got " << cell_m;
  LN_CHECK_ARG(gate_k > 0) << "gate: must be > 0 (inf: off)";
  LN_CHECK_ARG(std::isfinite(gate_floor_m) && gate_floor_m >= 0) << "gate floor: must be >= 0 m";
  LN_CHECK_ARG(gate_min_points >= 1) << "gate min points: must be >= 1";
  LN_CHECK_ARG(visibility_k > 0) << "visibility: must be > 0 (inf: off)";
  LN_CHECK_ARG(std::isfinite(visibility_floor_m) && visibility_floor_m >= 0) << "visibility floor: must be >= 0 m";
  LN_CHECK_ARG(support_rise_m > 0) << "support rise: must be > 0 m (inf: off)";
  LN_CHECK_ARG(carve_tolerance_m >= 0) << "carve tolerance: must be >= 0 m (inf: off)";
  LN_CHECK_ARG(moved_height_m > 0) << "moved height: must be > 0 m (inf: off)";
  LN_CHECK_ARG(std::isfinite(carve_reach_m) && carve_reach_m > 0) << "carve reach: must be > 0 m";
  LN_CHECK_ARG(hidden_tolerance_m >= 0) << "hidden tolerance: must be >= 0 m (inf: off)";
  LN_CHECK_ARG(hidden_ground_quantile >= 0 && hidden_ground_quantile <= 0.5)
      << "hidden ground quantile: must be in [0, 0.5]";
  LN_CHECK_ARG(std::isfinite(frame_floor_m) && frame_floor_m > 0) << "frame floor: must be > 0 m";
  LN_CHECK_ARG(std::isfinite(default_sigma_m) && default_sigma_m > 0) << "default sigma: must be > 0 m";
  LN_CHECK_ARG(max_range_m > 0) << "max range: must be > 0 m";
  LN_CHECK_ARG(max_horizontal_sigma_cells > 0) << "max horizontal sigma: must be > 0 cells";
  LN_CHECK_ARG(!std::isnan(ground_sigma_cells)) << "ground sigma: must be a number of cells";
  LN_CHECK_ARG(std::isfinite(ground_gate_m) && ground_gate_m > 0) << "ground gate: must be > 0 m";
  LN_CHECK_ARG(lone_object_height_m > 0) << "lone object height: must be > 0 m (inf: off)";
  LN_CHECK_ARG(edge_margin_px >= 0 && edge_margin_px <= internal::kEdgeRowPad)
      << "edge margin: must be in 0..64 px (0: off)";
  LN_CHECK_ARG(std::isfinite(edge_step_px) && edge_step_px > 0) << "edge step: must be > 0 px";
  LN_CHECK_ARG(std::isfinite(edge_height_m) && edge_height_m >= 0) << "edge height: must be >= 0 m";
  LN_CHECK_ARG(min_frames >= 1) << "min frames: must be >= 1";
  LN_CHECK_ARG(!window_m || (std::isfinite(*window_m) && *window_m >= 4 * cell_m))
      << "window-m: must be a finite size of at least 4 cells (" << 4 * cell_m << " m), got " << *window_m;
  LN_CHECK_ARG(max_cells >= 1) << "max map cells: must be >= 1";
  obstacles.Validate();
}

nlohmann::json TerrainMapOptions::ToJson() const {
  auto number = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json("inf"); };
  return {{"cell_m", cell_m},
          {"gate_k", number(gate_k)},
          {"gate_floor_m", gate_floor_m},
          {"gate_min_points", gate_min_points},
          {"visibility_k", number(visibility_k)},
          {"visibility_floor_m", visibility_floor_m},
          {"support_rise_m", number(support_rise_m)},
          {"carve_tolerance_m", number(carve_tolerance_m)},
          {"moved_height_m", number(moved_height_m)},
          {"carve_reach_m", carve_reach_m},
          {"hidden_tolerance_m", number(hidden_tolerance_m)},
          {"hidden_ground_quantile", hidden_ground_quantile},
          {"frame_floor_m", frame_floor_m},
          {"default_sigma_m", default_sigma_m},
          {"max_range_m", number(max_range_m)},
          {"max_horizontal_sigma_cells", number(max_horizontal_sigma_cells)},
          {"ground_sigma_cells", number(ground_sigma_cells)},
          {"ground_gate_m", ground_gate_m},
          {"lone_object_height_m", number(lone_object_height_m)},
          {"edge_margin_px", edge_margin_px},
          {"edge_step_px", edge_step_px},
          {"edge_height_m", edge_height_m},
          {"min_frames", min_frames},
          {"window_m", window_m ? nlohmann::json(*window_m) : nlohmann::json(nullptr)},
          {"max_cells", max_cells},
          {"obstacles", obstacles.ToJson()}};
}

void CellStats::Merge(const CellStats& o) {
  sum_w += o.sum_w;
  sum_wz += o.sum_wz;
  sum_wzz += o.sum_wzz;
  // The two lowest of the four lows and the two highest of the four highs.
  z_min2 = std::min(std::max(z_min, o.z_min), std::min(z_min2, o.z_min2));
  z_max2 = std::max(std::min(z_max, o.z_max), std::max(z_max2, o.z_max2));
  step2 = std::max(std::min(step1, o.step1), std::max(step2, o.step2));
  step1 = std::max(step1, o.step1);
  step_pairs += o.step_pairs;
  z_min = std::min(z_min, o.z_min);
  z_max = std::max(z_max, o.z_max);
  count += o.count;
  rejected += o.rejected;
  frames += o.frames;
  last_t2_s = std::max(std::min(last_t_s, o.last_t_s), std::max(last_t2_s, o.last_t2_s));
  last_t_s = std::max(last_t_s, o.last_t_s);
  TwoLowest(&ceiling, &ceiling2, o.ceiling, o.ceiling2);
  carved_points += o.carved_points;
  carved_frames += o.carved_frames;
  moved_points += o.moved_points;
  moved_frames += o.moved_frames;
}

double CellStats::StdDev() const {
  if (count == 0) return std::numeric_limits<double>::quiet_NaN();
  const double m = Mean();
  return std::sqrt(std::max(0.0, sum_wzz / sum_w - m * m));
}

double CellStats::Sigma() const {
  return count == 0 ? std::numeric_limits<double>::quiet_NaN() : 1.0 / std::sqrt(sum_w);
}

// A pair's own steps (ObstacleOptions::pair_step_support): on `cells`, the pair's cells of
// its box (i0, j0, nx x ny), in the box's order, the step rule on the pair's own points: at
// each cell where it has min_points and so has a neighbour, its top (the third highest point,
// trimmed) over the neighbourhood's lows, with the slope of its own means. One pair's points
// share one pose, so two pairs' height errors do not make its steps.
void PairSteps(const ObstacleOptions& o, double cell_m, std::int64_t i0, std::int64_t j0, std::int64_t nx,
               std::int64_t ny, std::vector<std::pair<CellIndex, CellStats>>* cells, std::vector<StepCell>* box) {
  box->assign(static_cast<std::size_t>(nx * ny), StepCell{});
  for (const auto& [index, cell] : *cells) {
    if (static_cast<int>(cell.count) < o.min_points) continue;
    StepCell& s = (*box)[static_cast<std::size_t>((index.j - j0) * nx + (index.i - i0))];
    s.judged = true;
    s.elevation = cell.Mean();
    const double rough = cell.StdDev();
    s.top = TrimmedTop(cell.z_max2, s.elevation, rough, o);
    s.low = TrimmedLow(cell.z_min, s.elevation, rough, o);
  }
  for (auto& [index, cell] : *cells) {
    const std::int64_t li = index.i - i0, lj = index.j - j0;
    if (!(*box)[static_cast<std::size_t>(lj * nx + li)].judged) continue;
    auto at = [&](int dx, int dy) {
      const std::int64_t a = li + dx, b = lj + dy;
      if (a < 0 || b < 0 || a >= nx || b >= ny) return StepCell{};
      return (*box)[static_cast<std::size_t>(b * nx + a)];
    };
    double gx = 0, gy = 0;
    int neighbours = 0;
    const double step = StepAt(at, cell_m, &gx, &gy, &neighbours);
    if (neighbours == 0) continue;  // nothing around it seen by this pair: no step of its own
    cell.step1 = static_cast<float>(step);
    cell.step_pairs = 1;
  }
}

FrameContribution BinFrame(const cv::Mat& xyz, const cv::Mat& sigma, const Eigen::Isometry3d& world_from_vehicle,
                           double t_s, const TerrainMapOptions& o, const ElevationErrorModel* error_model,
                           double y_min_m, double y_max_m) {
  LN_CHECK(xyz.type() == CV_32FC3) << "xyz must be CV_32FC3";
  LN_CHECK(sigma.empty() || (sigma.type() == CV_32FC3 && sigma.size() == xyz.size())) << "sigma: CV_32FC3 of xyz's size";
  FrameContribution out;
  const Eigen::Matrix3d r = world_from_vehicle.linear();
  const Eigen::Vector3d t = world_from_vehicle.translation();
  const double inv_cell = 1.0 / o.cell_m;
  // A requested interval is of horizontal distance ahead (the level frame: the vehicle's frame
  // turned by its pitch and roll), as stereo-batch and the planner take it.
  const bool interval = std::isfinite(y_min_m) || std::isfinite(y_max_m);
  const Eigen::Vector2d heading = HeadingDirection(world_from_vehicle);
  const double max_range2 = o.max_range_m * o.max_range_m;
  const double default_w = 1.0 / (o.default_sigma_m * o.default_sigma_m);
  const double max_h2 = o.max_horizontal_sigma_cells * o.cell_m * o.max_horizontal_sigma_cells * o.cell_m;
  const double ground_h2 = o.ground_sigma_cells * o.cell_m * o.ground_sigma_cells * o.cell_m;

  // Buffers kept per thread from frame to frame (a frame's worth of points each).
  struct Buffers {
    std::vector<std::int32_t> ci, cj;
    std::vector<float> zs, ws, sz, sw, scratch, kept;
    std::vector<std::uint32_t> start, local, fill;
    std::vector<ColumnWalk> walk;
    std::vector<Ray> rays;
    std::vector<float> ceilings;  // per cell of the frame's box, its kCeilingSupport lowest ray heights
    std::vector<std::uint32_t> src;
    std::vector<std::uint8_t> accepted;
    std::vector<float> lowest;  // per cell of the frame's box, the hidden rule's ground
    std::vector<std::pair<CellIndex, CellStats>> seen;
    std::vector<std::array<double, 4>> ground_only;  // candidates: world x, y, z and weight
    std::vector<float> row_disparity;                // the row's points' disparities (the edge rule), padded
    std::vector<std::uint8_t> row_edge;              // per column of the row: at a depth edge
    std::vector<std::uint8_t> at_edge, sorted_at_edge;  // by pass 1's index and sorted: at a depth edge
    std::vector<float> edge_ground;                  // per cell of the box: its own ground (NaN: unknown)
    std::vector<float> edge_floor;                   // per cell of the box: the ground its edge points meet
    std::vector<PlaneSample> plane;                  // a sample of the other points: world x, y, z
    std::vector<std::size_t> lone;                   // the ground-only candidates standing high: their index
    std::vector<std::uint8_t> standing;              // per cell of the placed points' box: one stands high
    std::vector<StepCell> steps;                     // per cell of the box: what the pair's step rule reads
  };
  static thread_local Buffers buf;
  std::vector<std::int32_t>& ci = buf.ci;
  std::vector<std::int32_t>& cj = buf.cj;
  std::vector<float>& zs = buf.zs;
  std::vector<float>& ws = buf.ws;
  std::vector<std::array<double, 4>>& ground_only = buf.ground_only;
  std::vector<std::uint8_t>& at_edge = buf.at_edge;
  std::vector<PlaneSample>& plane = buf.plane;
  ci.clear();
  cj.clear();
  zs.clear();
  ws.clear();
  ground_only.clear();
  at_edge.clear();
  plane.clear();
  // Carving and hidden observations: the rays start at the reference camera.
  const bool carving = error_model != nullptr && std::isfinite(o.carve_tolerance_m);
  const bool hiding = error_model != nullptr && std::isfinite(o.hidden_tolerance_m);
  const Eigen::Vector3d camera = error_model != nullptr
                                     ? Eigen::Vector3d(world_from_vehicle * error_model->ReferenceCamera())
                                     : Eigen::Vector3d::Zero();
  std::vector<Ray>& rays = buf.rays;
  rays.clear();

  // Pass 1: points to world cells, rows bottom up (rays rising) for the visibility rule.
  const std::size_t capacity = xyz.total();
  ci.reserve(capacity);
  cj.reserve(capacity);
  zs.reserve(capacity);
  ws.reserve(capacity);
  std::int32_t i0 = std::numeric_limits<std::int32_t>::max(), j0 = i0, i1 = std::numeric_limits<std::int32_t>::min(),
               j1 = i1;
  long edge_points = 0;  // points binned at a depth edge (at_edge), judged per cell in pass 3
  auto bin = [&](double wx, double wy, double wz, double w, bool edge = false) {  // a point in, its cell
    if (edge || edge_points > 0) {
      at_edge.resize(zs.size(), 0);
      at_edge.push_back(edge ? 1 : 0);
      edge_points += edge;
    }
    const std::int32_t i = FloorToInt32(wx * inv_cell), j = FloorToInt32(wy * inv_cell);
    i0 = std::min(i0, i);
    i1 = std::max(i1, i);
    j0 = std::min(j0, j);
    j1 = std::max(j1, j);
    ci.push_back(i);
    cj.push_back(j);
    zs.push_back(static_cast<float>(wz));
    ws.push_back(static_cast<float>(w));
  };
  const bool visibility = std::isfinite(o.visibility_k);
  const bool support = std::isfinite(o.support_rise_m);
  std::vector<ColumnWalk>& walk = buf.walk;
  if (visibility || support) walk.assign(static_cast<std::size_t>(xyz.cols), ColumnWalk{});
  // Depth edges: each row's disparities, to find a nearer point within the margin.
  const bool edges = error_model != nullptr && o.edge_margin_px > 0;
  std::vector<float>& row_disparity = buf.row_disparity;
  std::vector<std::uint8_t>& row_edge = buf.row_edge;
  for (int row = xyz.rows - 1; row >= 0; --row) {
    const float* p = xyz.ptr<float>(row);
    const float* s = sigma.empty() ? nullptr : sigma.ptr<float>(row);
    if (edges) {
      row_disparity.assign(static_cast<std::size_t>(xyz.cols + 2 * internal::kEdgeRowPad), kNaNF);
      float* d = row_disparity.data() + internal::kEdgeRowPad;
      bool any = false;
      for (int col = 0; col < xyz.cols; ++col) {
        const float* q = p + 3 * col;
        if (std::isfinite(q[0]) && std::isfinite(q[1]) && std::isfinite(q[2])) {
          d[col] = static_cast<float>(error_model->DisparityPx(q[0], q[1], q[2]));
          any = true;
        }
      }
      if (!any) continue;  // a row outside the band the pair was matched in
      row_edge.resize(static_cast<std::size_t>(xyz.cols));
      internal::DepthEdgeRow(d, xyz.cols, o.edge_margin_px, static_cast<float>(o.edge_step_px), row_edge.data());
    }
    for (int col = 0; col < xyz.cols; ++col, p += 3) {
      const float x = p[0], y = p[1], z = p[2];
      if (!(std::isfinite(x) && std::isfinite(y) && std::isfinite(z))) continue;
      ++out.points_in;
      double w = default_w;
      double h2 = 0;  // the predicted horizontal error, squared
      double range = 0, sigma_h = 0;
      if (s != nullptr) {
        const float sz = s[3 * col + 2];
        if (std::isfinite(sz) && sz > 0) w = 1.0 / (static_cast<double>(sz) * sz);
        h2 = static_cast<double>(s[3 * col]) * s[3 * col] + static_cast<double>(s[3 * col + 1]) * s[3 * col + 1];
        sigma_h = std::sqrt(h2);
        range = std::hypot(static_cast<double>(x), static_cast<double>(y));
      } else if (error_model != nullptr) {
        double sz = 0;
        if (error_model->Errors(x, y, z, &sz, &sigma_h, &range)) {
          if (sz > 0) w = 1.0 / (sz * sz);
          h2 = sigma_h * sigma_h;
        } else {
          h2 = std::numeric_limits<double>::quiet_NaN();  // behind the cameras: out below
        }
      } else {
        range = std::hypot(static_cast<double>(x), static_cast<double>(y));
      }
      if (visibility || support) {
        ColumnWalk& v = walk[col];
        if (visibility && range + o.visibility_k * sigma_h + o.visibility_floor_m < v.reach) {
          ++out.points_floating;
          continue;
        }
        if (support && z - v.last_z > o.support_rise_m && range - v.last_range < kSupportCot * (z - v.last_z)) {
          ++out.points_unsupported;
          continue;
        }
        v.bound[0] = v.bound[1];
        v.bound[1] = v.bound[2];
        v.bound[2] = static_cast<float>(range - o.visibility_k * sigma_h);
        v.reach = std::max(v.reach, std::min({v.bound[0], v.bound[1], v.bound[2]}));
        v.last_range = static_cast<float>(range);
        v.last_z = z;
      }
      // Too uncertain to say which cell it belongs to: out, or ground only.
      const bool uncertain = h2 > max_h2 && h2 <= ground_h2;
      if (!(h2 <= max_h2) && !uncertain) {
        ++out.points_out_of_range;
        continue;
      }
      if (static_cast<double>(x) * x + static_cast<double>(y) * y > max_range2) {
        ++out.points_out_of_range;
        continue;
      }
      const double wx = r(0, 0) * x + r(0, 1) * y + r(0, 2) * z + t.x();
      const double wy = r(1, 0) * x + r(1, 1) * y + r(1, 2) * z + t.y();
      const double wz = r(2, 0) * x + r(2, 1) * y + r(2, 2) * z + t.z();
      if (interval) {  // the requested interval: horizontal distance ahead, in the level frame
        const double ahead = heading.x() * (wx - t.x()) + heading.y() * (wy - t.y());
        if (!(ahead >= y_min_m && ahead <= y_max_m)) {
          ++out.points_out_of_range;
          continue;
        }
      }
      if (!(std::abs(wx) <= kMaxWorldCoordinateM && std::abs(wy) <= kMaxWorldCoordinateM &&
            std::abs(wz) <= kMaxWorldCoordinateM)) {  // off any map (and off the int32 cell indices)
        ++out.points_out_of_range;
        continue;
      }
      if (uncertain) {
        ground_only.push_back({wx, wy, wz, w});
        continue;
      }
      if (edges && row_edge[static_cast<std::size_t>(col)] != 0) {
        bin(wx, wy, wz, w, true);  // standing or not: decided in its cell (pass 3)
        continue;
      }
      if (zs.size() % kPlaneStride == 0) plane.push_back({wx, wy, wz});
      bin(wx, wy, wz, w);
      if (carving && wz < camera.z() && zs.size() % kRayStride == 1) {
        rays.push_back(
            {wx, wy, static_cast<float>(wz), static_cast<float>(sigma_h), static_cast<std::uint32_t>(zs.size() - 1)});
      }
    }
  }
  // The ground-only points: those within the gate of the pair's ground plane join the others
  // (they cast no rays: a ray says most near its point, whose place they do not know well).
  // (The points at a depth edge are judged in pass 3, against the ground their cell, or the
  // cells around it, hold.)
  std::optional<GroundPlaneFit> ground;
  if (!ground_only.empty()) {
    ground = FitGround(plane);
    if (ground && !(std::abs(ground->At(t.x(), t.y()) - t.z()) <= kPlaneOriginToleranceM)) ground.reset();
  }
  // Lone objects: the uncertain points standing lone_object_height_m over the plane are kept
  // where none of the pair's placed points stands that high within kLoneObjectReachCells.
  std::vector<std::size_t>& lone = buf.lone;
  lone.clear();
  for (std::size_t k = 0; k < ground_only.size(); ++k) {
    const auto& [wx, wy, wz, w] = ground_only[k];
    if (ground && std::abs(wz - ground->At(wx, wy)) <= o.ground_gate_m) {
      bin(wx, wy, wz, w);
      ++out.points_ground_only;
    } else if (ground && wz - ground->At(wx, wy) > o.lone_object_height_m) {
      lone.push_back(k);
    } else {
      ++out.points_off_ground;
    }
  }
  // The placed points' box (binning the lone points below widens i0..j1); one too large for
  // pass 2 is refused there.
  const std::int64_t bi0 = i0, bj0 = j0, bi1 = i1, bj1 = j1, box_w = bi1 - bi0 + 1;
  if (!lone.empty() && !zs.empty() && box_w * (bj1 - bj0 + 1) > kMaxFrameBoxCells) {
    out.points_off_ground += static_cast<long>(lone.size());
  } else if (!lone.empty()) {
    const std::size_t placed = zs.size();
    std::vector<std::uint8_t>& standing = buf.standing;  // per cell of that box: a placed point stands high
    standing.assign(placed > 0 ? static_cast<std::size_t>(box_w * (bj1 - bj0 + 1)) : 0, 0);
    for (std::size_t k = 0; k < placed; ++k) {
      const double x = (ci[k] + 0.5) * o.cell_m, y = (cj[k] + 0.5) * o.cell_m;
      if (zs[k] - ground->At(x, y) > o.lone_object_height_m) {
        standing[static_cast<std::size_t>((cj[k] - bj0) * box_w + (ci[k] - bi0))] = 1;
      }
    }
    auto near_standing = [&](std::int64_t i, std::int64_t j) {
      if (placed == 0) return false;
      for (std::int64_t b = std::max(j - kLoneObjectReachCells, bj0); b <= std::min(j + kLoneObjectReachCells, bj1);
           ++b) {
        for (std::int64_t a = std::max(i - kLoneObjectReachCells, bi0);
             a <= std::min(i + kLoneObjectReachCells, bi1); ++a) {
          if (standing[static_cast<std::size_t>((b - bj0) * box_w + (a - bi0))] != 0) return true;
        }
      }
      return false;
    };
    for (std::size_t k : lone) {
      const auto& [wx, wy, wz, w] = ground_only[k];
      if (near_standing(FloorToInt32(wx * inv_cell), FloorToInt32(wy * inv_cell))) {
        ++out.points_off_ground;
        continue;
      }
      bin(wx, wy, wz, w);
      ++out.points_lone_object;
    }
  }
  if (zs.empty()) return out;
  if (!rays.empty()) {  // the box reaches back to the camera, where the rays start
    const double ci_cam = std::floor(camera.x() * inv_cell), cj_cam = std::floor(camera.y() * inv_cell);
    if (std::abs(ci_cam) < 2e9 && std::abs(cj_cam) < 2e9) {
      i0 = std::min(i0, static_cast<std::int32_t>(ci_cam));
      i1 = std::max(i1, static_cast<std::int32_t>(ci_cam));
      j0 = std::min(j0, static_cast<std::int32_t>(cj_cam));
      j1 = std::max(j1, static_cast<std::int32_t>(cj_cam));
    } else {
      rays.clear();
    }
  }

  // Pass 2: counting sort by cell of the frame's bounding box.
  const std::int64_t nx = static_cast<std::int64_t>(i1) - i0 + 1, ny = static_cast<std::int64_t>(j1) - j0 + 1;
  LN_CHECK_INPUT(nx * ny <= kMaxFrameBoxCells) << "a frame's points span " << nx << " x " << ny
                                        << " cells (points far away: set a maximum range)";
  std::vector<std::uint32_t>& start = buf.start;
  std::vector<std::uint32_t>& local = buf.local;
  std::vector<std::uint32_t>& fill = buf.fill;
  start.assign(static_cast<std::size_t>(nx * ny) + 1, 0);
  local.resize(zs.size());
  for (std::size_t k = 0; k < zs.size(); ++k) {
    local[k] = static_cast<std::uint32_t>((cj[k] - j0) * nx + (ci[k] - i0));
    ++start[local[k] + 1];
  }
  for (std::size_t c = 1; c < start.size(); ++c) start[c] += start[c - 1];
  fill.assign(start.begin(), start.end() - 1);
  std::vector<float>& sz = buf.sz;
  std::vector<float>& sw = buf.sw;
  std::vector<std::uint32_t>& src = buf.src;
  sz.resize(zs.size());
  sw.resize(zs.size());
  src.resize(zs.size());
  std::vector<std::uint8_t>& sorted_at_edge = buf.sorted_at_edge;
  if (edge_points > 0) sorted_at_edge.resize(zs.size());
  for (std::size_t k = 0; k < zs.size(); ++k) {
    const std::uint32_t at = fill[local[k]]++;
    sz[at] = zs[k];
    sw[at] = ws[k];
    src[at] = static_cast<std::uint32_t>(k);
    if (edge_points > 0) sorted_at_edge[at] = at_edge[k];
  }
  std::vector<std::uint8_t>& accepted = buf.accepted;  // by pass 1's index: the gate kept the point
  if (!rays.empty()) accepted.assign(zs.size(), 0);

  // Pass 3: per cell, gate against the frame's median and sum.
  std::vector<float>& scratch = buf.scratch;
  // The depth-edge rule's ground of a cell (before pass 3 reorders any cell): the
  // kEdgeGroundQuantile of its points not at an edge, with at least gate_min_points of them;
  // +inf without (computed once a cell, on demand).
  std::vector<float>& edge_ground = buf.edge_ground;
  if (edge_points > 0) edge_ground.assign(static_cast<std::size_t>(nx * ny), kNaNF);
  auto OwnEdgeGround = [&](std::int64_t c) {
    float& g = edge_ground[static_cast<std::size_t>(c)];
    if (std::isnan(g)) {
      scratch.clear();
      for (std::uint32_t k = start[c]; k < start[c + 1]; ++k) {
        if (sorted_at_edge[k] == 0) scratch.push_back(sz[k]);
      }
      const bool enough = static_cast<int>(scratch.size()) >= o.gate_min_points;
      g = enough ? QuantileInPlace(scratch, kEdgeGroundQuantile) : kInfF;
    }
    return g;
  };
  // Per cell with points at an edge, the ground they are judged against: the cell's own, else
  // the lowest of the cells' around it within kEdgeGroundReachCells, +inf where none has
  // (inside a bush or a hedge, where the pair sees no ground near: nothing to judge the points
  // by); NaN for the cells without (most). Filled before pass 3 reorders any cell.
  std::vector<float>& edge_floor = buf.edge_floor;
  if (edge_points > 0) {
    edge_floor.assign(static_cast<std::size_t>(nx * ny), kNaNF);
    for (std::int64_t c = 0; c + 1 < static_cast<std::int64_t>(start.size()); ++c) {
      const auto b = sorted_at_edge.begin() + start[c], e = sorted_at_edge.begin() + start[c + 1];
      if (std::find(b, e, 1) == e) continue;
      float floor_z = OwnEdgeGround(c);
      if (std::isinf(floor_z)) {
        const std::int64_t ci = c % nx, cj = c / nx;
        for (std::int64_t j = std::max<std::int64_t>(0, cj - kEdgeGroundReachCells);
             j <= std::min<std::int64_t>(ny - 1, cj + kEdgeGroundReachCells); ++j) {
          for (std::int64_t i = std::max<std::int64_t>(0, ci - kEdgeGroundReachCells);
               i <= std::min<std::int64_t>(nx - 1, ci + kEdgeGroundReachCells); ++i) {
            const std::int64_t n = j * nx + i;
            if (start[n] != start[n + 1]) floor_z = std::min(floor_z, OwnEdgeGround(n));
          }
        }
      }
      edge_floor[static_cast<std::size_t>(c)] = floor_z;
    }
  }
  // The points of cell c at a depth edge that stand more than edge_height_m over its edge_floor
  // are dropped, the others moved to the front of the cell's range [b, e) in their order and
  // counted; returns how many points stay.
  auto JudgeEdgePoints = [&](std::uint32_t b, std::uint32_t e, std::int64_t c) -> std::uint32_t {
    const double floor_z = edge_floor[static_cast<std::size_t>(c)];
    if (!std::isfinite(floor_z)) return e - b;  // none at an edge (NaN), or no ground seen (+inf)
    std::uint32_t keep = b;  // the points kept, moved to the front in their order
    for (std::uint32_t k = b; k < e; ++k) {
      if (sorted_at_edge[k] != 0 && sz[k] - floor_z > o.edge_height_m) {
        ++out.points_edge;
        continue;
      }
      if (keep != k) {
        sz[keep] = sz[k];
        sw[keep] = sw[k];
        src[keep] = src[k];
        sorted_at_edge[keep] = sorted_at_edge[k];
      }
      ++keep;
    }
    return keep - b;
  };
  // The hidden rule's ground per cell of the frame's box: a low quantile of the points kept.
  std::vector<float>& lowest = buf.lowest;
  std::vector<float>& kept = buf.kept;
  const bool quantile = hiding && o.hidden_ground_quantile > 0;
  if (hiding) lowest.assign(static_cast<std::size_t>(nx * ny), kInfF);
  const double floor2 = o.gate_floor_m * o.gate_floor_m, k2 = o.gate_k * o.gate_k;
  const double frame_floor2 = o.frame_floor_m * o.frame_floor_m;
  for (std::int64_t c = 0; c + 1 < static_cast<std::int64_t>(start.size()); ++c) {
    const std::uint32_t b = start[c];
    std::uint32_t e = start[c + 1];
    if (b == e) continue;
    if (edge_points > 0) e = b + JudgeEdgePoints(b, e, c);
    if (b == e) continue;
    const std::uint32_t n = e - b;
    double median = 0, spread2 = 0;
    const bool gated = std::isfinite(o.gate_k) && static_cast<int>(n) >= o.gate_min_points;
    if (gated) {
      scratch.assign(sz.begin() + b, sz.begin() + e);
      auto mid = scratch.begin() + n / 2;
      std::nth_element(scratch.begin(), mid, scratch.end());
      median = *mid;
      for (float& v : scratch) v = std::abs(v - static_cast<float>(median));
      std::nth_element(scratch.begin(), mid, scratch.end());
      const double spread = kMadToSigma * *mid;
      spread2 = spread * spread;
    }
    CellStats cell;
    kept.clear();
    double sw_pts = 0, swz = 0, swzz = 0;  // the accepted points' weighted sums
    // The accepted points' highest kTopSupport, highest first: the last is the top that many
    // of this pair's points reach.
    std::array<float, kTopSupport> tops;
    tops.fill(-std::numeric_limits<float>::infinity());
    for (std::uint32_t k = b; k < e; ++k) {
      const double z = sz[k], w = sw[k];
      if (gated) {
        const double d = z - median;
        if (d * d > k2 * (1.0 / w + spread2 + floor2)) {
          ++cell.rejected;
          continue;
        }
      }
      if (static_cast<float>(z) > tops.back()) {  // among the highest so far
        for (float v = static_cast<float>(z), *t = tops.data(); t != tops.data() + kTopSupport; ++t) {
          if (v > *t) std::swap(v, *t);
        }
      }
      if (!rays.empty()) accepted[src[k]] = 1;
      sw_pts += w;
      swz += w * z;
      swzz += w * z * z;
      cell.z_min = std::min(cell.z_min, static_cast<float>(z));
      cell.z_max = std::max(cell.z_max, static_cast<float>(z));
      if (quantile) kept.push_back(static_cast<float>(z));
      ++cell.count;
    }
    if (hiding && cell.count > 0) {
      lowest[static_cast<std::size_t>(c)] = quantile ? QuantileInPlace(kept, o.hidden_ground_quantile) : cell.z_min;
    }
    if (cell.count > 0) {
      // The frame's one observation of the cell: the points' weighted mean, weighed by their
      // mean variance (count / sum of weights) plus the frame's floor.
      const double m = swz / sw_pts, v = std::max(0.0, swzz / sw_pts - m * m);
      const double frame_w = 1.0 / (cell.count / sw_pts + frame_floor2);
      cell.sum_w = frame_w;
      cell.sum_wz = frame_w * m;
      cell.sum_wzz = frame_w * (m * m + v);
      cell.last_t_s = t_s;
      cell.frames = 1;
      cell.z_max2 = tops.back();
    }
    out.points_fused += cell.count;
    out.points_rejected += cell.rejected;
    out.cells.push_back({CellIndex{i0 + c % nx, j0 + c / nx}, cell});
  }
  if (hiding) {
    // Pass 3b: an observation that the ray to it shows hidden is left out: on its way, the ray
    // passes through a cell of the same frame below that cell's ground (a low quantile of its
    // points, pass 3; by more than the tolerance, at the ray's highest over the cell), where the
    // frame sees the ground it would have hit. Wrong matches behind an object's edge, seen in
    // one camera only, lie there, metres deep. All tested against the frame's cells as binned.
    const Eigen::Isometry3d vehicle_from_world = world_from_vehicle.inverse();
    for (auto& entry : out.cells) {
      const CellIndex index = entry.first;  // (a lambda below uses it)
      CellStats& cell = entry.second;
      if (cell.count == 0) continue;
      const double x = (static_cast<double>(index.i) + 0.5) * o.cell_m,
                   y = (static_cast<double>(index.j) + 0.5) * o.cell_m;
      const double z = cell.Mean();
      if (!(z < camera.z())) continue;
      const Eigen::Vector3d v = vehicle_from_world * Eigen::Vector3d(x, y, z);
      const double sigma_h = error_model->SigmaHorizontal(v.x(), v.y(), v.z());
      if (!std::isfinite(sigma_h)) continue;
      const auto [s0, s1] = RayStretch(camera, x, y, sigma_h, o.carve_reach_m, o.cell_m);
      bool hidden = false;
      WalkRay(camera, x, y, z, s0, s1, o.cell_m, [&](std::int64_t i, std::int64_t j, double h_in, double) {
        const std::int64_t li = i - i0, lj = j - j0;
        if ((i != index.i || j != index.j) && li >= 0 && lj >= 0 && li < nx && lj < ny) {
          const float cell_ground = lowest[static_cast<std::size_t>(lj * nx + li)];
          hidden = std::isfinite(cell_ground) && h_in < static_cast<double>(cell_ground) - o.hidden_tolerance_m;
        }
        return !hidden;
      });
      if (!hidden) continue;
      out.points_fused -= cell.count;
      out.points_hidden += cell.count;
      if (!rays.empty()) {
        const std::int64_t c = (index.j - j0) * nx + (index.i - i0);
        for (std::uint32_t k = start[c]; k < start[c + 1]; ++k) accepted[src[k]] = 0;
      }
      CellStats emptied;
      emptied.rejected = cell.rejected;
      cell = emptied;
    }
  }
  // Pass 3c: the pair's own steps.
  if (o.obstacles.pair_step_support > 0) PairSteps(o.obstacles, o.cell_m, i0, j0, nx, ny, &out.cells, &buf.steps);
  if (rays.empty()) return out;

  // Pass 4: the rays of the points the gate kept set the frame's ceilings; a frame does not
  // carve what it sees itself (a cell its rays cross beside an object it sees in that cell, the
  // side of a parked car, keeps its points: the ceiling is at least the frame's own highest).
  std::vector<float>& ceilings = buf.ceilings;
  ceilings.assign(static_cast<std::size_t>(nx * ny) * kCeilingSupport, kInfF);
  for (const Ray& ray : rays) {
    if (accepted[ray.point]) out.rays_cast += CastRay(camera, ray, o, i0, j0, nx, ny, ceilings.data());
  }
  auto ceiling_of = [&](std::int64_t c) {
    return ceilings[static_cast<std::size_t>(c) * kCeilingSupport + kCeilingSupport - 1];
  };
  std::vector<std::pair<CellIndex, CellStats>>& seen = buf.seen;
  seen.clear();
  seen.swap(out.cells);
  out.cells.reserve(seen.size());
  std::size_t next = 0;
  for (std::int64_t c = 0; c < nx * ny; ++c) {
    const CellIndex index{i0 + c % nx, j0 + c / nx};
    const bool has = next < seen.size() && seen[next].first.i == index.i && seen[next].first.j == index.j;
    const float ceiling = ceiling_of(c);
    if (has) {
      CellStats& cell = seen[next++].second;
      cell.ceiling = cell.count > 0 ? std::max(ceiling, cell.z_max) : ceiling;
      out.cells.push_back({index, cell});
    } else if (std::isfinite(ceiling)) {
      CellStats free;
      free.ceiling = ceiling;
      out.cells.push_back({index, free});
    }
  }
  return out;
}

// A cell's record: its free space, the points its frames' gates rejected, and its frames'
// observations by height bin (index floor(mean / (kHeightBinM 2^level)), ascending).
struct TerrainGrid::Record {
  float ceiling = kInfF, ceiling2 = kInfF;
  std::uint32_t rejected = 0;
  std::uint8_t level = 0;
  std::vector<std::pair<std::int32_t, CellStats>> bins;

  bool Known() const { return !bins.empty() || rejected > 0 || std::isfinite(ceiling); }

  void Insert(std::int32_t index, const CellStats& s) {
    auto it = std::lower_bound(bins.begin(), bins.end(), index,
                               [](const std::pair<std::int32_t, CellStats>& b, std::int32_t v) { return b.first < v; });
    if (it != bins.end() && it->first == index) {
      it->second.Merge(s);
    } else {
      bins.insert(it, {index, s});
    }
  }
  // Doubles the bins' height, merging each even bin with the odd one above it.
  void Coarsen() {
    ++level;
    std::size_t out = 0;
    for (std::size_t k = 0; k < bins.size(); ++k) {
      const std::int32_t index = bins[k].first >> 1;  // arithmetic shift: floor(index / 2)
      if (out > 0 && bins[out - 1].first == index) {
        bins[out - 1].second.Merge(bins[k].second);
      } else {
        bins[out++] = {index, bins[k].second};
      }
    }
    bins.resize(out);
  }
  void Fit() {
    while (bins.size() > static_cast<std::size_t>(kMaxHeightBins)) Coarsen();
  }
  // One frame's observation (count > 0).
  void AddObservation(const CellStats& s) {
    CellStats bin = s;
    bin.ceiling = bin.ceiling2 = kInfF;
    bin.rejected = 0;
    const double q = std::clamp(std::floor(s.Mean() / kHeightBinM), -1073741824.0, 1073741823.0);
    Insert(static_cast<std::int32_t>(static_cast<std::int64_t>(q) >> level), bin);
    Fit();
  }
  // Another map's record of the same cell. The result depends only on the observations: the
  // level is the least at which all of them fit kMaxHeightBins bins.
  void MergeRecord(const Record& o) {
    TwoLowest(&ceiling, &ceiling2, o.ceiling, o.ceiling2);
    rejected += o.rejected;
    while (level < o.level) Coarsen();
    for (const auto& [index, stats] : o.bins) Insert(index >> (level - o.level), stats);
    Fit();
  }
};

struct TerrainGrid::Tile {
  std::int64_t ti = 0, tj = 0;
  std::array<Record, kTileSize * kTileSize> cells;
};

TerrainGrid::TerrainGrid(double cell_m) : cell_m_(cell_m) {
  LN_CHECK_ARG(std::isfinite(cell_m) && cell_m > 0) << "cell: must be > 0 m";
}
TerrainGrid::TerrainGrid(TerrainGrid&&) noexcept = default;
TerrainGrid& TerrainGrid::operator=(TerrainGrid&&) noexcept = default;
TerrainGrid::~TerrainGrid() = default;

TerrainGrid::Record* TerrainGrid::Cell(CellIndex c) {
  const std::int64_t ti = FloorDiv(c.i, kTileShift), tj = FloorDiv(c.j, kTileShift);
  std::unique_ptr<Tile>& tile = tiles_[TileKey(ti, tj)];
  if (!tile) {
    tile = std::make_unique<Tile>();
    tile->ti = ti;
    tile->tj = tj;
  }
  return &tile->cells[static_cast<std::size_t>((c.j - (tj << kTileShift)) * kTileSize + (c.i - (ti << kTileShift)))];
}

const TerrainGrid::Record* TerrainGrid::FindRecord(CellIndex c) const {
  const std::int64_t ti = FloorDiv(c.i, kTileShift), tj = FloorDiv(c.j, kTileShift);
  const auto it = tiles_.find(TileKey(ti, tj));
  if (it == tiles_.end()) return nullptr;
  return &it->second
              ->cells[static_cast<std::size_t>((c.j - (tj << kTileShift)) * kTileSize + (c.i - (ti << kTileShift)))];
}

std::optional<CellStats> TerrainGrid::Find(CellIndex c, double carve_tolerance_m, double moved_height_m) const {
  const Record* r = FindRecord(c);
  if (r == nullptr || (r->bins.empty() && r->rejected == 0)) return std::nullopt;
  CellStats s;
  s.rejected = r->rejected;
  const double limit = static_cast<double>(r->ceiling2) + carve_tolerance_m;  // inf + anything: no carving
  // Moved on: a later, lower bin that two pairs after all of `bin`'s saw, whose top stands
  // below bin's mean and more than moved_height_m below its top.
  auto moved_on = [&](const CellStats& bin) {
    if (!std::isfinite(moved_height_m)) return false;
    for (const auto& [index, later] : r->bins) {
      if (&later == &bin || later.Mean() > limit || !(later.last_t2_s > bin.last_t_s)) continue;
      if (later.z_max2 < bin.Mean() && bin.z_max2 - later.z_max2 > moved_height_m) return true;
    }
    return false;
  };
  for (const auto& [index, bin] : r->bins) {
    if (bin.Mean() > limit) {
      s.carved_points += bin.count;
      s.carved_frames += bin.frames;
    } else if (moved_on(bin)) {
      s.moved_points += bin.count;
      s.moved_frames += bin.frames;
    } else {
      s.Merge(bin);
    }
  }
  s.ceiling = r->ceiling;
  s.ceiling2 = r->ceiling2;
  return s;
}

void TerrainGrid::Add(const FrameContribution& frame) {
  for (const auto& [index, stats] : frame.cells) {
    Record* r = Cell(index);
    TwoLowest(&r->ceiling, &r->ceiling2, stats.ceiling, stats.ceiling2);
    r->rejected += stats.rejected;
    if (stats.count > 0) r->AddObservation(stats);
  }
}

void TerrainGrid::Merge(const TerrainGrid& other) {
  LN_CHECK_ARG(std::abs(other.cell_m_ - cell_m_) <= 1e-9 * cell_m_)
      << "cannot merge maps of different cell sizes (" << cell_m_ << " and " << other.cell_m_ << " m)";
  for (const auto& [key, tile] : other.tiles_) {
    for (int k = 0; k < kTileSize * kTileSize; ++k) {
      const Record& r = tile->cells[k];
      if (!r.Known()) continue;
      Cell({(tile->ti << kTileShift) + k % kTileSize, (tile->tj << kTileShift) + k / kTileSize})->MergeRecord(r);
    }
  }
}

void TerrainGrid::KeepWindow(double x_m, double y_m, double side_m) {
  const double tile_m = cell_m_ * kTileSize, half = 0.5 * side_m;
  for (auto it = tiles_.begin(); it != tiles_.end();) {
    const double tx0 = it->second->ti * tile_m, ty0 = it->second->tj * tile_m;
    const bool outside = tx0 > x_m + half || tx0 + tile_m < x_m - half || ty0 > y_m + half || ty0 + tile_m < y_m - half;
    it = outside ? tiles_.erase(it) : std::next(it);
  }
}

std::size_t TerrainGrid::TileCount() const { return tiles_.size(); }

std::size_t TerrainGrid::MappedCells() const {
  std::size_t n = 0;
  for (const auto& [key, tile] : tiles_) {
    for (const Record& r : tile->cells) n += !r.bins.empty();
  }
  return n;
}

namespace {

// The box {i0, j0, i1, j1} of the grid's cells for which `take` holds.
template <typename Tiles, typename Take>
std::optional<std::array<std::int64_t, 4>> BoxOf(const Tiles& tiles, Take take) {
  std::optional<std::array<std::int64_t, 4>> b;
  for (const auto& [key, tile] : tiles) {
    for (int k = 0; k < kTileSize * kTileSize; ++k) {
      if (!take(tile->cells[k])) continue;
      const std::int64_t i = (tile->ti << kTileShift) + k % kTileSize, j = (tile->tj << kTileShift) + k / kTileSize;
      if (!b) {
        b = std::array<std::int64_t, 4>{i, j, i, j};
      } else {
        (*b)[0] = std::min((*b)[0], i);
        (*b)[1] = std::min((*b)[1], j);
        (*b)[2] = std::max((*b)[2], i);
        (*b)[3] = std::max((*b)[3], j);
      }
    }
  }
  return b;
}

}  // namespace

std::optional<std::array<std::int64_t, 4>> TerrainGrid::MappedBounds() const {
  return BoxOf(tiles_, [](const Record& r) { return !r.bins.empty(); });
}

std::optional<std::array<std::int64_t, 4>> TerrainGrid::KnownBounds() const {
  return BoxOf(tiles_, [](const Record& r) { return r.Known(); });
}

io::GeoRaster TerrainGrid::ToStateRaster() const {
  io::GeoRaster r;
  r.cell_m = cell_m_;
  r.metadata["lunarnav_content"] = "terrain-map state";
  const auto b = KnownBounds();
  const int w = b ? static_cast<int>((*b)[2] - (*b)[0] + 1) : 1, h = b ? static_cast<int>((*b)[3] - (*b)[1] + 1) : 1;
  const std::int64_t i0 = b ? (*b)[0] : 0, j1 = b ? (*b)[3] : 0;
  r.x_west_m = static_cast<double>(i0) * cell_m_;
  r.y_north_m = static_cast<double>(j1 + 1) * cell_m_;
  std::size_t slots = 1;
  for (const auto& [key, tile] : tiles_) {
    for (const Record& rec : tile->cells) slots = std::max(slots, rec.bins.size());
  }
  auto add_band = [&](const std::string& name, double fill) {
    io::RasterBand band;
    band.description = name;
    band.pixels = cv::Mat(h, w, CV_64FC1, cv::Scalar(fill));
    r.bands.push_back(std::move(band));
  };
  for (const char* name : kStateCellBands) add_band(name, 0.0);
  r.bands[0].pixels.setTo(cv::Scalar(std::numeric_limits<double>::infinity()));
  r.bands[1].pixels.setTo(cv::Scalar(std::numeric_limits<double>::infinity()));
  for (std::size_t k = 0; k < slots; ++k) {
    for (const char* name : kStateBinBands) add_band("bin" + std::to_string(k + 1) + "_" + name, 0.0);
  }
  for (int row = 0; row < h && b; ++row) {
    for (int col = 0; col < w; ++col) {
      const Record* rec = FindRecord({i0 + col, j1 - row});
      if (rec == nullptr || !rec->Known()) continue;
      const double cell[4] = {rec->ceiling, rec->ceiling2, static_cast<double>(rec->rejected),
                              static_cast<double>(rec->level)};
      for (int k = 0; k < 4; ++k) r.bands[k].pixels.at<double>(row, col) = cell[k];
      for (std::size_t k = 0; k < rec->bins.size(); ++k) {
        const auto& [index, s] = rec->bins[k];
        const double v[kStateBinBands.size()] = {static_cast<double>(index), s.sum_w, s.sum_wz, s.sum_wzz,
                                                 s.z_min, s.z_max, static_cast<double>(s.count), s.last_t_s,
                                                 static_cast<double>(s.frames), s.z_min2, s.z_max2, s.step1,
                                                 s.step2, static_cast<double>(s.step_pairs), s.last_t2_s};
        const std::size_t n = kStateBinBands.size(), base = kStateCellBands.size() + n * k;
        for (std::size_t m = 0; m < n; ++m) r.bands[base + m].pixels.at<double>(row, col) = v[m];
      }
    }
  }
  return r;
}

TerrainGrid TerrainGrid::FromStateRaster(const io::GeoRaster& r, const std::string& source) {
  auto named = [&](std::size_t k, const std::string& name) {
    return r.bands[k].description == name && r.bands[k].pixels.type() == CV_64FC1;
  };
  bool v1 = r.bands.size() == kStateBandsV1.size();
  for (std::size_t k = 0; v1 && k < kStateBandsV1.size(); ++k) v1 = named(k, kStateBandsV1[k]);
  const std::size_t cell_bands = kStateCellBands.size();
  // Bins of every band now, or of the bands before the pairs' steps (kStateBinBandsV2).
  const bool v2 = !v1 && !(r.bands.size() > cell_bands + kStateBinBandsV2 &&
                           r.bands[cell_bands + kStateBinBandsV2].description == "bin1_step1");
  const std::size_t bin_bands = v2 ? kStateBinBandsV2 : kStateBinBands.size();
  if (!v1) {
    LN_CHECK_INPUT(r.bands.size() > cell_bands && (r.bands.size() - cell_bands) % bin_bands == 0)
        << source << ": not a terrain-map state file";
    for (std::size_t k = 0; k < r.bands.size(); ++k) {
      const std::string name = k < cell_bands ? std::string(kStateCellBands[k])
                                              : "bin" + std::to_string((k - cell_bands) / bin_bands + 1) + "_" +
                                                    kStateBinBands[(k - cell_bands) % bin_bands];
      LN_CHECK_INPUT(named(k, name)) << source << ": band " << k + 1 << " is not the state band '" << name << "'";
    }
  }
  // The map's world: cells within the poses' 1,000 km of the origin (the grid's tile keys hold
  // that at the finest cell; a state moved beyond it is no map of this world).
  const double far_x = std::max(std::abs(r.x_west_m), std::abs(r.x_west_m + r.Width() * r.cell_m));
  const double far_y = std::max(std::abs(r.y_north_m), std::abs(r.y_north_m - r.Height() * r.cell_m));
  LN_CHECK_INPUT(std::max(far_x, far_y) <= kMaxWorldCoordinateM && r.cell_m >= 0.01)
      << source << ": its cells reach (" << far_x << ", " << far_y << ") m from the world origin, or are "
      << r.cell_m << " m; a map lies within " << kMaxWorldCoordinateM << " m, in cells of 1 cm or more";
  TerrainGrid grid(r.cell_m);
  const double fi = r.x_west_m / r.cell_m, fj = r.y_north_m / r.cell_m;
  LN_CHECK_INPUT(std::abs(fi - std::round(fi)) < 1e-6 && std::abs(fj - std::round(fj)) < 1e-6)
      << source << ": origin is not on the cell lattice";
  const auto i0 = static_cast<std::int64_t>(std::llround(fi)), j1 = static_cast<std::int64_t>(std::llround(fj)) - 1;
  // A count band's value: a whole number of 0 to 2^32 - 1.
  auto count_of = [&](double v, int col, int row, const char* what) {
    LN_CHECK_INPUT(v >= 0 && v <= 4294967295.0 && v == std::floor(v))
        << source << ": cell (" << col << ", " << row << ") has " << what << " " << v << " (a count)";
    return static_cast<std::uint32_t>(v);
  };
  int at_col = 0, at_row = 0;
  auto stats_of =
      [&](const double* v) {  // sum_w, sum_wz, sum_wzz, z_min, z_max, count, last_t_s, frames, z_min2, z_max2
        CellStats s;
        s.sum_w = v[0];
        s.sum_wz = v[1];
        s.sum_wzz = v[2];
        s.z_min = static_cast<float>(v[3]);
        s.z_max = static_cast<float>(v[4]);
        s.count = count_of(v[5], at_col, at_row, "count");
        s.last_t_s = v[6];
        s.frames = count_of(v[7], at_col, at_row, "frames");
        LN_CHECK_INPUT(std::isfinite(s.sum_w) && s.sum_w > 0 && std::isfinite(s.sum_wz) && std::isfinite(s.sum_wzz))
            << source << ": cell (" << at_col << ", " << at_row << ") has sums " << s.sum_w << ", " << s.sum_wz << ", "
            << s.sum_wzz << " (finite, weights > 0)";
        s.z_min2 = static_cast<float>(v[8]);
        s.z_max2 = static_cast<float>(v[9]);
        return s;
      };
  // A bin's pairs' steps and second last time: (step1, step2, step_pairs, last_t2_s), each step
  // finite or -infinity, the time -infinity or up to the last.
  auto steps_of = [&](const double* v, CellStats* s) {
    s->step_pairs = count_of(v[2], at_col, at_row, "step pairs");
    const double none = -std::numeric_limits<double>::infinity();
    const bool valid = (s->step_pairs > 0 ? std::isfinite(v[0]) : v[0] == none) &&
                       (s->step_pairs > 1 ? std::isfinite(v[1]) && v[1] <= v[0] : v[1] == none);
    LN_CHECK_INPUT(valid)
        << source << ": cell (" << at_col << ", " << at_row << ") has pair steps " << v[0] << ", " << v[1] << " of "
        << s->step_pairs << " pairs";
    s->step1 = static_cast<float>(v[0]);
    s->step2 = static_cast<float>(v[1]);
    LN_CHECK_INPUT(v[3] == none || (s->frames > 1 && v[3] <= s->last_t_s))
        << source << ": cell (" << at_col << ", " << at_row << ") has second last time " << v[3] << " of "
        << s->frames << " frames, the last " << s->last_t_s;
    s->last_t2_s = v[3];
  };
  const std::size_t slots = v1 ? 0 : (r.bands.size() - cell_bands) / bin_bands;
  for (int row = 0; row < r.Height(); ++row) {
    for (int col = 0; col < r.Width(); ++col) {
      auto at = [&](std::size_t k) { return r.bands[k].pixels.at<double>(row, col); };
      at_col = col;
      at_row = row;
      if (v1) {  // one set of sums: one bin, no ceiling
        double v[11];
        for (std::size_t k = 0; k < 11; ++k) v[k] = at(k);
        if (v[5] <= 0 && v[6] <= 0) continue;
        Record* rec = grid.Cell({i0 + col, j1 - row});
        rec->rejected = count_of(v[6], col, row, "rejected");
        const double sums[10] = {v[0], v[1], v[2], v[3], v[4], v[5], v[7], v[8], v[9], v[10]};
        if (v[5] > 0) rec->AddObservation(stats_of(sums));
        continue;
      }
      const double level = at(3);
      const bool any = std::isfinite(at(0)) || at(2) > 0 || (slots > 0 && at(cell_bands + 6) > 0);
      if (!any) continue;
      LN_CHECK_INPUT(level >= 0 && level <= 31 && level == std::floor(level))
          << source << ": cell (" << col << ", " << row << ") has bin level " << level << " (0-31)";
      Record* rec = grid.Cell({i0 + col, j1 - row});
      rec->ceiling = static_cast<float>(at(0));
      rec->ceiling2 = static_cast<float>(at(1));
      rec->rejected = count_of(at(2), col, row, "rejected");
      rec->level = static_cast<std::uint8_t>(level);
      for (std::size_t k = 0; k < slots; ++k) {
        const std::size_t base = cell_bands + k * bin_bands;
        if (!(at(base + 6) > 0)) continue;
        double v[kStateBinBands.size() - 1];
        for (std::size_t m = 0; m + 1 < bin_bands; ++m) v[m] = at(base + 1 + m);
        const double index = at(base);
        LN_CHECK_INPUT(std::abs(index) <= 1073741824.0 && index == std::floor(index))
            << source << ": cell (" << col << ", " << row << ") has bin index " << index;
        CellStats stats = stats_of(v);
        if (!v2) steps_of(v + 10, &stats);
        rec->Insert(static_cast<std::int32_t>(index), stats);
      }
      rec->Fit();
    }
  }
  return grid;
}

bool MapLayers::CellOf(double x_m, double y_m, int* col, int* row) const {
  const double c = std::floor((x_m - x_west_m) / cell_m), r = std::floor((y_north_m - y_m) / cell_m);
  if (c < 0 || r < 0 || c >= elevation_m.cols || r >= elevation_m.rows) return false;
  *col = static_cast<int>(c);
  *row = static_cast<int>(r);
  return true;
}

cv::Mat DetectObstacles(const cv::Mat& elevation, const cv::Mat& min_m, const cv::Mat& max_m, const cv::Mat& count,
                        double cell_m, const ObstacleOptions& o, const cv::Mat& roughness, const cv::Mat& pair_step) {
  o.Validate();
  const int h = elevation.rows, w = elevation.cols;
  cv::Mat out(h, w, CV_32FC1, cv::Scalar(kNaN));
  auto judged = [&](int r, int c) {
    return r >= 0 && c >= 0 && r < h && c < w && std::isfinite(elevation.at<float>(r, c)) &&
           (count.empty() || count.at<float>(r, c) >= o.min_points);
  };
  const double tan_limit = std::tan(o.max_slope_deg * M_PI / 180.0);
  const double threshold = o.step_height_m - o.step_tolerance_m;
  for (int r = 0; r < h; ++r) {
    for (int c = 0; c < w; ++c) {
      if (!judged(r, c)) continue;
      // Rows run north to south: dy north is a row up.
      auto at = [&](int dx, int dy) {
        StepCell s;
        const int rr = r - dy, cc = c + dx;
        if (!judged(rr, cc)) return s;
        s.judged = true;
        s.elevation = elevation.at<float>(rr, cc);
        const double rough = roughness.empty() ? kNaN : roughness.at<float>(rr, cc);
        s.top = TrimmedTop(max_m.at<float>(rr, cc), s.elevation, rough, o);
        s.low = TrimmedLow(min_m.at<float>(rr, cc), s.elevation, rough, o);
        return s;
      };
      double gx = 0, gy = 0;
      int neighbours = 0;
      const double step = StepAt(at, cell_m, &gx, &gy, &neighbours);
      int kind = std::hypot(gx, gy) > tan_limit ? 2 : 0;
      // The pairs' own steps, where some pair measured one (NaN: none did), must agree.
      const float own = pair_step.empty() ? kNaN : pair_step.at<float>(r, c);
      if (step > threshold && !(own <= threshold)) kind |= 1;
      out.at<float>(r, c) = static_cast<float>(kind);
    }
  }
  return out;
}

MapLayers ComputeLayers(const TerrainGrid& grid, const ObstacleOptions& obstacles, int min_frames,
                        double carve_tolerance_m, double moved_height_m, CarveCounts* carved) {
  LN_CHECK_ARG(min_frames >= 1) << "min frames: must be >= 1";
  MapLayers l;
  l.cell_m = grid.cell_m();
  const auto b = grid.MappedBounds();
  if (!b) return l;
  const int w = static_cast<int>((*b)[2] - (*b)[0] + 1), h = static_cast<int>((*b)[3] - (*b)[1] + 1);
  const std::int64_t i0 = (*b)[0], j1 = (*b)[3];
  l.x_west_m = static_cast<double>(i0) * l.cell_m;
  l.y_north_m = static_cast<double>(j1 + 1) * l.cell_m;
  // The obstacle rule's extremes: those a second pair confirms (a cell one pair saw has only its).
  cv::Mat low(h, w, CV_32FC1, cv::Scalar(kNaN)), high(h, w, CV_32FC1, cv::Scalar(kNaN));
  cv::Mat pair_step;  // the pairs' own steps (ObstacleOptions::pair_step_support), NaN where none measured one
  if (obstacles.pair_step_support > 0) pair_step = cv::Mat(h, w, CV_32FC1, cv::Scalar(kNaN));
  for (cv::Mat* m : {&l.elevation_m, &l.min_m, &l.max_m, &l.count, &l.roughness_m, &l.sigma_m, &l.last_t_s, &l.frames}) {
    *m = cv::Mat(h, w, CV_32FC1, cv::Scalar(kNaN));
  }
  for (int row = 0; row < h; ++row) {
    for (int col = 0; col < w; ++col) {
      const std::optional<CellStats> s = grid.Find({i0 + col, j1 - row}, carve_tolerance_m, moved_height_m);
      if (s && carved != nullptr && s->carved_frames + s->moved_frames > 0) {
        carved->points += s->carved_points;
        carved->observations += s->carved_frames;
        carved->points_moved_on += s->moved_points;
        carved->observations_moved_on += s->moved_frames;
        ++(s->count > 0 ? carved->cells_changed : carved->cells_cleared);
      }
      if (!s || s->count == 0 || s->frames < static_cast<std::uint32_t>(min_frames)) continue;
      l.elevation_m.at<float>(row, col) = static_cast<float>(s->Mean());
      l.min_m.at<float>(row, col) = s->z_min;
      l.max_m.at<float>(row, col) = s->z_max;
      l.count.at<float>(row, col) = static_cast<float>(s->count);
      l.roughness_m.at<float>(row, col) = static_cast<float>(s->StdDev());
      l.sigma_m.at<float>(row, col) = static_cast<float>(s->Sigma());
      l.last_t_s.at<float>(row, col) = static_cast<float>(s->last_t_s);
      l.frames.at<float>(row, col) = static_cast<float>(s->frames);
      low.at<float>(row, col) = s->frames >= 2 ? s->z_min2 : s->z_min;
      high.at<float>(row, col) = s->frames >= 2 ? s->z_max2 : s->z_max;
      if (!pair_step.empty() && s->step_pairs > 0) {
        pair_step.at<float>(row, col) = obstacles.pair_step_support >= 2 && s->step_pairs >= 2 ? s->step2 : s->step1;
      }
    }
  }
  l.obstacle = DetectObstacles(l.elevation_m, low, high, l.count, l.cell_m, obstacles, l.roughness_m, pair_step);
  return l;
}

io::GeoRaster LayersToRaster(const MapLayers& l) {
  io::GeoRaster r;
  r.x_west_m = l.x_west_m;
  r.y_north_m = l.y_north_m;
  r.cell_m = l.cell_m;
  r.metadata["lunarnav_frame"] = "world: x east, y north, z up; metres";
  r.metadata["lunarnav_nodata"] = "NaN in every band where the cell has no point";
  const std::array<std::tuple<const cv::Mat*, const char*, const char*>, 9> bands = {{
      {&l.elevation_m, "elevation_m", "weighted mean of the pairs' observations of the cell (each its points' mean), m"},
      {&l.min_m, "min_m", "lowest accepted point, m"},
      {&l.max_m, "max_m", "highest accepted point, m"},
      {&l.count, "count", "accepted points"},
      {&l.roughness_m, "roughness_m", "standard deviation of the points about the mean (their pairs' spread and offsets), m"},
      {&l.sigma_m, "sigma_m", "predicted error of the mean elevation (1 / sqrt of the pairs' summed weights), m"},
      {&l.last_t_s, "last_t_s", "time of the last frame that added points, s"},
      {&l.obstacle, "obstacle", "0 free, 1 step, 2 slope, 3 step and slope; NaN not judged"},
      {&l.frames, "frames", "pairs that added points"},
  }};
  for (const auto& [mat, name, meaning] : bands) {
    io::RasterBand band;
    band.pixels = *mat;
    band.description = name;
    band.metadata["meaning"] = meaning;
    r.bands.push_back(std::move(band));
  }
  return r;
}

namespace internal {

// The slopes of a row's surface agree when they differ by at most this, px of disparity per px.
constexpr float kEdgeSlopeAgreement = 0.3f;

namespace {

// One column of DepthEdgeRow.
std::uint8_t DepthEdgeAt(const float* row, int col, int margin, float step) {
  const float own = row[col];
  // The farthest valid column 2-4 px away on either side (distance 0: none).
  const float l4 = row[col - 4], l3 = row[col - 3], l2 = row[col - 2];
  const float r4 = row[col + 4], r3 = row[col + 3], r2 = row[col + 2];
  const float ld = !std::isnan(l4) ? 4.0f : !std::isnan(l3) ? 3.0f : !std::isnan(l2) ? 2.0f : 0.0f;
  const float lv = !std::isnan(l4) ? l4 : !std::isnan(l3) ? l3 : l2;
  const float rd = !std::isnan(r4) ? 4.0f : !std::isnan(r3) ? 3.0f : !std::isnan(r2) ? 2.0f : 0.0f;
  const float rv = !std::isnan(r4) ? r4 : !std::isnan(r3) ? r3 : r2;
  float slope = 0.0f;
  if (ld > 0 && rd > 0) {
    const float left = (own - lv) / ld, right = (rv - own) / rd;
    if (std::abs(left - right) <= kEdgeSlopeAgreement) slope = 0.5f * (left + right);
  }
  for (int k = -margin; k <= margin; ++k) {
    if (row[col + k] - own - slope * static_cast<float>(k) > step) return 1;  // NaN compares false
  }
  return 0;
}

}  // namespace

void DepthEdgeRow(const float* row, int cols, int margin, float step, std::uint8_t* edge) {
  LN_CHECK(margin >= 0 && margin <= kEdgeRowPad) << "depth edge: margin " << margin << " beyond the row's padding";
  int col = 0;
#if defined(__SSE2__)
  // Four columns at a time, the same IEEE operations in the same order as DepthEdgeAt (bit for
  // bit its answers), without its branches: most of a row's columns are not at an edge, and
  // the scalar test's branches on holes and slopes mispredict.
  auto valid = [](__m128 v) { return _mm_cmpord_ps(v, v); };  // not NaN
  auto select = [](__m128 mask, __m128 a, __m128 b) { return _mm_or_ps(_mm_and_ps(mask, a), _mm_andnot_ps(mask, b)); };
  const __m128 zero = _mm_setzero_ps(), two = _mm_set1_ps(2.0f), three = _mm_set1_ps(3.0f), four = _mm_set1_ps(4.0f);
  const __m128 half = _mm_set1_ps(0.5f), agreement = _mm_set1_ps(kEdgeSlopeAgreement), step4 = _mm_set1_ps(step);
  const __m128 abs_mask = _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff));
  for (; col + 4 <= cols; col += 4) {
    const float* p = row + col;
    const __m128 own = _mm_loadu_ps(p);
    if (_mm_movemask_ps(valid(own)) == 0) {  // no points here (most of a row off the band's ground)
      std::fill(edge + col, edge + col + 4, std::uint8_t{0});
      continue;
    }
    const __m128 l4 = _mm_loadu_ps(p - 4), l3 = _mm_loadu_ps(p - 3), l2 = _mm_loadu_ps(p - 2);
    const __m128 r4 = _mm_loadu_ps(p + 4), r3 = _mm_loadu_ps(p + 3), r2 = _mm_loadu_ps(p + 2);
    const __m128 ld = select(valid(l4), four, select(valid(l3), three, select(valid(l2), two, zero)));
    const __m128 lv = select(valid(l4), l4, select(valid(l3), l3, l2));
    const __m128 rd = select(valid(r4), four, select(valid(r3), three, select(valid(r2), two, zero)));
    const __m128 rv = select(valid(r4), r4, select(valid(r3), r3, r2));
    const __m128 both = _mm_and_ps(_mm_cmpgt_ps(ld, zero), _mm_cmpgt_ps(rd, zero));
    // Where a side has no point its slope is unused: divide by 1 there, not 0.
    const __m128 one = _mm_set1_ps(1.0f);
    const __m128 left = _mm_div_ps(_mm_sub_ps(own, lv), select(both, ld, one));
    const __m128 right = _mm_div_ps(_mm_sub_ps(rv, own), select(both, rd, one));
    const __m128 agree = _mm_cmple_ps(_mm_and_ps(_mm_sub_ps(left, right), abs_mask), agreement);
    const __m128 slope = _mm_and_ps(_mm_and_ps(both, agree), _mm_mul_ps(half, _mm_add_ps(left, right)));
    __m128 at = _mm_setzero_ps();
    for (int k = -margin; k <= margin; ++k) {
      const __m128 carried = _mm_mul_ps(slope, _mm_set1_ps(static_cast<float>(k)));
      at = _mm_or_ps(at, _mm_cmpgt_ps(_mm_sub_ps(_mm_sub_ps(_mm_loadu_ps(p + k), own), carried), step4));
    }
    const int bits = _mm_movemask_ps(at);
    for (int q = 0; q < 4; ++q) edge[col + q] = static_cast<std::uint8_t>((bits >> q) & 1);
  }
#endif
  for (; col < cols; ++col) edge[col] = DepthEdgeAt(row, col, margin, step);
}

}  // namespace internal

}  // namespace lunarnav::mapping
