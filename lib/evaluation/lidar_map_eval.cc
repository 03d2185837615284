#include "evaluation/lidar_map_eval.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iomanip>
#include <map>
#include <optional>
#include <opencv2/imgproc.hpp>
#include <set>
#include <sstream>

#include "calib/stereo_rig_io.h"
#include "calib/window_selection.h"
#include "evaluation/map_rasters.h"
#include "io/atomic_file.h"
#include "io/float_array_io.h"
#include "io/image_io.h"
#include "io/json_io.h"
#include "io/point_cloud_io.h"
#include "io/stereo_pairs.h"
#include "mapping/kitti_trajectory.h"
#include "stereo/batch.h"
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
constexpr float kNaNf = std::numeric_limits<float>::quiet_NaN();
// Cells this far beyond (or short of) an untimely pair's band are not judged either: its
// points reach past the band's distances by their errors and at the image's sides, m.
constexpr double kUntimelyMarginM = 3.0;
// How far the path is carried on beyond its first and last pairs for the lateral profile, m.
constexpr double kPathExtensionM = 100.0;
// A pair's offset from its sweep needs this many flat cells that both saw.
constexpr std::size_t kPairOffsetMinCells = 10;
// PairDisparityOffset: the differences counted, and the fewest that make a pair's median.
constexpr double kPairDisparityWithinPx = 3.0;
constexpr std::size_t kPairDisparityMinReturns = 50;
// A cell whose low returns lie this far below the wider area's is sunk (a reflection, a hole), m.
constexpr double kSunkDepthM = 0.3;
// The largest truth grid, cells: 4096 x 4096 (a square kilometre of 25 cm cells).
constexpr std::int64_t kMaxTruthCells = std::int64_t{1} << 24;

enum CellClass : int { kNone = 0, kFlat = 1, kObject = 2, kOther = 3 };

// A band of a raster: its pixels and name.
io::RasterBand NamedBand(const cv::Mat& pixels, const char* name) {
  io::RasterBand band;
  band.pixels = pixels;
  band.description = name;
  return band;
}

using internal::Number;
using internal::Ratio;

double Median(std::vector<float>* v) {
  if (v->empty()) return kNaN;
  const auto mid = v->begin() + static_cast<std::ptrdiff_t>(v->size() / 2);
  std::nth_element(v->begin(), mid, v->end());
  double m = *mid;
  if (v->size() % 2 == 0) m = 0.5 * (m + *std::max_element(v->begin(), mid));
  return m;
}

double MedianOf(std::vector<double> v) {
  if (v.empty()) return kNaN;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

const cv::Mat& Band(const io::GeoRaster& r, const std::string& name, const std::string& what) {
  return internal::FloatBand(r, name, what);
}

float At(const cv::Mat& m, int col, int row) { return internal::ValueAt(m, col, row); }

// The returns of every sweep binned by truth cell (a counting sort): cell k's returns are
// z[start[k] .. start[k + 1]), with their sweeps.
struct Binned {
  std::vector<std::int64_t> start;
  std::vector<float> z;
  std::vector<int> sweep;
};

Binned BinReturns(const std::vector<LidarSweep>& sweeps, const io::GeoRaster& grid) {
  const int w = grid.Width(), h = grid.Height();
  auto cell_of = [&](const Eigen::Vector3f& p) -> std::int64_t {
    const double col = std::floor((p.x() - grid.x_west_m) / grid.cell_m);
    const double row = std::floor((grid.y_north_m - p.y()) / grid.cell_m);
    if (!(col >= 0 && row >= 0 && col < w && row < h)) return -1;
    return static_cast<std::int64_t>(row) * w + static_cast<std::int64_t>(col);
  };
  Binned b;
  b.start.assign(static_cast<std::size_t>(w) * static_cast<std::size_t>(h) + 1, 0);
  for (const LidarSweep& s : sweeps) {
    for (const Eigen::Vector3f& p : s.points) {
      const std::int64_t k = cell_of(p);
      if (k >= 0) ++b.start[static_cast<std::size_t>(k) + 1];
    }
  }
  for (std::size_t k = 1; k < b.start.size(); ++k) b.start[k] += b.start[k - 1];
  b.z.resize(static_cast<std::size_t>(b.start.back()));
  b.sweep.resize(b.z.size());
  std::vector<std::int64_t> fill(b.start.begin(), b.start.end() - 1);
  for (std::size_t s = 0; s < sweeps.size(); ++s) {
    for (const Eigen::Vector3f& p : sweeps[s].points) {
      const std::int64_t k = cell_of(p);
      if (k < 0) continue;
      const auto at = static_cast<std::size_t>(fill[static_cast<std::size_t>(k)]++);
      b.z[at] = p.z();
      b.sweep[at] = static_cast<int>(s);
    }
  }
  return b;
}

// The height at cell (col, row)'s centre of the ground's plane under the 5 x 5 cells' low
// returns (sunk cells left out): the least-squares plane of all the lows, then four times of
// those no more than 5 cm above the last plane, so that it sinks to the lower envelope: an
// object's own lows stand above and drop out, a slope's stay. The lowest low when fewer than
// 4 lows are there.
double LowPlaneAtCentre(const cv::Mat& low, const cv::Mat& sunk, int col, int row, double cell_m) {
  struct Low {
    double x, y, z;
  };
  std::vector<Low> lows;
  double lowest = std::numeric_limits<double>::infinity();
  for (int dr = -2; dr <= 2; ++dr) {
    for (int dc = -2; dc <= 2; ++dc) {
      const int c = col + dc, r = row + dr;
      const float v = At(low, c, r);
      if (!std::isfinite(v) || sunk.at<std::uint8_t>(r, c) != 0) continue;
      lows.push_back({dc * cell_m, -dr * cell_m, v});
      lowest = std::min(lowest, static_cast<double>(v));
    }
  }
  if (lows.size() < 4) return std::isfinite(lowest) ? lowest : At(low, col, row);
  Eigen::Vector3d plane(lowest, 0, 0);  // z = a + b x + c y
  for (int pass = 0; pass < 5; ++pass) {
    Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
    Eigen::Vector3d atb = Eigen::Vector3d::Zero();
    int used = 0;
    for (const Low& l : lows) {
      const Eigen::Vector3d a(1, l.x, l.y);
      if (pass > 0 && l.z - a.dot(plane) > 0.05) continue;
      ata += a * a.transpose();
      atb += a * l.z;
      ++used;
    }
    if (used < 4 || std::abs(ata.determinant()) < 1e-9) break;
    plane = ata.ldlt().solve(atb);
  }
  return plane(0);
}

// The truth grid's lattice: the map's, over the box of every return.
io::GeoRaster TruthLattice(const std::vector<LidarSweep>& sweeps, const io::GeoRaster& map) {
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
  for (const LidarSweep& s : sweeps) {
    for (const Eigen::Vector3f& p : s.points) {
      x0 = std::min(x0, static_cast<double>(p.x()));
      x1 = std::max(x1, static_cast<double>(p.x()));
      y0 = std::min(y0, static_cast<double>(p.y()));
      y1 = std::max(y1, static_cast<double>(p.y()));
    }
  }
  io::GeoRaster g;
  g.cell_m = map.cell_m;
  if (!(x0 <= x1)) {  // no return: one empty cell at the map's corner
    g.x_west_m = map.x_west_m;
    g.y_north_m = map.y_north_m;
    g.bands.push_back(NamedBand(cv::Mat(1, 1, CV_32FC1, cv::Scalar(0)), "returns"));
    return g;
  }
  const double c = map.cell_m;
  const double first_col = std::floor((x0 - map.x_west_m) / c), last_col = std::floor((x1 - map.x_west_m) / c);
  const double first_row = std::floor((map.y_north_m - y1) / c), last_row = std::floor((map.y_north_m - y0) / c);
  const double cells = (last_col - first_col + 1) * (last_row - first_row + 1);
  LN_CHECK_INPUT(cells <= static_cast<double>(kMaxTruthCells))
      << "the LiDAR returns span " << (x1 - x0) << " x " << (y1 - y0) << " m, more than " << kMaxTruthCells
      << " cells of " << c << " m (a sweep or pose far from the others?)";
  g.x_west_m = map.x_west_m + first_col * c;
  g.y_north_m = map.y_north_m - first_row * c;
  const int w = static_cast<int>(last_col - first_col + 1), h = static_cast<int>(last_row - first_row + 1);
  g.bands.push_back(NamedBand(cv::Mat(h, w, CV_32FC1, cv::Scalar(0)), "returns"));
  return g;
}

// Offset of raster b's cells in raster a's: b(col, row) = a(col + dc, row + dr).
void LatticeOffset(const io::GeoRaster& a, const io::GeoRaster& b, int* dc, int* dr) {
  internal::LatticeOffset(a, b, "the LiDAR truth", dc, dr);
}

// Where a vehicle-frame point falls in the rig's rectified images: true when inside both.
bool InBothImages(const calib::StereoRig& rig, const Eigen::Isometry3d& left_from_vehicle, const Eigen::Vector3d& v) {
  const calib::RectifiedGeometry& g = *rig.rectified;
  const Eigen::Vector3d rect = g.rect_from_left * (left_from_vehicle * v);
  if (rect.z() <= 0.1) return false;
  for (const auto* p : {&g.P_left, &g.P_right}) {
    const Eigen::Vector3d x = *p * rect.homogeneous();
    const double u = x.x() / x.z(), r = x.y() / x.z();
    if (!(u >= -0.5 && u <= g.width_px - 0.5 && r >= -0.5 && r <= g.height_px - 0.5)) return false;
  }
  return true;
}

}  // namespace

