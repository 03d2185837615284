#include "sim/terrain.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <tbb/parallel_for.h>

#include "sim/random.h"
#include "util/check.h"

namespace lunarnav::sim {
namespace {

constexpr int kLevelShift = 2;  // each level of the hierarchy groups 4 x 4 nodes of the one below

struct Rock {
  double x, y, height, r1, r2, cos_t, sin_t;
};

// Salts that keep the random streams of the terrain apart.
constexpr std::uint64_t kReliefSalt = 0x52454C49;  // "RELI"
constexpr std::uint64_t kRockSalt = 0x524F434B;    // "ROCK"
constexpr std::uint64_t kAlbedoSalt = 0x414C4245;  // "ALBE"

// floor for |x| < 2^62 without a library call.
inline double FastFloor(double x) {
  const auto t = static_cast<double>(static_cast<std::int64_t>(x));
  return t > x ? t - 1.0 : t;
}

// seeds: NoiseSeed((seed ^ kReliefSalt) + k), k = 0, 1, 2, so that
// ValueNoise2Mixed(..., seeds[k]) = ValueNoise2(..., (seed ^ kReliefSalt) + k).
double Relief(const TerrainOptions& o, const std::uint32_t* seeds, double x, double y) {
  double h = o.slope_x * x + o.slope_y * y;
  if (o.relief_amplitude_m > 0) {
    const double l = o.relief_wavelength_m;
    const double n = ValueNoise2Mixed(x / l, y / l, seeds[0]) + 0.5 * ValueNoise2Mixed(2 * x / l, 2 * y / l, seeds[1]) +
                     0.25 * ValueNoise2Mixed(4 * x / l, 4 * y / l, seeds[2]);
    h += o.relief_amplitude_m * n / 1.75;
  }
  return h;
}

double MaxRockRadius(const TerrainOptions& o) {
  return 0.5 * o.rock_max_height_m * o.rock_diameter_to_height * 1.25;
}

// Whether rock r's footprint comes within the clear path's half width of its polyline.
bool OnClearPath(const TerrainOptions& o, const Rock& r) {
  const std::vector<Eigen::Vector2d>& p = o.clear_path_m;
  if (p.empty()) return false;
  const Eigen::Vector2d c(r.x, r.y);
  const double reach = o.clear_half_width_m + r.r1;
  if (p.size() == 1) return (c - p[0]).norm() <= reach;
  for (std::size_t k = 1; k < p.size(); ++k) {
    const Eigen::Vector2d d = p[k] - p[k - 1];
    const double len2 = d.squaredNorm();
    const double u = len2 > 0 ? std::clamp((c - p[k - 1]).dot(d) / len2, 0.0, 1.0) : 0.0;
    if ((c - (p[k - 1] + u * d)).norm() <= reach) return true;
  }
  return false;
}

// The rocks of the 1 m tile (tx, ty): a pure function of the tile and the seed (and the clear path).
void TileRocks(const TerrainOptions& o, std::int64_t tx, std::int64_t ty, std::vector<Rock>* out) {
  SplitMix64 rng(HashCoords(o.seed ^ kRockSalt, tx, ty));
  const double whole = std::floor(o.rock_density_per_m2);
  const int count = static_cast<int>(whole) + (rng.Uniform() < o.rock_density_per_m2 - whole ? 1 : 0);
  const double a = o.rock_size_exponent;
  const double ratio = std::pow(o.rock_min_height_m / o.rock_max_height_m, a);
  for (int k = 0; k < count; ++k) {
    Rock r;
    r.x = static_cast<double>(tx) + rng.Uniform();
    r.y = static_cast<double>(ty) + rng.Uniform();
    // Inverse CDF of the power law truncated to [min, max].
    r.height = o.rock_min_height_m * std::pow(1.0 - rng.Uniform() * (1.0 - ratio), -1.0 / a);
    const double diameter = r.height * o.rock_diameter_to_height * rng.Uniform(0.8, 1.25);
    r.r1 = 0.5 * diameter;
    r.r2 = r.r1 * rng.Uniform(0.7, 1.0);
    const double theta = rng.Uniform(0.0, M_PI);
    r.cos_t = std::cos(theta);
    r.sin_t = std::sin(theta);
    if (r.height > o.clear_max_rock_height_m && OnClearPath(o, r)) continue;  // drawn all the same: the stream stays
    out->push_back(r);
  }
}

}  // namespace

void TerrainOptions::Validate() const {
  LN_CHECK_ARG(std::isfinite(min_x_m) && std::isfinite(max_x_m) && min_x_m < max_x_m &&
               std::isfinite(min_y_m) && std::isfinite(max_y_m) && min_y_m < max_y_m)
      << "terrain extent: need min < max in x and y";
  LN_CHECK_ARG(cell_m >= 0.005 && cell_m <= 0.5) << "terrain cell: must be in [0.005, 0.5] m, got " << cell_m;
  LN_CHECK_ARG(std::isfinite(slope_x) && std::isfinite(slope_y) && std::abs(slope_x) < 1 && std::abs(slope_y) < 1)
      << "terrain slope: must be below 1 (45 deg)";
  LN_CHECK_ARG(std::isfinite(clear_half_width_m) && clear_half_width_m >= 0 && std::isfinite(clear_max_rock_height_m))
      << "terrain clear path: half width >= 0 and a finite rock height";
  for (const Eigen::Vector2d& q : clear_path_m) LN_CHECK_ARG(q.allFinite()) << "terrain clear path: not finite";
  LN_CHECK_ARG(relief_amplitude_m >= 0 && relief_amplitude_m <= 10) << "relief amplitude: must be in [0, 10] m";
  LN_CHECK_ARG(relief_wavelength_m >= 1) << "relief wavelength: must be >= 1 m";
  LN_CHECK_ARG(rock_density_per_m2 >= 0 && rock_density_per_m2 <= 20) << "rock density: must be in [0, 20] per m^2";
  LN_CHECK_ARG(rock_min_height_m > 0 && rock_min_height_m <= rock_max_height_m && rock_max_height_m <= 3)
      << "rock heights: need 0 < min <= max <= 3 m";
  LN_CHECK_ARG(rock_size_exponent > 0 && rock_size_exponent <= 10) << "rock size exponent: must be in (0, 10]";
  LN_CHECK_ARG(rock_diameter_to_height >= 1 && rock_diameter_to_height <= 20)
      << "rock diameter/height: must be in [1, 20]";
  LN_CHECK_ARG(albedo_mean > 0 && albedo_mean <= 1 && albedo_sigma >= 0 && albedo_sigma <= 1)
      << "albedo: mean in (0, 1], sigma in [0, 1]";
  LN_CHECK_ARG(texture_finest_m > 0 && texture_octaves >= 1 && texture_octaves <= 16)
      << "texture: finest spacing > 0, 1..16 octaves";
}

nlohmann::json TerrainOptions::ToJson() const {
  nlohmann::json j = {{"seed", seed},
          {"extent_m", {{"min_x", min_x_m}, {"max_x", max_x_m}, {"min_y", min_y_m}, {"max_y", max_y_m}}},
          {"cell_m", cell_m},
          {"slope_x", slope_x},
          {"slope_y", slope_y},
          {"relief_amplitude_m", relief_amplitude_m},
          {"relief_wavelength_m", relief_wavelength_m},
          {"rock_density_per_m2", rock_density_per_m2},
          {"rock_min_height_m", rock_min_height_m},
          {"rock_max_height_m", rock_max_height_m},
          {"rock_size_exponent", rock_size_exponent},
          {"rock_diameter_to_height", rock_diameter_to_height},
          {"albedo_mean", albedo_mean},
          {"albedo_sigma", albedo_sigma},
          {"texture_finest_m", texture_finest_m},
          {"texture_octaves", texture_octaves}};
  if (!clear_path_m.empty()) {
    j["clear_path"] = {{"points", clear_path_m.size()},
                       {"half_width_m", clear_half_width_m},
                       {"max_rock_height_m", clear_max_rock_height_m}};
  }
  return j;
}

Terrain::Terrain(const TerrainOptions& options) : options_(options) {
  options_.Validate();
  const TerrainOptions& o = options_;
  inv_cell_ = 1.0 / o.cell_m;
  double spacing = o.texture_finest_m;
  for (int k = 0; k < o.texture_octaves; ++k, spacing *= 2) {
    octave_seeds_.push_back(NoiseSeed((o.seed ^ kAlbedoSalt) + static_cast<std::uint64_t>(k)));
    octave_spacing_.push_back(spacing);
    octave_inv_spacing_.push_back(1.0 / spacing);
  }
  const double c = o.cell_m;
  const double cells_x = std::ceil((o.max_x_m - o.min_x_m) / c), cells_y = std::ceil((o.max_y_m - o.min_y_m) / c);
  LN_CHECK_ARG(cells_x * cells_y <= 2e8) << "terrain: " << cells_x << " x " << cells_y
                                         << " cells is too many (enlarge the cell or shrink the extent)";
  nx_ = static_cast<int>(cells_x) + 1;
  ny_ = static_cast<int>(cells_y) + 1;
  heights_.resize(static_cast<std::size_t>(nx_) * ny_);

  // Rocks by 1 m band of y, so that each grid row looks at the few rocks that reach it.
  const double reach = MaxRockRadius(o);
  const auto tx0 = static_cast<std::int64_t>(std::floor(o.min_x_m - reach));
  const auto tx1 = static_cast<std::int64_t>(std::floor(o.min_x_m + (nx_ - 1) * c + reach));
  const auto ty0 = static_cast<std::int64_t>(std::floor(o.min_y_m - reach));
  const auto ty1 = static_cast<std::int64_t>(std::floor(o.min_y_m + (ny_ - 1) * c + reach));
  std::vector<std::vector<Rock>> bands(static_cast<std::size_t>(ty1 - ty0 + 1));
  if (o.rock_density_per_m2 > 0) {
    tbb::parallel_for(ty0, ty1 + 1, [&](std::int64_t ty) {
      for (std::int64_t tx = tx0; tx <= tx1; ++tx) TileRocks(o, tx, ty, &bands[ty - ty0]);
    });
  }
  const auto band_reach = static_cast<std::int64_t>(std::ceil(reach)) + 1;
  std::uint32_t relief_seeds[3];
  for (int k = 0; k < 3; ++k) {
    relief_seeds[k] = NoiseSeed((o.seed ^ kReliefSalt) + static_cast<std::uint64_t>(k));
  }

  tbb::parallel_for(0, ny_, [&](int j) {
    const double y = o.min_y_m + j * c;
    float* row = &heights_[static_cast<std::size_t>(j) * nx_];
    std::vector<double> rock(nx_, 0.0);
    const auto band = static_cast<std::int64_t>(std::floor(y));
    for (std::int64_t b = std::max(band - band_reach, ty0); b <= std::min(band + band_reach, ty1); ++b) {
      for (const Rock& r : bands[b - ty0]) {
        const double dy = y - r.y;
        if (std::abs(dy) >= r.r1) continue;
        const int i0 = std::max(0, static_cast<int>(std::floor((r.x - r.r1 - o.min_x_m) / c)));
        const int i1 = std::min(nx_ - 1, static_cast<int>(std::ceil((r.x + r.r1 - o.min_x_m) / c)));
        for (int i = i0; i <= i1; ++i) {
          const double dx = o.min_x_m + i * c - r.x;
          const double u = (r.cos_t * dx + r.sin_t * dy) / r.r1, v = (-r.sin_t * dx + r.cos_t * dy) / r.r2;
          const double q = u * u + v * v;
          if (q < 1) rock[i] = std::max(rock[i], r.height * (1 - q) * (1 - q));
        }
      }
    }
    for (int i = 0; i < nx_; ++i) row[i] = static_cast<float>(Relief(o, relief_seeds, o.min_x_m + i * c, y) + rock[i]);
  });

  // Level 0: the maximum of each cell's four corners bounds its bilinear patch.
  level_nx_.push_back(nx_ - 1);
  level_ny_.push_back(ny_ - 1);
  levels_.emplace_back(static_cast<std::size_t>(nx_ - 1) * (ny_ - 1));
  tbb::parallel_for(0, ny_ - 1, [&](int j) {
    for (int i = 0; i < nx_ - 1; ++i) {
      levels_[0][static_cast<std::size_t>(j) * (nx_ - 1) + i] =
          std::max({H(i, j), H(i + 1, j), H(i, j + 1), H(i + 1, j + 1)});
    }
  });
  while (level_nx_.back() > 2 || level_ny_.back() > 2) {
    const int pnx = level_nx_.back(), pny = level_ny_.back();
    const int lnx = (pnx + 3) >> kLevelShift, lny = (pny + 3) >> kLevelShift;
    std::vector<float> level(static_cast<std::size_t>(lnx) * lny, -std::numeric_limits<float>::infinity());
    const std::vector<float>& prev = levels_.back();
    for (int j = 0; j < pny; ++j) {
      for (int i = 0; i < pnx; ++i) {
        float& m = level[static_cast<std::size_t>(j >> kLevelShift) * lnx + (i >> kLevelShift)];
        m = std::max(m, prev[static_cast<std::size_t>(j) * pnx + i]);
      }
    }
    levels_.push_back(std::move(level));
    level_nx_.push_back(lnx);
    level_ny_.push_back(lny);
  }
  const auto [lo, hi] = std::minmax_element(heights_.begin(), heights_.end());
  min_height_ = *lo;
  max_height_ = *hi;
}

std::vector<TerrainRock> Terrain::Rocks() const {
  const TerrainOptions& o = options_;
  std::vector<TerrainRock> out;
  if (o.rock_density_per_m2 <= 0) return out;
  const double x1 = o.min_x_m + (nx_ - 1) * o.cell_m, y1 = o.min_y_m + (ny_ - 1) * o.cell_m;
  std::vector<Rock> tile;
  for (auto ty = static_cast<std::int64_t>(std::floor(o.min_y_m)); ty <= static_cast<std::int64_t>(std::floor(y1)); ++ty) {
    for (auto tx = static_cast<std::int64_t>(std::floor(o.min_x_m)); tx <= static_cast<std::int64_t>(std::floor(x1));
         ++tx) {
      tile.clear();
      TileRocks(o, tx, ty, &tile);
      for (const Rock& r : tile) {
        if (r.x < o.min_x_m || r.x > x1 || r.y < o.min_y_m || r.y > y1) continue;
        out.push_back({r.x, r.y, r.height, r.r1, r.r2, std::atan2(r.sin_t, r.cos_t)});
      }
    }
  }
  return out;
}

double Terrain::HeightAt(double x_m, double y_m) const {
  const double c = options_.cell_m;
  const double gx = (x_m - options_.min_x_m) / c, gy = (y_m - options_.min_y_m) / c;
  if (!(gx >= 0 && gy >= 0 && gx <= nx_ - 1 && gy <= ny_ - 1)) return std::numeric_limits<double>::quiet_NaN();
  const int i = std::min(static_cast<int>(gx), nx_ - 2), j = std::min(static_cast<int>(gy), ny_ - 2);
  const double u = gx - i, v = gy - j;
  const double h00 = H(i, j), h10 = H(i + 1, j), h01 = H(i, j + 1), h11 = H(i + 1, j + 1);
  return h00 + (h10 - h00) * u + (h01 - h00) * v + (h00 - h10 - h01 + h11) * u * v;
}

Eigen::Vector2d Terrain::VertexGradient(int i, int j) const {
  const int i0 = std::max(i - 1, 0), i1 = std::min(i + 1, nx_ - 1);
  const int j0 = std::max(j - 1, 0), j1 = std::min(j + 1, ny_ - 1);
  const double sx = (i1 - i0 == 2 ? 0.5 : 1.0) * inv_cell_, sy = (j1 - j0 == 2 ? 0.5 : 1.0) * inv_cell_;
  return {(H(i1, j) - H(i0, j)) * sx, (H(i, j1) - H(i, j0)) * sy};
}

Eigen::Vector3d Terrain::NormalAt(double x_m, double y_m) const {
  const double c = options_.cell_m;
  const double gx = (x_m - options_.min_x_m) / c, gy = (y_m - options_.min_y_m) / c;
  if (!(gx >= 0 && gy >= 0 && gx <= nx_ - 1 && gy <= ny_ - 1)) return Eigen::Vector3d::UnitZ();
  const int i = std::min(static_cast<int>(gx), nx_ - 2), j = std::min(static_cast<int>(gy), ny_ - 2);
  const double u = gx - i, v = gy - j;
  const Eigen::Vector2d g = (1 - u) * (1 - v) * VertexGradient(i, j) + u * (1 - v) * VertexGradient(i + 1, j) +
                            (1 - u) * v * VertexGradient(i, j + 1) + u * v * VertexGradient(i + 1, j + 1);
  return Eigen::Vector3d(-g.x(), -g.y(), 1.0).normalized();
}

double Terrain::AlbedoAt(double x_m, double y_m, double footprint_m) const {
  const TerrainOptions& o = options_;
  // FractalNoise2(x, y, seed ^ kAlbedoSalt, finest, octaves, footprint) with the per-octave
  // work hoisted out (same values up to the rounding of x / spacing; terrain_test checks it).
  double sum = 0;
  const double inv_footprint = footprint_m > 0 ? 1.0 / footprint_m : 0.0;
  for (std::size_t k = 0; k < octave_seeds_.size(); ++k) {
    const double w = footprint_m > 0 ? std::clamp(octave_spacing_[k] * inv_footprint - 1.0, 0.0, 1.0) : 1.0;
    if (w > 0) sum += w * ValueNoise2Mixed(x_m * octave_inv_spacing_[k], y_m * octave_inv_spacing_[k], octave_seeds_[k]);
  }
  constexpr double kValueNoiseSigma = 0.45;  // as in FractalNoise2
  const double n = sum / (kValueNoiseSigma * std::sqrt(static_cast<double>(o.texture_octaves)));
  return std::clamp(o.albedo_mean + o.albedo_sigma * n, 0.02, 1.0);
}

std::optional<double> Terrain::Intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                                         double t_min, double t_max) const {
  const double c = options_.cell_m;
  const double x0 = options_.min_x_m, y0 = options_.min_y_m;
  const double ox = origin.x(), oy = origin.y(), oz = origin.z();
  const double dx = direction.x(), dy = direction.y(), dz = direction.z();
  // Clip to the grid's box: x, y inside the grid, z below the highest point.
  double t0 = t_min, t1 = t_max;
  auto clip = [&](double o, double d, double lo, double hi) {
    if (d == 0) {
      if (o < lo || o > hi) t1 = -1;
      return;
    }
    double a = (lo - o) / d, b = (hi - o) / d;
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
  };
  clip(ox, dx, x0, x0 + (nx_ - 1) * c);
  clip(oy, dy, y0, y0 + (ny_ - 1) * c);
  clip(oz, dz, -std::numeric_limits<double>::infinity(), max_height_);
  if (!(t0 <= t1)) return std::nullopt;

  const int top = static_cast<int>(levels_.size()) - 1;
  int level = top;
  auto node_of = [&](double p, double origin_m, int lvl, int count) {
    // Within an ulp of the division; on a node boundary either neighbour is a valid start.
    const double inv_size = inv_cell_ / static_cast<double>(1 << (kLevelShift * lvl));
    return std::clamp(static_cast<int>(FastFloor((p - origin_m) * inv_size)), 0, count - 1);
  };
  int ix = node_of(ox + dx * t0, x0, level, level_nx_[level]);
  int iy = node_of(oy + dy * t0, y0, level, level_ny_[level]);
  const int sx = dx > 0 ? 1 : -1, sy = dy > 0 ? 1 : -1;
  // Reciprocals: the node-boundary crossings below are the inner loop's only divisions.
  const double inv_dx = dx != 0 ? 1.0 / dx : 0.0, inv_dy = dy != 0 ? 1.0 / dy : 0.0;
  double t = t0;
  for (int guard = 0; guard < 10000000; ++guard) {
    const double size = c * static_cast<double>(1 << (kLevelShift * level));
    const double bx = x0 + (ix + (dx > 0 ? 1 : 0)) * size, by = y0 + (iy + (dy > 0 ? 1 : 0)) * size;
    const double tx = dx != 0 ? (bx - ox) * inv_dx : std::numeric_limits<double>::infinity();
    const double ty = dy != 0 ? (by - oy) * inv_dy : std::numeric_limits<double>::infinity();
    const double t_exit = std::max(t, std::min({tx, ty, t1}));
    const double z_low = oz + dz * (dz < 0 ? t_exit : t);
    const float node_max = levels_[level][static_cast<std::size_t>(iy) * level_nx_[level] + ix];
    if (z_low <= node_max) {
      if (level > 0) {
        // Descend into the child that contains the ray at t.
        --level;
        const double px = ox + dx * t, py = oy + dy * t;
        ix = std::clamp(node_of(px, x0, level, level_nx_[level]), ix << kLevelShift,
                        std::min((ix << kLevelShift) + 3, level_nx_[level] - 1));
        iy = std::clamp(node_of(py, y0, level, level_ny_[level]), iy << kLevelShift,
                        std::min((iy << kLevelShift) + 3, level_ny_[level] - 1));
        continue;
      }
      // A cell: solve z(s) = h(s) for the bilinear patch, s = t' - t in [0, t_exit - t].
      const double h00 = H(ix, iy), h10 = H(ix + 1, iy), h01 = H(ix, iy + 1), h11 = H(ix + 1, iy + 1);
      const double a = h10 - h00, b = h01 - h00, e = h00 - h10 - h01 + h11;
      const double u0 = (ox + dx * t - (x0 + ix * c)) / c, v0 = (oy + dy * t - (y0 + iy * c)) / c;
      const double du = dx / c, dv = dy / c;
      const double cc = (oz + dz * t) - (h00 + a * u0 + b * v0 + e * u0 * v0);
      const double bb = dz - (a * du + b * dv + e * (u0 * dv + v0 * du));
      const double aa = -e * du * dv;
      const double len = t_exit - t;
      if (cc <= 0) return t;
      double s = std::numeric_limits<double>::infinity();
      if (std::abs(aa) * len < 1e-12 * (std::abs(bb) + 1e-300)) {
        if (bb < 0) s = -cc / bb;
      } else {
        const double disc = bb * bb - 4 * aa * cc;
        if (disc >= 0) {
          const double q = -0.5 * (bb + (bb >= 0 ? 1 : -1) * std::sqrt(disc));
          const double r1 = q / aa, r2 = q != 0 ? cc / q : std::numeric_limits<double>::infinity();
          for (double r : {r1, r2}) {
            if (r >= 0 && r < s) s = r;
          }
        }
      }
      if (s <= len) return t + s;
    }
    // Move to the next node along the ray.
    if (t_exit >= t1) return std::nullopt;
    t = t_exit;
    const int old_ix = ix, old_iy = iy;
    if (tx <= ty) {
      ix += sx;
    } else {
      iy += sy;
    }
    if (ix < 0 || iy < 0 || ix >= level_nx_[level] || iy >= level_ny_[level]) return std::nullopt;
    if (level < top && ((ix >> kLevelShift) != (old_ix >> kLevelShift) || (iy >> kLevelShift) != (old_iy >> kLevelShift))) {
      ++level;
      ix >>= kLevelShift;
      iy >>= kLevelShift;
    }
  }
  LN_CHECK(false) << "terrain ray cast did not terminate";
  return std::nullopt;
}

}  // namespace lunarnav::sim