namespace internal {

PathOffsets::PathOffsets(std::vector<Eigen::Vector2d> path, double bucket_m)
    : path_(std::move(path)), bucket_m_(bucket_m) {
  LN_CHECK_ARG(std::isfinite(bucket_m_) && bucket_m_ > 0) << "path offsets: bucket must be > 0 m";
  if (path_.empty()) return;
  origin_ = path_.front();
  auto bucket = [&](double v, double o) { return static_cast<std::int64_t>(std::floor((v - o) / bucket_m_)); };
  for (std::size_t k = 0; k + 1 < path_.size(); ++k) {
    const Eigen::Vector2d a = path_[k], b = path_[k + 1];
    if (!((b - a).squaredNorm() > 0)) continue;
    const std::int64_t x0 = bucket(std::min(a.x(), b.x()), origin_.x());
    const std::int64_t x1 = bucket(std::max(a.x(), b.x()), origin_.x());
    const std::int64_t y0 = bucket(std::min(a.y(), b.y()), origin_.y());
    const std::int64_t y1 = bucket(std::max(a.y(), b.y()), origin_.y());
    // A long diagonal segment (the path's extensions) crosses few of its box's buckets: keep
    // those within a bucket's diagonal of it.
    const Eigen::Vector2d d = b - a;
    const double reach = bucket_m_ * std::sqrt(2.0);
    for (std::int64_t bx = x0; bx <= x1; ++bx) {
      for (std::int64_t by = y0; by <= y1; ++by) {
        const Eigen::Vector2d c = origin_ + bucket_m_ * Eigen::Vector2d(bx + 0.5, by + 0.5);
        const double s = std::clamp((c - a).dot(d) / d.squaredNorm(), 0.0, 1.0);
        if ((c - (a + s * d)).norm() > reach) continue;
        buckets_[Key(bx, by)].push_back(static_cast<int>(k));
        if (bx1_ < bx0_) {
          bx0_ = bx1_ = bx;
          by0_ = by1_ = by;
        }
        bx0_ = std::min(bx0_, bx);
        bx1_ = std::max(bx1_, bx);
        by0_ = std::min(by0_, by);
        by1_ = std::max(by1_, by);
      }
    }
  }
}

double PathOffsets::Offset(const Eigen::Vector2d& w) const {
  if (buckets_.empty()) return kNaN;
  const std::int64_t qx = static_cast<std::int64_t>(std::floor((w.x() - origin_.x()) / bucket_m_));
  const std::int64_t qy = static_cast<std::int64_t>(std::floor((w.y() - origin_.y()) / bucket_m_));
  double best = std::numeric_limits<double>::infinity(), offset = kNaN;
  int best_k = -1;
  auto visit = [&](std::int64_t bx, std::int64_t by) {
    const auto it = buckets_.find(Key(bx, by));
    if (it == buckets_.end()) return;
    for (const int k : it->second) {
      const Eigen::Vector2d a = path_[static_cast<std::size_t>(k)], d = path_[static_cast<std::size_t>(k) + 1] - a;
      const double s = std::clamp((w - a).dot(d) / d.squaredNorm(), 0.0, 1.0);
      const Eigen::Vector2d r = w - (a + s * d);
      const double r2 = r.squaredNorm();
      if (r2 < best || (r2 == best && k < best_k)) {
        best = r2;
        best_k = k;
        const double cross = d.x() * r.y() - d.y() * r.x();  // > 0: left of travel
        offset = (cross > 0 ? -1.0 : 1.0) * r.norm();
      }
    }
  };
  // Ring r holds the buckets r away (Chebyshev); every point of ring r + 1 lies at least
  // r buckets from w. A segment's nearest point lies in a bucket holding the segment
  // (buckets within a diagonal of it hold it), so once the best is that near, no ring beyond
  // can hold a nearer one.
  const std::int64_t last =
      std::max({std::abs(qx - bx0_), std::abs(qx - bx1_), std::abs(qy - by0_), std::abs(qy - by1_)});
  for (std::int64_t r = 0; r <= last; ++r) {
    if (r == 0) {
      visit(qx, qy);
    } else {
      for (std::int64_t i = -r; i <= r; ++i) {
        visit(qx + i, qy - r);
        visit(qx + i, qy + r);
      }
      for (std::int64_t i = -r + 1; i <= r - 1; ++i) {
        visit(qx - r, qy + i);
        visit(qx + r, qy + i);
      }
    }
    const double clear = static_cast<double>(r) * bucket_m_;
    if (best_k >= 0 && best < clear * clear) break;
  }
  return offset;
}

}  // namespace internal

void LidarEvalOptions::Validate() const {
  LN_CHECK_ARG(min_points >= 1 && min_lidar_points >= 1) << "min points: must be >= 1";
  LN_CHECK_ARG(std::isfinite(flat_spread_m) && flat_spread_m > 0) << "flat spread: must be > 0 m";
  LN_CHECK_ARG(std::isfinite(object_height_m) && object_height_m > 0) << "object height: must be > 0 m";
  LN_CHECK_ARG(std::isfinite(clearance_m) && clearance_m > object_height_m)
      << "clearance: must exceed the object height";
  LN_CHECK_ARG(std::isfinite(min_range_m) && std::isfinite(max_range_m) && min_range_m >= 0 &&
               min_range_m < max_range_m)
      << "LiDAR range: need 0 <= MIN < MAX";
  LN_CHECK_ARG(std::isfinite(relief_height_m) && relief_height_m > 0 && std::isfinite(recall_height_m) &&
               recall_height_m > 0)
      << "relief heights: must be > 0 m";
  LN_CHECK_ARG(tolerance_cells >= 0 && tolerance_cells <= 10) << "tolerance: must be in 0..10 cells";
  LN_CHECK_ARG(std::isfinite(overhang_m) && overhang_m > recall_height_m) << "overhang: must exceed the recall height";
  LN_CHECK_ARG(std::isfinite(large_error_m) && large_error_m > 0) << "large error: must be > 0 m";
  LN_CHECK_ARG(max_sweep_gap_s >= 0) << "sweep gap: must be >= 0 s";
  LN_CHECK_ARG(std::isfinite(band_min_y_m) && std::isfinite(band_max_y_m) && band_min_y_m < band_max_y_m)
      << "band: need finite MIN < MAX, got " << band_min_y_m << ":" << band_max_y_m << " m";
  // Within 1000 m, as every distance interval (a band 1e300 m ahead scored nothing, exit 0).
  LN_CHECK_ARG(std::abs(band_min_y_m) <= 1000 && std::abs(band_max_y_m) <= 1000)
      << "band: " << band_min_y_m << ":" << band_max_y_m << " m reaches beyond 1000 m";
  LN_CHECK_ARG(max_range_m <= 1000) << "LiDAR range: at most 1000 m, got " << max_range_m << " m";
  LN_CHECK_ARG(std::isfinite(sweeps_agree_m) && sweeps_agree_m > 0) << "sweeps agree: must be > 0 m";
  LN_CHECK_ARG(std::isfinite(band_max_z_m) && std::abs(band_max_z_m) <= 1000)
      << "band height: must be finite, within 1000 m, got " << band_max_z_m << " m";
}

json LidarEvalOptions::ToJson() const {
  return {{"min_points", min_points},
          {"min_lidar_points", min_lidar_points},
          {"flat_spread_m", flat_spread_m},
          {"object_height_m", object_height_m},
          {"clearance_m", clearance_m},
          {"lidar_range_m", {min_range_m, max_range_m}},
          {"relief_height_m", relief_height_m},
          {"recall_height_m", recall_height_m},
          {"overhang_m", overhang_m},
          {"tolerance_cells", tolerance_cells},
          {"large_error_m", large_error_m},
          {"band_y_m", {band_min_y_m, band_max_y_m}},
          {"band_max_z_m", band_max_z_m},
          {"sweeps_agree_m", sweeps_agree_m},
          {"max_sweep_gap_s", Number(max_sweep_gap_s)}};
}

io::GeoRaster GridLidarTruth(const std::vector<LidarSweep>& sweeps, const io::GeoRaster& lattice,
                             const LidarEvalOptions& o, std::vector<std::vector<int>>* stood_in) {
  io::GeoRaster g = TruthLattice(sweeps, lattice);
  const int w = g.Width(), h = g.Height();
  const Binned b = BinReturns(sweeps, g);
  cv::Mat returns = g.bands[0].pixels;
  if (stood_in != nullptr) stood_in->assign(static_cast<std::size_t>(w) * static_cast<std::size_t>(h), {});
  cv::Mat low(h, w, CV_32FC1, cv::Scalar(kNaNf));
  for (int row = 0; row < h; ++row) {
    for (int col = 0; col < w; ++col) {
      const std::size_t k = static_cast<std::size_t>(row) * static_cast<std::size_t>(w) + static_cast<std::size_t>(col);
      const std::int64_t n = b.start[k + 1] - b.start[k];
      returns.at<float>(row, col) = static_cast<float>(n);
      if (n == 0) continue;
      std::vector<float> z(b.z.begin() + b.start[k], b.z.begin() + b.start[k + 1]);
      const auto at = z.begin() + static_cast<std::ptrdiff_t>(z.size() / 10);
      std::nth_element(z.begin(), at, z.end());
      low.at<float>(row, col) = *at;  // the cell's low returns: its ground, or the top of what hides it
    }
  }
  // Sunk cells: low returns far below the wider area's (the median of the 9 x 9 cells' low
  // returns): a laser's reflection in glass or water (a mirror image below the road: KITTI raw
  // drive 0005 has 3-5 m deep ones beside shop windows) or a hole. They are neither ground nor
  // the ground under their neighbours.
  cv::Mat sunk(h, w, CV_8UC1, cv::Scalar(0));
  for (int row = 0; row < h; ++row) {
    for (int col = 0; col < w; ++col) {
      const float own = low.at<float>(row, col);
      if (!std::isfinite(own)) continue;
      std::vector<float> around;
      for (int dr = -4; dr <= 4; ++dr) {
        for (int dc = -4; dc <= 4; ++dc) {
          const float v = At(low, col + dc, row + dr);
          if (std::isfinite(v)) around.push_back(v);
        }
      }
      sunk.at<std::uint8_t>(row, col) = own < Median(&around) - kSunkDepthM;
    }
  }
  // The local ground: the lowest low return of the 5 x 5 cells around that are not sunk.
  cv::Mat ground(h, w, CV_32FC1, cv::Scalar(kNaNf)), relief(h, w, CV_32FC1, cv::Scalar(kNaNf));
  cv::Mat top(h, w, CV_32FC1, cv::Scalar(kNaNf)), median(h, w, CV_32FC1, cv::Scalar(kNaNf));
  cv::Mat spread(h, w, CV_32FC1, cv::Scalar(kNaNf)), standing(h, w, CV_32FC1, cv::Scalar(kNaNf));
  cv::Mat persistence(h, w, CV_32FC1, cv::Scalar(kNaNf));
  for (int row = 0; row < h; ++row) {
    for (int col = 0; col < w; ++col) {
      if (returns.at<float>(row, col) == 0) continue;
      float g0 = std::numeric_limits<float>::infinity();
      for (int dr = -2; dr <= 2; ++dr) {
        for (int dc = -2; dc <= 2; ++dc) {
          const int c = col + dc, r = row + dr;
          const float v = At(low, c, r);
          if (std::isfinite(v) && sunk.at<std::uint8_t>(r, c) == 0) g0 = std::min(g0, v);
        }
      }
      if (!std::isfinite(g0)) g0 = low.at<float>(row, col);  // every cell around is sunk
      ground.at<float>(row, col) = g0;
      const std::size_t k = static_cast<std::size_t>(row) * static_cast<std::size_t>(w) + static_cast<std::size_t>(col);
      std::vector<float> below;  // the returns under the clearance
      for (std::int64_t i = b.start[k]; i < b.start[k + 1]; ++i) {
        const float z = b.z[static_cast<std::size_t>(i)];
        if (z - g0 <= o.clearance_m) below.push_back(z);
      }
      if (below.empty()) continue;
      // What stands here: the highest return over the plane through the 5 x 5 cells' low
      // returns (a slope's rise is no object), and in how many of the sweeps that saw the
      // cell it stood (a moving object stands in one or two of the many).
      const double plane = LowPlaneAtCentre(low, sunk, col, row, g.cell_m);
      // An overhang: the ground seen, and nothing between it and overhang_m.
      bool ground_seen = false;
      double base = std::numeric_limits<double>::infinity();
      for (float z : below) {
        if (z - plane < o.recall_height_m) {
          ground_seen = true;
        } else {
          base = std::min(base, z - plane);
        }
      }
      const bool overhang = ground_seen && base >= o.overhang_m;
      double highest = -std::numeric_limits<double>::infinity();
      std::map<int, bool> stood;  // per sweep that saw the cell: whether it stood
      for (std::int64_t i = b.start[k]; i < b.start[k + 1]; ++i) {
        const float z = b.z[static_cast<std::size_t>(i)];
        if (z - g0 > o.clearance_m || (overhang && z - plane >= o.recall_height_m)) continue;
        highest = std::max(highest, static_cast<double>(z));
        bool& s = stood[b.sweep[static_cast<std::size_t>(i)]];
        s = s || z - plane >= o.recall_height_m;
      }
      int stood_count = 0;
      for (const auto& [sweep, yes] : stood) {
        stood_count += yes;
        if (yes && stood_in != nullptr) (*stood_in)[k].push_back(sweep);
      }
      standing.at<float>(row, col) = static_cast<float>(highest - plane);
      persistence.at<float>(row, col) = static_cast<float>(stood_count) / static_cast<float>(stood.size());
      const auto [lo, hi] = std::minmax_element(below.begin(), below.end());
      relief.at<float>(row, col) = *hi - g0;
      top.at<float>(row, col) = *hi;
      const float lo_v = *lo, hi_v = *hi;
      const double m = Median(&below);
      median.at<float>(row, col) = static_cast<float>(m);
      spread.at<float>(row, col) = static_cast<float>(std::max(hi_v - m, m - lo_v));
      returns.at<float>(row, col) = static_cast<float>(below.size());
    }
  }
  cv::Mat cls(h, w, CV_32FC1, cv::Scalar(kNone)), flat_ground(h, w, CV_32FC1, cv::Scalar(kNaNf));
  for (int row = 0; row < h; ++row) {
    for (int col = 0; col < w; ++col) {
      const float r = relief.at<float>(row, col);
      if (!std::isfinite(r)) continue;
      if (sunk.at<std::uint8_t>(row, col) != 0) {
        cls.at<float>(row, col) = kOther;
        continue;
      }
      if (r >= o.object_height_m) {
        cls.at<float>(row, col) = kObject;
        continue;
      }
      bool beside_object = false;
      for (int dr = -1; dr <= 1; ++dr) {
        for (int dc = -1; dc <= 1; ++dc)
          beside_object = beside_object || At(relief, col + dc, row + dr) >= o.object_height_m;
      }
      const bool flat = !beside_object && returns.at<float>(row, col) >= o.min_lidar_points &&
                        spread.at<float>(row, col) <= o.flat_spread_m;
      cls.at<float>(row, col) = flat ? kFlat : kOther;
      if (flat) flat_ground.at<float>(row, col) = median.at<float>(row, col);
    }
  }
  g.bands.clear();
  g.bands.push_back(NamedBand(flat_ground, "ground_m"));
  g.bands.push_back(NamedBand(relief, "relief_m"));
  g.bands.push_back(NamedBand(top, "top_m"));
  g.bands.push_back(NamedBand(cls, "class"));
  g.bands.push_back(NamedBand(returns, "returns"));
  g.bands.push_back(NamedBand(standing, "standing_m"));
  g.bands.push_back(NamedBand(persistence, "persistence"));
  return g;
}

LidarEvalResult EvaluateMapAgainstLidar(const io::GeoRaster& map, const io::GeoRaster& truth,
                                        const std::vector<mapping::FramePose>& pairs, const calib::StereoRig& rig,
                                        const LidarEvalOptions& o, const std::vector<double>& sweep_times_s,
                                        cv::Mat* untimely_out, const std::vector<std::vector<int>>* stood_in,
                                        cv::Mat* band_out) {
  o.Validate();
  LN_CHECK_ARG(rig.rectified.has_value()) << "the rig is not rectified";
  const cv::Mat& elevation = Band(map, "elevation_m", "map");
  const cv::Mat& count = Band(map, "count", "map");
  const cv::Mat& obstacle = Band(map, "obstacle", "map");
  const cv::Mat& ground = Band(truth, "ground_m", "truth");
  const cv::Mat& relief = Band(truth, "relief_m", "truth");
  const cv::Mat& top = Band(truth, "top_m", "truth");
  const cv::Mat& cls = Band(truth, "class", "truth");
  int dc = 0, dr = 0;
  LatticeOffset(map, truth, &dc, &dr);  // truth (col, row) = map (col + dc, row + dr)
  auto mapped = [&](int tcol, int trow) {
    const int c = tcol + dc, r = trow + dr;
    return At(count, c, r) >= o.min_points && std::isfinite(At(elevation, c, r));
  };
  auto map_obstacle = [&](int tcol, int trow) { return mapped(tcol, trow) && At(obstacle, tcol + dc, trow + dr) > 0; };
  LidarEvalResult res;
  const Eigen::Isometry3d left_from_vehicle = rig.VehicleFromLeft().inverse();
  const double c = truth.cell_m;
  const cv::Mat& standing = Band(truth, "standing_m", "truth");
  const cv::Mat& persistence = Band(truth, "persistence", "truth");
  // What recall counts: something recall_height_m or more over the local ground's plane in most
  // of the sweeps that saw the cell (without the sweeps' times; with them, where it stood when a
  // pair saw it, below).
  auto stands = [&](int c0, int r0) {
    return standing.at<float>(r0, c0) >= o.recall_height_m &&
           (stood_in != nullptr || persistence.at<float>(r0, c0) >= 0.5f);
  };
  // The masses of standing cells (8-connected), band or not: a line of sight to a part of one
  // passes over its own cells, not over another's.
  cv::Mat mass;
  {
    cv::Mat stands_mask(ground.size(), CV_8UC1, cv::Scalar(0));
    for (int row = 0; row < ground.rows; ++row) {
      for (int col = 0; col < ground.cols; ++col) stands_mask.at<std::uint8_t>(row, col) = stands(col, row) ? 1 : 0;
    }
    cv::connectedComponents(stands_mask, mass, 8, CV_32S);  // 0: no mass
  }
  // The cells of each pair's band (with a metre's margin for its points' errors) in its images;
  // an object's cell at the highest part of it the search matches (band_max_z_m over the
  // vehicle's base plane; the part above, no pair's search matched).
  auto for_band_cells = [&](const mapping::FramePose& pose, double margin_m, const auto& fn) {
    const Eigen::Isometry3d world_from_vehicle = pose.WorldFromVehicle();
    const Eigen::Isometry3d vehicle_from_world = world_from_vehicle.inverse();
    // The band's cells lie within twice its far end (half fields of view up to 60 deg).
    const double reach =
        2 * (o.band_max_y_m + margin_m) + std::abs(rig.mast.lateral_offset_m) + std::abs(rig.mast.forward_offset_m);
    const int col0 = std::max(0, static_cast<int>(std::floor((pose.x_m - reach - truth.x_west_m) / c)));
    const int col1 = std::min(ground.cols - 1, static_cast<int>(std::floor((pose.x_m + reach - truth.x_west_m) / c)));
    const int row0 = std::max(0, static_cast<int>(std::floor((truth.y_north_m - pose.y_m - reach) / c)));
    const int row1 = std::min(ground.rows - 1, static_cast<int>(std::floor((truth.y_north_m - pose.y_m + reach) / c)));
    for (int row = row0; row <= row1; ++row) {
      for (int col = col0; col <= col1; ++col) {
        const int k = static_cast<int>(cls.at<float>(row, col));
        // A cell without returns is taken at the height of the vehicle's base.
        const double z = k == kFlat ? ground.at<float>(row, col) : k == kNone ? pose.z_m : top.at<float>(row, col);
        Eigen::Vector3d w(truth.CellCentreX(col), truth.CellCentreY(row), z);
        Eigen::Vector3d v = vehicle_from_world * w;
        if (k == kObject && v.z() > o.band_max_z_m) {
          // Down to the search's top (the vehicle frame's, as the search's own: where no LiDAR
          // return shows the ground, inside a hedge, the object's foot is unknown).
          v.z() = o.band_max_z_m;
          w = world_from_vehicle * v;
        }
        if (v.y() < o.band_min_y_m - margin_m || v.y() > o.band_max_y_m + margin_m) continue;
        if (!InBothImages(rig, left_from_vehicle, v)) continue;
        fn(col, row, k, w);
      }
    }
  };
  // Untimely cells: in the band (kUntimelyMarginM wider) of a pair taken farther in time from
  // every sweep than max_sweep_gap_s. What stood there then (a cyclist who rode on) no sweep shows: the truth
  // cannot judge them.
  cv::Mat untimely(ground.size(), CV_8UC1, cv::Scalar(0));
  std::vector<bool> timely(pairs.size(), true);
  std::vector<int> nearest_sweep(pairs.size(), -1);
  if (!sweep_times_s.empty()) {
    for (std::size_t p = 0; p < pairs.size(); ++p) {
      double gap = std::numeric_limits<double>::infinity();
      for (std::size_t s = 0; s < sweep_times_s.size(); ++s) {
        const double d = std::abs(sweep_times_s[s] - pairs[p].t_s);
        if (d < gap) {
          gap = d;
          nearest_sweep[p] = static_cast<int>(s);
        }
      }
      timely[p] = gap <= o.max_sweep_gap_s;
      if (timely[p]) continue;
      for_band_cells(pairs[p], kUntimelyMarginM,
                     [&](int col, int row, int, const Eigen::Vector3d&) { untimely.at<std::uint8_t>(row, col) = 1; });
    }
  }
  auto judged = [&](int tcol, int trow) {
    return tcol >= 0 && trow >= 0 && tcol < untimely.cols && trow < untimely.rows &&
           untimely.at<std::uint8_t>(trow, tcol) == 0;
  };

  // The signed lateral offset of a world point from the pairs' path (right of travel
  // positive): the nearest point of the polyline through the pairs' positions in order,
  // carried kPathExtensionM on along the first and last pairs' headings.
  std::vector<Eigen::Vector2d> path;
  if (!pairs.empty()) {
    auto ahead = [](const mapping::FramePose& q) {
      return Eigen::Vector2d(std::sin(q.heading_rad), std::cos(q.heading_rad));
    };
    path.push_back(Eigen::Vector2d(pairs.front().x_m, pairs.front().y_m) - kPathExtensionM * ahead(pairs.front()));
    for (const mapping::FramePose& q : pairs) path.emplace_back(q.x_m, q.y_m);
    path.push_back(Eigen::Vector2d(pairs.back().x_m, pairs.back().y_m) + kPathExtensionM * ahead(pairs.back()));
  }
  const internal::PathOffsets path_offsets(std::move(path));
  auto lateral_offset = [&](double x, double y) { return path_offsets.Offset(Eigen::Vector2d(x, y)); };

  // The elevation error on flat ground (and where the sweeps agree).
  const int spread_band = truth.BandIndex("sweep_spread_m");
  const cv::Mat* spread = spread_band >= 0 ? &truth.bands[static_cast<std::size_t>(spread_band)].pixels : nullptr;
  std::vector<double> agree_errors;
  std::vector<double> errors;
  std::map<int, std::vector<double>> by_lateral;  // 1 m bands: floor(offset)
  double worst = -1;
  for (int row = 0; row < ground.rows; ++row) {
    for (int col = 0; col < ground.cols; ++col) {
      const float t = ground.at<float>(row, col);
      if (!std::isfinite(t)) continue;
      ++res.flat_cells;
      if (!judged(col, row)) {
        ++res.flat_cells_untimely;
        continue;
      }
      if (!mapped(col, row)) continue;
      const double e = At(elevation, col + dc, row + dr) - t;
      errors.push_back(e);
      if (spread != nullptr && spread->at<float>(row, col) <= o.sweeps_agree_m) agree_errors.push_back(e);
      const double lateral = lateral_offset(truth.CellCentreX(col), truth.CellCentreY(row));
      if (std::isfinite(lateral)) by_lateral[static_cast<int>(std::floor(lateral))].push_back(e);
      res.cells_large_error += std::abs(e) > o.large_error_m;
      if (std::abs(e) > worst) {
        worst = std::abs(e);
        res.large_error_x_m = truth.CellCentreX(col);
        res.large_error_y_m = truth.CellCentreY(row);
      }
    }
  }
  res.cells_compared = static_cast<long>(errors.size());
  res.agree_cells = static_cast<long>(agree_errors.size());
  if (!agree_errors.empty()) {
    double sum2 = 0;
    for (double e : agree_errors) sum2 += e * e;
    res.agree_rmse_m = std::sqrt(sum2 / static_cast<double>(agree_errors.size()));
    res.agree_median_m = MedianOf(agree_errors);
  }
  for (auto& [band, es] : by_lateral) {
    LateralBin bin;
    bin.from_m = band;
    bin.to_m = band + 1;
    bin.cells = static_cast<long>(es.size());
    double sum2 = 0;
    for (double e : es) sum2 += e * e;
    bin.rmse_m = std::sqrt(sum2 / static_cast<double>(es.size()));
    bin.median_m = MedianOf(es);
    res.lateral_profile.push_back(bin);
  }
  if (errors.empty()) {
    res.rmse_m = res.median_m = res.mean_m = res.p90_abs_m = res.max_abs_m = kNaN;
  } else {
    double sum = 0, sum2 = 0;
    std::vector<double> abs_err;
    for (double e : errors) {
      sum += e;
      sum2 += e * e;
      abs_err.push_back(std::abs(e));
    }
    const double n = static_cast<double>(errors.size());
    res.mean_m = sum / n;
    res.rmse_m = std::sqrt(sum2 / n);
    res.median_m = MedianOf(errors);
    std::sort(abs_err.begin(), abs_err.end());
    res.p90_abs_m = abs_err[static_cast<std::size_t>(0.9 * (n - 1))];
    res.max_abs_m = abs_err.back();
  }

  // The band: cells a timely pair's cameras saw between band_min_y_m and band_max_y_m ahead,
  // in both images and in both cameras' lines of sight over the LiDAR's surface (a point one
  // camera cannot see no matcher measures). Over its last metre, ground's line of sight is
  // hidden only by objects (the ground there, which the grazing ray meets within the returns'
  // spread, does not hide it; a walker beside it does); an object's is judged to its own cell
  // and the cells of its own mass beside it (where the ray enters its face): its mass's deeper
  // cells and anything in front of it, however near, hide it.
  auto visible = [&](const Eigen::Vector3d& camera, const Eigen::Vector3d& target, int tcol, int trow,
                     bool object) {
    const Eigen::Vector3d d = target - camera;
    const double length = d.head<2>().norm();
    const double last_metre = length - 4 * c;
    const int own_mass = object ? mass.at<int>(trow, tcol) : 0;
    for (double s = c; s < length; s += 0.5 * c) {
      const Eigen::Vector3d p = camera + d * (s / length);
      const int col = static_cast<int>(std::floor((p.x() - truth.x_west_m) / c));
      const int row = static_cast<int>(std::floor((truth.y_north_m - p.y()) / c));
      if (!object && s > last_metre &&
          ((col == tcol && row == trow) || At(cls, col, row) != static_cast<float>(kObject))) {
        continue;
      }
      if (object && std::abs(col - tcol) <= 1 && std::abs(row - trow) <= 1 &&
          ((col == tcol && row == trow) ||
           (own_mass > 0 && col >= 0 && row >= 0 && col < mass.cols && row < mass.rows &&
            mass.at<int>(row, col) == own_mass))) {
        continue;
      }
      const float t = At(top, col, row);
      if (std::isfinite(t) && t > p.z() + 0.05) return false;
    }
    return true;
  };
  // 1 flat ground seen; 2 an object's top seen while it stood there (in the sweep nearest the
  // pair, when the sweeps' times and who stood when are given).
  cv::Mat in_band(ground.size(), CV_8UC1, cv::Scalar(0));
  for (std::size_t p = 0; p < pairs.size(); ++p) {
    if (!timely[p]) continue;
    const Eigen::Vector3d left = pairs[p].WorldFromVehicle() * rig.VehicleFromLeft().translation();
    const Eigen::Vector3d right = pairs[p].WorldFromVehicle() * rig.VehicleFromRight().translation();
    for_band_cells(pairs[p], 0.0, [&](int col, int row, int k, const Eigen::Vector3d& w) {
      if ((k != kFlat && k != kObject) || in_band.at<std::uint8_t>(row, col) != 0 || !judged(col, row)) return;
      if (k == kObject && stood_in != nullptr && nearest_sweep[p] >= 0) {
        const auto& who = (*stood_in)[static_cast<std::size_t>(row) * static_cast<std::size_t>(ground.cols) +
                                      static_cast<std::size_t>(col)];
        if (std::find(who.begin(), who.end(), nearest_sweep[p]) == who.end()) return;  // not there then
      }
      if (!visible(left, w, col, row, k == kObject) || !visible(right, w, col, row, k == kObject)) return;
      in_band.at<std::uint8_t>(row, col) = static_cast<std::uint8_t>(k == kFlat ? 1 : 2);
    });
  }
  for (int row = 0; row < ground.rows; ++row) {
    for (int col = 0; col < ground.cols; ++col) {
      if (in_band.at<std::uint8_t>(row, col) != 1) continue;
      ++res.band_cells;
      res.band_mapped += mapped(col, row);
    }
  }
  res.coverage = Ratio(res.band_mapped, res.band_cells);

  // Obstacle precision: a map obstacle is judged where the LiDAR has returns within the
  // tolerance, and real when one of those cells has the relief.
  const int tol = o.tolerance_cells;
  for (int row = 0; row < elevation.rows; ++row) {
    for (int col = 0; col < elevation.cols; ++col) {
      if (!(At(count, col, row) >= o.min_points && At(obstacle, col, row) > 0)) continue;
      if (!judged(col - dc, row - dr)) continue;
      ++res.obstacle_map;
      bool judged = false, real = false;
      for (int r = -tol; r <= tol; ++r) {
        for (int q = -tol; q <= tol; ++q) {
          const float rel = At(relief, col - dc + q, row - dr + r);
          judged = judged || std::isfinite(rel);
          real = real || rel >= o.relief_height_m;
        }
      }
      res.obstacle_judged += judged;
      res.obstacle_tp += real;
    }
  }
  res.precision = Ratio(res.obstacle_tp, res.obstacle_judged);

  // Recall: the LiDAR's objects (8-connected cells where something at least recall_height_m
  // stands over the local ground's plane in most of the sweeps that saw the cell: no slope, no
  // passing car) whose part a pair saw in the band, found when a map obstacle lies within the
  // tolerance of one of their cells.
  cv::Mat label(ground.size(), CV_32SC1, cv::Scalar(-1));
  for (int row = 0; row < ground.rows; ++row) {
    for (int col = 0; col < ground.cols; ++col) {
      if (in_band.at<std::uint8_t>(row, col) != 2 || !stands(col, row)) continue;
      if (label.at<int>(row, col) >= 0) continue;
      const int id = static_cast<int>(res.objects++);
      bool found = false;
      LidarObject object;
      std::vector<std::pair<int, int>> stack = {{col, row}};
      label.at<int>(row, col) = id;
      while (!stack.empty()) {
        const auto [x, y] = stack.back();
        stack.pop_back();
        ++object.cells;
        object.x_m += truth.CellCentreX(x);
        object.y_m += truth.CellCentreY(y);
        object.height_m = std::max(object.height_m, static_cast<double>(standing.at<float>(y, x)));
        for (int r = -tol; r <= tol && !found; ++r) {
          for (int q = -tol; q <= tol && !found; ++q) found = map_obstacle(x + q, y + r);
        }
        for (int r = -1; r <= 1; ++r) {
          for (int q = -1; q <= 1; ++q) {
            const int nx = x + q, ny = y + r;
            if (nx < 0 || ny < 0 || nx >= ground.cols || ny >= ground.rows) continue;
            if (label.at<int>(ny, nx) >= 0 || in_band.at<std::uint8_t>(ny, nx) != 2 || !stands(nx, ny)) {
              continue;
            }
            label.at<int>(ny, nx) = id;
            stack.emplace_back(nx, ny);
          }
        }
      }
      res.objects_found += found;
      object.x_m /= static_cast<double>(object.cells);
      object.y_m /= static_cast<double>(object.cells);
      object.found = found;
      res.object_list.push_back(object);
    }
  }
  res.object_recall = Ratio(res.objects_found, res.objects);
  if (untimely_out != nullptr) *untimely_out = untimely;
  if (band_out != nullptr) *band_out = in_band;
  return res;
}

void MeasureSweepConsistency(const std::vector<LidarSweep>& sweeps, const io::GeoRaster& truth,
                             const LidarEvalOptions& o, LidarEvalResult* result, cv::Mat* spread) {
  io::GeoRaster grid;
  grid.cell_m = truth.cell_m;
  grid.x_west_m = truth.x_west_m;
  grid.y_north_m = truth.y_north_m;
  grid.bands.push_back(NamedBand(cv::Mat(truth.Height(), truth.Width(), CV_32FC1, cv::Scalar(0)), "returns"));
  const Binned b = BinReturns(sweeps, grid);
  const cv::Mat& ground = Band(truth, "ground_m", "truth");
  std::vector<double> diffs;
  const int w = truth.Width();
  if (spread != nullptr) *spread = cv::Mat(ground.size(), CV_32FC1, cv::Scalar(kNaNf));
  for (int row = 0; row < ground.rows; ++row) {
    for (int col = 0; col < ground.cols; ++col) {
      if (!std::isfinite(ground.at<float>(row, col))) continue;
      const std::size_t k = static_cast<std::size_t>(row) * static_cast<std::size_t>(w) + static_cast<std::size_t>(col);
      std::map<int, std::vector<float>> by_sweep;
      for (std::int64_t i = b.start[k]; i < b.start[k + 1]; ++i) {
        by_sweep[b.sweep[static_cast<std::size_t>(i)]].push_back(b.z[static_cast<std::size_t>(i)]);
      }
      std::vector<double> medians;
      for (auto& [s, z] : by_sweep) {
        if (static_cast<int>(z.size()) >= o.min_lidar_points) medians.push_back(Median(&z));
      }
      for (std::size_t i = 0; i < medians.size(); ++i) {
        for (std::size_t j = i + 1; j < medians.size(); ++j) diffs.push_back(medians[i] - medians[j]);
      }
      if (spread != nullptr && medians.size() >= 2) {
        const auto [lo, hi] = std::minmax_element(medians.begin(), medians.end());
        spread->at<float>(row, col) = static_cast<float>(*hi - *lo);
      }
    }
  }
  result->sweep_pairs = static_cast<long>(diffs.size());
  if (diffs.empty()) {
    result->sweep_rms_m = result->sweep_median_abs_m = kNaN;
    return;
  }
  double sum2 = 0;
  std::vector<double> abs_d;
  for (double d : diffs) {
    sum2 += d * d;
    abs_d.push_back(std::abs(d));
  }
  result->sweep_rms_m = std::sqrt(sum2 / static_cast<double>(diffs.size()));
  result->sweep_median_abs_m = MedianOf(abs_d);
}

double PairOffset(const std::vector<Eigen::Vector3f>& stereo_world, const LidarSweep& sweep,
                  const io::GeoRaster& truth, const LidarEvalOptions& o) {
  const cv::Mat& ground = Band(truth, "ground_m", "truth");
  io::GeoRaster grid;
  grid.cell_m = truth.cell_m;
  grid.x_west_m = truth.x_west_m;
  grid.y_north_m = truth.y_north_m;
  grid.bands.push_back(NamedBand(cv::Mat(truth.Height(), truth.Width(), CV_32FC1, cv::Scalar(0)), "returns"));
  LidarSweep stereo;
  stereo.points = stereo_world;
  const Binned mine = BinReturns({stereo}, grid);
  const Binned theirs = BinReturns({sweep}, grid);
  std::vector<double> d;
  for (int row = 0; row < ground.rows; ++row) {
    for (int col = 0; col < ground.cols; ++col) {
      if (!std::isfinite(ground.at<float>(row, col))) continue;
      const std::size_t i =
          static_cast<std::size_t>(row) * static_cast<std::size_t>(ground.cols) + static_cast<std::size_t>(col);
      if (mine.start[i + 1] - mine.start[i] < 3 || theirs.start[i + 1] - theirs.start[i] < o.min_lidar_points) {
        continue;
      }
      std::vector<float> a(mine.z.begin() + mine.start[i], mine.z.begin() + mine.start[i + 1]);
      std::vector<float> b(theirs.z.begin() + theirs.start[i], theirs.z.begin() + theirs.start[i + 1]);
      d.push_back(Median(&a) - Median(&b));
    }
  }
  return d.size() >= kPairOffsetMinCells ? MedianOf(d) : kNaN;
}

double PairDisparityOffset(const cv::Mat& disparity, calib::ReferenceImage reference, const LidarSweep& sweep,
                           const io::GeoRaster& truth, const Eigen::Isometry3d& world_from_vehicle,
                           const calib::StereoRig& rig, const LidarEvalOptions& o) {
  LN_CHECK(disparity.type() == CV_32FC1) << "disparity: CV_32FC1 expected";
  const cv::Mat& ground = Band(truth, "ground_m", "truth");
  const Eigen::Isometry3d vehicle_from_world = world_from_vehicle.inverse();
  std::vector<double> d;
  for (const Eigen::Vector3f& p : sweep.points) {
    const int col = static_cast<int>(std::floor((p.x() - truth.x_west_m) / truth.cell_m));
    const int row = static_cast<int>(std::floor((truth.y_north_m - p.y()) / truth.cell_m));
    if (!std::isfinite(At(ground, col, row))) continue;  // flat ground only: no edge, no occlusion
    const Eigen::Vector3d v = vehicle_from_world * p.cast<double>();
    if (v.y() < o.band_min_y_m || v.y() > o.band_max_y_m) continue;
    const calib::RectifiedProjection q = calib::ProjectToRectified(rig, v, reference);
    if (!(q.depth_m > 0)) continue;
    const long x = std::lround(q.x_px), y = std::lround(q.y_px);
    if (x < 0 || y < 0 || x >= disparity.cols || y >= disparity.rows) continue;
    const float s = disparity.at<float>(static_cast<int>(y), static_cast<int>(x));
    if (!std::isfinite(s) || std::abs(s - q.disparity_px) > kPairDisparityWithinPx) continue;
    d.push_back(s - q.disparity_px);
  }
  return d.size() >= kPairDisparityMinReturns ? MedianOf(d) : kNaN;
}

void SummarizePairOffsets(const std::vector<double>& offsets_m, const std::vector<double>& gaps_s,
                          const LidarEvalOptions& o, LidarEvalResult* result) {
  LN_CHECK(offsets_m.size() == gaps_s.size()) << "pair offsets: one gap per offset";
  std::vector<double> abs_offsets, signed_offsets;
  for (std::size_t k = 0; k < offsets_m.size(); ++k) {
    if (!std::isfinite(offsets_m[k])) continue;
    abs_offsets.push_back(std::abs(offsets_m[k]));
    if (gaps_s[k] <= o.max_sweep_gap_s) signed_offsets.push_back(offsets_m[k]);
  }
  result->pairs_measured = static_cast<long>(abs_offsets.size());
  result->pair_offset_median_abs_m = result->pair_offset_max_abs_m = result->pair_offset_median_m = kNaN;
  if (abs_offsets.empty()) return;
  result->pair_offset_median_abs_m = MedianOf(abs_offsets);
  result->pair_offset_max_abs_m = *std::max_element(abs_offsets.begin(), abs_offsets.end());
  if (!signed_offsets.empty()) result->pair_offset_median_m = MedianOf(signed_offsets);
}

json LidarEvalResult::ToJson() const {
  return {{"sweeps", sweeps},
          {"returns", returns},
          {"flat_cells", flat_cells},
          {"flat_cells_untimely", flat_cells_untimely},
          {"cells_compared", cells_compared},
          {"elevation_rmse_m", Number(rmse_m)},
          {"elevation_median_m", Number(median_m)},
          {"elevation_mean_m", Number(mean_m)},
          {"elevation_p90_abs_m", Number(p90_abs_m)},
          {"elevation_max_abs_m", Number(max_abs_m)},
          {"largest_error_at_m", {Number(large_error_x_m), Number(large_error_y_m)}},
          {"cells_large_error", cells_large_error},
          {"sweeps_agree_cells", agree_cells},
          {"sweeps_agree_rmse_m", Number(agree_rmse_m)},
          {"sweeps_agree_median_m", Number(agree_median_m)},
          {"band_flat_cells", band_cells},
          {"band_flat_cells_mapped", band_mapped},
          {"coverage", Number(coverage)},
          {"obstacle_cells_map", obstacle_map},
          {"obstacle_cells_judged", obstacle_judged},
          {"obstacle_true_positive", obstacle_tp},
          {"obstacle_precision", Number(precision)},
          {"lidar_objects_in_band", objects},
          {"lidar_objects_found", objects_found},
          {"object_recall", Number(object_recall)},
          {"truth_sweep_pairs", sweep_pairs},
          {"truth_sweep_rms_m", Number(sweep_rms_m)},
          {"truth_sweep_median_abs_m", Number(sweep_median_abs_m)},
          {"pairs_against_nearest_sweep", pairs_measured},
          {"pair_offset_median_abs_m", Number(pair_offset_median_abs_m)},
          {"pair_offset_median_m", Number(pair_offset_median_m)},
          {"pair_offset_max_abs_m", Number(pair_offset_max_abs_m)},
          {"pairs_disparity_measured", pairs_disparity_measured},
          {"pair_disparity_offset_px", Number(pair_disparity_offset_px)}};
}

Table LidarEvalResult::ToTable() const {
  Table t;
  t.title = "Terrain map against LiDAR (flat ground; objects)";
  t.columns = {{"cells", "", "flat cells compared", 0},
               {"rmse", "cm", "RMSE (cm)", 2},
               {"median", "cm", "median offset (cm)", 2},
               {"largest", "cm", "largest error (cm)", 1},
               {"large", "", "cells > 30 cm", 0},
               {"agree_cells", "", "flat cells whose sweeps agree", 0},
               {"agree_rmse", "cm", "there: RMSE (cm)", 2},
               {"agree_median", "cm", "there: median offset (cm)", 2},
               {"coverage", "pct", "coverage of the band's flat ground (%)", 1},
               {"precision", "pct", "obstacle precision (%)", 1},
               {"recall", "pct", "LiDAR objects found (%)", 1},
               {"sweeps", "cm", "truth: sweep vs sweep median |d| (cm)", 2},
               {"pairs", "cm", "truth: pair vs nearest sweep median |d| (cm)", 2},
               {"pairs_signed", "cm", "truth: pair vs its sweep at one instant, median (cm)", 2},
               {"pairs_disparity", "px", "truth: pair vs its sweep at one instant, disparity (px)", 2}};
  auto pct = [](double v, const std::string& why) { return Cell::NumberOr(100 * v, why); };
  t.AddRow({Cell::Number(static_cast<double>(cells_compared)), Cell::NumberOr(100 * rmse_m, "no cell"),
            Cell::NumberOr(100 * median_m, "no cell"), Cell::NumberOr(100 * max_abs_m, "no cell"),
            Cell::Number(static_cast<double>(cells_large_error)), Cell::Number(static_cast<double>(agree_cells)),
            Cell::NumberOr(100 * agree_rmse_m, "no cell"), Cell::NumberOr(100 * agree_median_m, "no cell"),
            pct(coverage, "no flat ground in the band"),
            pct(precision, "no obstacle judged"), pct(object_recall, "no object in the band"),
            Cell::NumberOr(100 * sweep_median_abs_m, "no cell two sweeps saw"),
            Cell::NumberOr(100 * pair_offset_median_abs_m, "no stereo points given"),
            Cell::NumberOr(100 * pair_offset_median_m, "no pair at a sweep's time"),
            Cell::NumberOr(pair_disparity_offset_px, "no disparity map of a pair at a sweep's time")});
  return t;
}

std::string LidarEvalResult::BriefReport() const {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(1);
  s << "flat ground: RMSE " << 100 * rmse_m << " cm, median " << 100 * median_m << " cm, largest " << 100 * max_abs_m
    << " cm, " << cells_large_error << " of " << cells_compared << " cells > 30 cm; coverage " << 100 * coverage
    << " %; obstacles precision " << 100 * precision << " %, LiDAR objects " << objects_found << "/" << objects;
  return s.str();
}

namespace {

// The picture: the error on flat ground over the map, the LiDAR's objects, the map's obstacles
// and the pairs' path, 4 pixels a cell (fewer for a truth over 1024 cells a side, so that the
// picture stays within 4096 pixels a side where it can), north up.
cv::Mat ErrorPicture(const io::GeoRaster& map, const io::GeoRaster& truth, const std::vector<mapping::FramePose>& pairs,
                     const LidarEvalOptions& o, const cv::Mat& untimely) {
  const cv::Mat& ground = Band(truth, "ground_m", "truth");
  const int kScale = std::clamp(4096 / std::max({ground.rows, ground.cols, 1}), 1, 4);
  const cv::Mat& cls = Band(truth, "class", "truth");
  const cv::Mat& elevation = Band(map, "elevation_m", "map");
  const cv::Mat& count = Band(map, "count", "map");
  const cv::Mat& obstacle = Band(map, "obstacle", "map");
  int dc = 0, dr = 0;
  LatticeOffset(map, truth, &dc, &dr);
  cv::Mat image(ground.rows * kScale, ground.cols * kScale, CV_8UC3, cv::Scalar(25, 25, 25));
  for (int row = 0; row < ground.rows; ++row) {
    for (int col = 0; col < ground.cols; ++col) {
      const int k = static_cast<int>(cls.at<float>(row, col));
      cv::Scalar colour(25, 25, 25);
      if (k == kObject) colour = cv::Scalar(120, 60, 30);
      if (k == kOther) colour = cv::Scalar(70, 70, 70);
      const bool is_mapped = At(count, col + dc, row + dr) >= o.min_points;
      if (k == kFlat) {
        colour = cv::Scalar(140, 140, 140);
        if (is_mapped) {
          const double e =
              std::clamp((At(elevation, col + dc, row + dr) - ground.at<float>(row, col)) / o.large_error_m, -1.0, 1.0);
          const double a = std::abs(e);
          // white at 0, red above, blue below (BGR)
          colour =
              e > 0 ? cv::Scalar(255 * (1 - a), 255 * (1 - a), 255) : cv::Scalar(255, 255 * (1 - a), 255 * (1 - a));
        }
      } else if (is_mapped && k != kObject) {
        colour = cv::Scalar(90, 110, 90);  // mapped where the LiDAR has no flat ground
      }
      if (untimely.at<std::uint8_t>(row, col) != 0) colour *= 0.35;  // not judged: seen far in time from every sweep
      const cv::Rect box(col * kScale, row * kScale, kScale, kScale);
      cv::rectangle(image, box, colour, cv::FILLED);
      if (k == kFlat && is_mapped &&
          std::abs(At(elevation, col + dc, row + dr) - ground.at<float>(row, col)) > o.large_error_m) {
        cv::rectangle(image, box, cv::Scalar(0, 230, 255), 1);
      }
      if (is_mapped && At(obstacle, col + dc, row + dr) > 0) {
        cv::rectangle(image, cv::Rect(col * kScale + kScale / 4, row * kScale + kScale / 4, std::max(1, kScale / 2),
                                      std::max(1, kScale / 2)),
                      cv::Scalar(255, 0, 255), cv::FILLED);
      }
    }
  }
  for (std::size_t i = 1; i < pairs.size(); ++i) {
    auto px = [&](const mapping::FramePose& p) {
      return cv::Point(static_cast<int>((p.x_m - truth.x_west_m) / truth.cell_m * kScale),
                       static_cast<int>((truth.y_north_m - p.y_m) / truth.cell_m * kScale));
    };
    cv::line(image, px(pairs[i - 1]), px(pairs[i]), cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  }
  const char* const legend[] = {
      "map - LiDAR on flat ground: blue -30 cm, white 0, red +30 cm; yellow box: > 30 cm off",
      "grey: flat ground the map left empty; dark blue: LiDAR objects; magenta: map obstacles; white: path",
      "dimmed: not judged (seen by a pair far in time from every sweep)"};
  int y = 14;
  for (const char* line : legend) {
    cv::putText(image, line, cv::Point(6, y), cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0), 3, cv::LINE_AA);
    cv::putText(image, line, cv::Point(6, y), cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
    y += 16;
  }
  return image;
}

}  // namespace

LidarEvalResult RunLidarMapEvaluation(const LidarMapCommand& cmd, const json& invocation) {
  util::Timer timer;
  LidarEvalOptions o = cmd.options;
  const calib::StereoRig rig = calib::ReadStereoRig(cmd.rig);
  LN_CHECK_ARG(rig.rectified.has_value()) << cmd.rig.string() << ": the rig is not rectified";
  // The rig's default search over the heights stereo-batch searched (its --z-range).
  calib::GroundWindowOptions search;
  if (std::isfinite(cmd.z_max_m)) {
    search.z_min_m = cmd.z_min_m;
    search.z_max_m = cmd.z_max_m;
  }
  search.Validate();
  o.band_max_z_m = search.z_max_m;
  if (std::isfinite(cmd.band_min_y_m)) {
    o.band_min_y_m = cmd.band_min_y_m;
    o.band_max_y_m = cmd.band_max_y_m;
  } else {
    const calib::GroundWindow window = calib::SelectGroundWindow(rig, calib::ReferenceImage::kRight, search);
    o.band_min_y_m = window.region.y_min_m;
    o.band_max_y_m = window.region.y_max_m;
  }
  o.Validate();
  const io::GeoRaster map = io::ReadGeoTiff(cmd.map_dir / "elevation.tif");

  // The pairs taken: the pair directory's (every pair, mapped or not), else the map's own list.
  std::vector<std::string> pair_stems;
  std::string pairs_source;
  if (!cmd.pairs_dir.empty()) {
    for (const io::PairFiles& p : io::ListStereoPairs(cmd.pairs_dir)) pair_stems.push_back(p.stem);
    pairs_source = cmd.pairs_dir.string();
  } else {
    for (const mapping::FramePose& p : mapping::ReadPosesCsv(cmd.map_dir / "frames.csv")) pair_stems.push_back(p.stem);
    pairs_source = (cmd.map_dir / "frames.csv").string() + " (the map's own pairs)";
  }
  const std::optional<Eigen::Isometry3d> vehicle_from_camera = rig.VehicleFromLeft();
  const std::vector<mapping::FramePose> pairs =
      mapping::PosesOfPairs(cmd.poses_csv, cmd.trajectory, cmd.frame_times, pair_stems, vehicle_from_camera);

  // The sweeps, each in the world by its stem's pose and the LiDAR's mounting.
  std::vector<fs::path> files;
  {
    std::error_code ec;
    io::CheckInputDirectory(cmd.lidar_dir);
    for (const auto& e : fs::directory_iterator(cmd.lidar_dir, ec)) {
      if (io::HasPointCloudExtension(e.path()) && e.path().filename().string()[0] != '.') files.push_back(e.path());
    }
    std::sort(files.begin(), files.end());
    LN_CHECK_INPUT(!files.empty()) << cmd.lidar_dir.string() << ": no point clouds (.bin, .ply, .pcd)";
  }
  std::vector<std::string> sweep_stems;
  for (const fs::path& f : files) sweep_stems.push_back(f.stem().string());
  std::map<std::string, mapping::FramePose> sweep_poses;
  if (!cmd.lidar_in_world) {
    sweep_poses = mapping::IndexByStem(
        mapping::PosesOfPairs(cmd.poses_csv, cmd.trajectory, cmd.frame_times, sweep_stems, vehicle_from_camera));
  }
  Eigen::Isometry3d vehicle_from_lidar = Eigen::Isometry3d::Identity();
  if (!cmd.lidar_calib.empty()) {
    vehicle_from_lidar = mapping::KittiLidarInVehicle(cmd.lidar_calib, rig.VehicleFromLeft());
  }
  std::vector<LidarSweep> sweeps(files.size());
  util::ParallelForEachItem(files.size(), cmd.num_threads, [&](std::size_t k) {
    LidarSweep& s = sweeps[k];
    s.stem = sweep_stems[k];
    Eigen::Isometry3d world_from_lidar = Eigen::Isometry3d::Identity();
    if (!cmd.lidar_in_world) {
      const mapping::FramePose& pose = sweep_poses.at(s.stem);
      s.t_s = pose.t_s;
      world_from_lidar = pose.WorldFromVehicle() * vehicle_from_lidar;
    }
    s.sensor_m = world_from_lidar.translation();
    const Eigen::Isometry3f transform = world_from_lidar.cast<float>();
    for (const Eigen::Vector3f& p : io::ReadPointCloud(files[k])) {
      const Eigen::Vector3f w = transform * p;
      const double range =
          cmd.lidar_in_world ? o.min_range_m : (w.head<2>().cast<double>() - s.sensor_m.head<2>()).norm();
      if (!cmd.lidar_in_world && (range < o.min_range_m || range > o.max_range_m)) continue;
      s.points.push_back(w);
    }
  });
  std::vector<std::vector<int>> stood_in;
  io::GeoRaster truth = GridLidarTruth(sweeps, map, o, cmd.lidar_in_world ? nullptr : &stood_in);
  // The truth's own consistency, sweep against sweep, and where it holds (scored apart).
  LidarEvalResult consistency;
  cv::Mat spread;
  MeasureSweepConsistency(sweeps, truth, o, &consistency, &spread);
  truth.bands.push_back(NamedBand(spread, "sweep_spread_m"));
  std::vector<double> sweep_times;
  if (!cmd.lidar_in_world) {
    for (const LidarSweep& s : sweeps) sweep_times.push_back(s.t_s);
  }
  cv::Mat untimely, band;
  LidarEvalResult result = EvaluateMapAgainstLidar(map, truth, pairs, rig, o, sweep_times, &untimely,
                                                   cmd.lidar_in_world ? nullptr : &stood_in, &band);
  result.sweeps = static_cast<long>(sweeps.size());
  for (const LidarSweep& s : sweeps) result.returns += static_cast<long>(s.points.size());
  result.sweep_pairs = consistency.sweep_pairs;
  result.sweep_rms_m = consistency.sweep_rms_m;
  result.sweep_median_abs_m = consistency.sweep_median_abs_m;

  // Each pair against the sweep nearest in time, on flat ground (the pose's share of the error).
  json pair_rows = json::array();
  if (!cmd.stereo_dir.empty() && !cmd.lidar_in_world) {
    std::vector<double> offsets(pairs.size(), kNaN), disparity_offsets(pairs.size(), kNaN);
    std::vector<std::string> nearest(pairs.size());
    std::vector<double> gap_s(pairs.size(), kNaN);
    // The image the disparity maps are referenced to, as stereo-batch's summary records it
    // (without it the pairs' disparities are not compared).
    std::string problem;
    const std::optional<calib::ReferenceImage> reference = stereo::ReadRunReference(cmd.stereo_dir, &problem);
    if (!reference) {
      result.warnings.push_back(problem +
                                ": the pairs' disparity is not compared with the LiDAR's (one instant, px: n/a)");
      LN_LOG(Warning) << result.warnings.back();
    }
    util::ParallelForEachItem(pairs.size(), cmd.num_threads, [&](std::size_t k) {
      const mapping::FramePose& pose = pairs[k];
      const fs::path xyz_path = cmd.stereo_dir / "xyz" / (pose.stem + ".exr");
      std::error_code ec;
      if (!fs::is_regular_file(xyz_path, ec)) return;
      const LidarSweep* sweep = nullptr;
      for (const LidarSweep& s : sweeps) {
        if (sweep == nullptr || std::abs(s.t_s - pose.t_s) < std::abs(sweep->t_s - pose.t_s)) sweep = &s;
      }
      nearest[k] = sweep->stem;
      gap_s[k] = std::abs(sweep->t_s - pose.t_s);
      const io::ExrImage xyz = io::ReadExr(xyz_path);
      LN_CHECK_INPUT(xyz.pixels.type() == CV_32FC3) << xyz_path.string() << ": not 3 channels";
      LidarSweep stereo;
      const Eigen::Isometry3f world_from_vehicle = pose.WorldFromVehicle().cast<float>();
      for (int y = 0; y < xyz.pixels.rows; ++y) {
        const auto* v = xyz.pixels.ptr<cv::Vec3f>(y);
        for (int x = 0; x < xyz.pixels.cols; ++x) {
          if (!std::isfinite(v[x][0]) || !std::isfinite(v[x][1]) || !std::isfinite(v[x][2])) continue;
          if (v[x][1] < o.band_min_y_m || v[x][1] > o.band_max_y_m) continue;
          stereo.points.push_back(world_from_vehicle * Eigen::Vector3f(v[x][0], v[x][1], v[x][2]));
        }
      }
      offsets[k] = PairOffset(stereo.points, *sweep, truth, o);
      const fs::path disparity_path = cmd.stereo_dir / "disparity" / (pose.stem + ".pfm");
      if (reference && gap_s[k] <= o.max_sweep_gap_s && fs::is_regular_file(disparity_path, ec)) {
        const cv::Mat disparity = io::ReadPfm(disparity_path);
        LN_CHECK_INPUT(disparity.cols == rig.rectified->width_px && disparity.rows == rig.rectified->height_px)
            << disparity_path.string() << " is " << disparity.cols << "x" << disparity.rows
            << ", the rig's rectified images " << rig.rectified->width_px << "x" << rig.rectified->height_px
            << " (another rig's stereo run?)";
        disparity_offsets[k] =
            PairDisparityOffset(disparity, *reference, *sweep, truth, pose.WorldFromVehicle(), rig, o);
      }
    });
    SummarizePairOffsets(offsets, gap_s, o, &result);
    std::vector<double> measured;
    for (double d : disparity_offsets) {
      if (std::isfinite(d)) measured.push_back(d);
    }
    result.pairs_disparity_measured = static_cast<long>(measured.size());
    if (!measured.empty()) result.pair_disparity_offset_px = MedianOf(measured);
    for (std::size_t k = 0; k < pairs.size(); ++k) {
      if (!std::isfinite(offsets[k])) continue;
      json row = {{"stem", pairs[k].stem}, {"sweep", nearest[k]}, {"offset_m", offsets[k]}};
      if (std::isfinite(disparity_offsets[k])) row["disparity_offset_px"] = disparity_offsets[k];
      pair_rows.push_back(row);
    }
  }

  io::CreateOutputDirectory(cmd.output_dir);
  const Table table = result.ToTable();
  WriteTable(cmd.output_dir, "lidar", table);
  {
    // Every flat cell: the truth, the map, the error.
    const cv::Mat& ground = Band(truth, "ground_m", "truth");
    const cv::Mat& elevation = Band(map, "elevation_m", "map");
    const cv::Mat& count = Band(map, "count", "map");
    const cv::Mat& obstacle = Band(map, "obstacle", "map");
    int dc = 0, dr = 0;
    LatticeOffset(map, truth, &dc, &dr);
    std::ostringstream csv;
    csv.imbue(std::locale::classic());
    csv << "# lunarnav evaluate map --lidar: every LiDAR flat-ground cell; map_m NaN where the map holds fewer than "
        << o.min_points << " points; judged 0 where a pair far in time from every sweep saw it\n";
    csv << "x_m,y_m,lidar_m,map_m,error_m,map_points,map_obstacle,judged,sweep_spread_m\n" << std::fixed
        << std::setprecision(4);
    for (int row = 0; row < ground.rows; ++row) {
      for (int col = 0; col < ground.cols; ++col) {
        const float t = ground.at<float>(row, col);
        if (!std::isfinite(t)) continue;
        const float n = At(count, col + dc, row + dr);
        const double m = n >= o.min_points ? At(elevation, col + dc, row + dr) : kNaN;
        csv << truth.CellCentreX(col) << "," << truth.CellCentreY(row) << "," << t << "," << m << "," << m - t << ","
            << (std::isfinite(n) ? static_cast<long>(n) : 0L) << ","
            << (n >= o.min_points && At(obstacle, col + dc, row + dr) > 0) << ","
            << (untimely.at<std::uint8_t>(row, col) == 0) << "," << spread.at<float>(row, col) << "\n";
      }
    }
    io::WriteFileAtomic(cmd.output_dir / "cells.csv", csv.str());
  }
  {
    // Every LiDAR object of the band, found or not.
    std::ostringstream csv;
    csv.imbue(std::locale::classic());
    csv << "# lunarnav evaluate map --lidar: the LiDAR objects of the band (what stands " << o.recall_height_m
        << " m or more over the ground's plane where a pair saw its part up to " << o.band_max_z_m
        << " m); found: a map obstacle within "
        << o.tolerance_cells << " cell(s) of one of its cells\n";
    csv << "x_m,y_m,cells,height_m,found\n" << std::fixed << std::setprecision(3);
    for (const LidarObject& b : result.object_list) {
      csv << b.x_m << "," << b.y_m << "," << b.cells << "," << b.height_m << "," << b.found << "\n";
    }
    io::WriteFileAtomic(cmd.output_dir / "objects.csv", csv.str());
  }
  {
    // The flat ground's error by lateral offset from the path.
    std::ostringstream csv;
    csv.imbue(std::locale::classic());
    csv << "# lunarnav evaluate map --lidar: the flat ground's error (map minus LiDAR) by signed lateral offset "
           "from the pairs' path (right of travel positive), 1 m bands\n";
    csv << "from_m,to_m,cells,median_m,rmse_m\n" << std::fixed << std::setprecision(4);
    for (const LateralBin& b : result.lateral_profile) {
      csv << b.from_m << "," << b.to_m << "," << b.cells << "," << b.median_m << "," << b.rmse_m << "\n";
    }
    io::WriteFileAtomic(cmd.output_dir / "profile.csv", csv.str());
  }
  io::WriteImageAtomic(cmd.output_dir / "error.png", ErrorPicture(map, truth, pairs, o, untimely));
  {
    // The truth as gridded, for a GIS beside the map's elevation.tif.
    io::GeoRaster layers = truth;
    cv::Mat judged;
    untimely.convertTo(judged, CV_32FC1, -1.0, 1.0);
    layers.bands.push_back(NamedBand(judged, "judged"));
    cv::Mat band_f;
    band.convertTo(band_f, CV_32FC1);
    layers.bands.push_back(NamedBand(band_f, "band"));
    const std::map<std::string, std::string> meaning = {
        {"ground_m", "the median LiDAR return of a flat-ground cell, m (NaN: not flat ground)"},
        {"relief_m", "the highest return under the clearance above the local ground, m"},
        {"top_m", "that highest return's height, m"},
        {"class", "0 no returns, 1 flat ground, 2 object, 3 other (rough, beside an object, sunk)"},
        {"returns", "LiDAR returns in the cell (all sweeps, under the clearance)"},
        {"standing_m", "the highest return over the plane through the 5 x 5 cells' low returns, m"},
        {"persistence", "the share of the sweeps that saw the cell in which something 20 cm tall stood there"},
        {"sweep_spread_m", "the largest difference of two sweeps' medians in a flat-ground cell, m (NaN: fewer "
                           "than two sweeps saw it)"},
        {"judged", "1 judged, 0 seen by a pair far in time from every sweep"},
        {"band",
         "1 flat ground the coverage counts (a timely pair saw it in the band), 2 an object's part the recall counts, "
         "0 neither"}};
    for (io::RasterBand& b : layers.bands) b.metadata["meaning"] = meaning.at(b.description);
    layers.metadata["lunarnav_content"] = "evaluate map --lidar: the LiDAR truth on the map's lattice";
    io::WriteGeoTiffAtomic(cmd.output_dir / "truth.tif", layers);
  }
  json j = util::SummaryHead("evaluate", invocation);
  j["subcommand"] = "map";
  j["mode"] = "lidar";
  j["inputs"] = {{"map", cmd.map_dir.string()},
                 {"lidar", cmd.lidar_dir.string()},
                 {"lidar_calib", cmd.lidar_calib.string()},
                 {"rig", cmd.rig.string()},
                 {"poses", cmd.poses_csv.string()},
                 {"trajectory", cmd.trajectory.string()},
                 {"frame_times", cmd.frame_times.string()},
                 {"pairs", pairs_source},
                 {"pair_count", pairs.size()},
                 {"stereo", cmd.stereo_dir.string()}};
  j["options"] = o.ToJson();
  j["result"] = result.ToJson();
  j["warnings"] = result.warnings;
  j["pairs_against_nearest_sweep"] = pair_rows;
  j["table"] = table.ToJson();
  j["outputs"] = {"lidar.csv",   "lidar.json",  "lidar.md",  "cells.csv",
                  "objects.csv", "profile.csv", "error.png", "truth.tif"};
  j["timings_s"] = {{"total", timer.ElapsedSeconds()}};
  io::WriteJsonAtomic(cmd.output_dir / "summary.json", j);
  return result;
}

}  // namespace lunarnav::evaluation
