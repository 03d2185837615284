#include "mapping/ground_alignment.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>
#include <opencv2/core.hpp>

#include "mapping/robust_plane.h"
#include "util/check.h"

namespace lunarnav::mapping {
namespace {

constexpr double kDeg = M_PI / 180.0;

// A pair's own samples in one cell.
struct CellSamples {
  double sum_x = 0, sum_y = 0, sum_z = 0;
  int n = 0;
};

}  // namespace

void GroundAlignmentOptions::Validate() const {
  LN_CHECK_ARG(stride_px >= 1 && stride_px <= 64) << "alignment stride: must be in 1..64 px";
  LN_CHECK_ARG(std::isfinite(min_range_m) && std::isfinite(max_range_m) && min_range_m >= 0 && min_range_m < max_range_m)
      << "alignment range: need 0 <= MIN < MAX, finite";
  LN_CHECK_ARG(min_samples_per_cell >= 1) << "alignment samples per cell: must be >= 1";
  LN_CHECK_ARG(min_cells >= 3) << "alignment cells: must be >= 3";
  LN_CHECK_ARG(std::isfinite(robust_m) && robust_m > 0) << "alignment robust scale: must be > 0 m";
  LN_CHECK_ARG(std::isfinite(max_tilt_deg) && max_tilt_deg > 0 && max_tilt_deg < 45)
      << "alignment largest tilt: must be in (0, 45) deg";
  LN_CHECK_ARG(std::isfinite(max_shift_m) && max_shift_m > 0) << "alignment largest shift: must be > 0 m";
  LN_CHECK_ARG(std::isfinite(gain) && gain > 0 && gain <= 1) << "alignment gain: must be in (0, 1]";
  LN_CHECK_ARG(std::isfinite(tilt_prior_rad) && tilt_prior_rad > 0) << "alignment tilt prior: must be > 0";
}

nlohmann::json GroundAlignmentOptions::ToJson() const {
  return {{"stride_px", stride_px},         {"range_m", {min_range_m, max_range_m}},
          {"min_samples_per_cell", min_samples_per_cell}, {"min_cells", min_cells},
          {"robust_m", robust_m},           {"max_tilt_deg", max_tilt_deg},
          {"max_shift_m", max_shift_m},     {"gain", gain},
          {"tilt_prior_deg", tilt_prior_rad * 180 / M_PI}};
}

nlohmann::json GroundAlignment::ToJson() const {
  nlohmann::json j = {{"stem", stem}, {"applied", applied}, {"contradicts", contradicts}, {"cells", cells}};
  if (!applied) j["reason"] = reason;
  j["shift_m"] = shift_m;
  j["tilt_x_deg"] = tilt_x_deg;
  j["tilt_y_deg"] = tilt_y_deg;
  j["rms_before_m"] = rms_before_m;
  j["rms_after_m"] = rms_after_m;
  return j;
}

GroundAligner::GroundAligner(double cell_m, const GroundAlignmentOptions& options)
    : cell_m_(cell_m), options_(options) {
  LN_CHECK_ARG(std::isfinite(cell_m) && cell_m > 0) << "alignment cell: must be > 0 m";
  options_.Validate();
}

std::uint64_t GroundAligner::Key(double x, double y) const {
  const auto i = static_cast<std::int64_t>(std::floor(x / cell_m_));
  const auto j = static_cast<std::int64_t>(std::floor(y / cell_m_));
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(i)) << 32) | static_cast<std::uint32_t>(j);
}

void GroundAligner::AddReference(double x_m, double y_m, double z_m) {
  Sum& s = reference_[Key(x_m, y_m)];
  s.z += z_m;
  ++s.pairs;
}

FramePose GroundAligner::Align(const FramePose& estimated, const std::vector<Eigen::Vector3f>& vehicle_points,
                               GroundAlignment* record) {
  GroundAlignment r;
  r.stem = estimated.stem;
  const Eigen::Isometry3d world_from_vehicle = estimated.WorldFromVehicle();
  const Eigen::Vector3d origin = world_from_vehicle.translation();
  // The pair's own cell heights, placed by its estimated pose.
  std::unordered_map<std::uint64_t, CellSamples> own;
  const double r_lo2 = options_.min_range_m * options_.min_range_m, r_hi2 = options_.max_range_m * options_.max_range_m;
  for (const Eigen::Vector3f& v : vehicle_points) {
    const Eigen::Vector3d w = world_from_vehicle * v.cast<double>();
    const double d2 = (w - origin).head<2>().squaredNorm();
    if (d2 < r_lo2 || d2 > r_hi2) continue;
    CellSamples& c = own[Key(w.x(), w.y())];
    c.sum_x += w.x();
    c.sum_y += w.y();
    c.sum_z += w.z();
    ++c.n;
  }
  // Differences with the reference: reference height minus the pair's, at the samples' mean place.
  std::vector<PlaneSample> rows;
  for (const auto& [key, c] : own) {
    if (c.n < options_.min_samples_per_cell) continue;
    const auto it = reference_.find(key);
    if (it == reference_.end()) continue;
    const double n = c.n;
    rows.push_back({c.sum_x / n - origin.x(), c.sum_y / n - origin.y(), it->second.z / it->second.pairs - c.sum_z / n});
  }
  r.cells = static_cast<int>(rows.size());
  Eigen::Vector3d x = Eigen::Vector3d::Zero();  // shift, slope along x, slope along y
  if (rows.size() < static_cast<std::size_t>(options_.min_cells)) {
    r.reason = "too little ground in common with the map (" + std::to_string(rows.size()) + " cells)";
  } else {
    // The RMS of the residuals within three robust scales.
    auto robust_rms = [&](const std::vector<double>& abs_res) {
      std::vector<double> scratch = abs_res;
      const double scale = std::max(options_.robust_m, 1.4826 * MedianInPlace(scratch));
      double s2 = 0;
      long n = 0;
      for (double a : abs_res) {
        if (a > 3 * scale) continue;
        s2 += a * a;
        ++n;
      }
      return n > 0 ? std::sqrt(s2 / static_cast<double>(n)) : 0.0;
    };
    std::vector<double> abs_res(rows.size());
    for (std::size_t i = 0; i < rows.size(); ++i) abs_res[i] = std::abs(rows[i].z);
    r.rms_before_m = robust_rms(abs_res);
    // A prior on the tilt: ground in common that does not spread along the view (the band of
    // one distance the loop asks for) fixes the shift there but not the pitch; the least tilt
    // that explains it is taken (a full view outweighs the prior a hundredfold).
    const std::optional<Eigen::Vector3d> fit = FitRobustPlane(rows, options_.robust_m, options_.tilt_prior_rad, &abs_res);
    const double tilt = fit ? std::atan(std::hypot((*fit)[1], (*fit)[2])) / kDeg : 0.0;
    if (!fit) {
      r.reason = "the fit is singular";
    } else if (tilt > options_.max_tilt_deg || std::abs((*fit)[0]) > options_.max_shift_m) {
      r.reason = "the fit asks for more than the largest correction";
      r.contradicts = true;
    } else {
      x = *fit;
      r.applied = true;
      r.rms_after_m = robust_rms(abs_res);
    }
  }
  x *= options_.gain;
  // z += shift + a (x - x0) + b (y - y0) as a rotation about the vehicle: about world y by -a,
  // about world x by b; then the shift.
  const Eigen::Matrix3d rotation =
      (Eigen::AngleAxisd(std::atan(x[2]), Eigen::Vector3d::UnitX()) *
       Eigen::AngleAxisd(-std::atan(x[1]), Eigen::Vector3d::UnitY()))
          .toRotationMatrix();
  Eigen::Isometry3d correction = Eigen::Isometry3d::Identity();
  correction.linear() = rotation;
  correction.translation() = origin + Eigen::Vector3d(0, 0, x[0]) - rotation * origin;
  const Eigen::Isometry3d corrected = correction * world_from_vehicle;
  r.shift_m = x[0];
  r.tilt_x_deg = std::atan(x[2]) / kDeg;
  r.tilt_y_deg = -std::atan(x[1]) / kDeg;
  const FramePose out = r.applied ? PoseFromTransform(corrected, estimated) : estimated;

  if (record != nullptr) *record = r;
  if (r.contradicts) return out;
  // The pair's samples, placed by the pose it keeps, join the reference: one observation per cell.
  const Eigen::Isometry3d placed = out.WorldFromVehicle();
  own.clear();
  for (const Eigen::Vector3f& v : vehicle_points) {
    const Eigen::Vector3d p = placed * v.cast<double>();
    const double d2 = (p - placed.translation()).head<2>().squaredNorm();
    if (d2 < r_lo2 || d2 > r_hi2) continue;
    CellSamples& c = own[Key(p.x(), p.y())];
    c.sum_z += p.z();
    ++c.n;
  }
  for (const auto& [key, c] : own) {
    if (c.n < options_.min_samples_per_cell) continue;
    Sum& s = reference_[key];
    s.z += c.sum_z / c.n;
    ++s.pairs;
  }
  return out;
}

FramePose PoseFromTransform(const Eigen::Isometry3d& world_from_vehicle, const FramePose& like) {
  // R = Rz(-heading) Rx(pitch) Ry(roll): its last row is (-cos p sin r, sin p, cos p cos r),
  // its second column (sin h cos p, cos h cos p, sin p).
  const Eigen::Matrix3d r = world_from_vehicle.linear();
  FramePose p = like;
  p.x_m = world_from_vehicle.translation().x();
  p.y_m = world_from_vehicle.translation().y();
  p.z_m = world_from_vehicle.translation().z();
  p.pitch_rad = std::asin(std::clamp(r(2, 1), -1.0, 1.0));
  p.roll_rad = std::atan2(-r(2, 0), r(2, 2));
  const double heading = std::atan2(r(0, 1), r(1, 1));
  // Keep the heading's turns (an unwrapped heading stays unwrapped).
  p.heading_rad = like.heading_rad + std::remainder(heading - like.heading_rad, 2 * M_PI);
  return p;
}

std::vector<Eigen::Vector3f> SampleXyz(const cv::Mat& xyz, int stride_px) {
  LN_CHECK(xyz.type() == CV_32FC3) << "SampleXyz: a CV_32FC3 array";
  std::vector<Eigen::Vector3f> out;
  for (int y = stride_px / 2; y < xyz.rows; y += stride_px) {
    const auto* row = xyz.ptr<cv::Vec3f>(y);
    for (int x = stride_px / 2; x < xyz.cols; x += stride_px) {
      const cv::Vec3f& v = row[x];
      if (std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2])) out.emplace_back(v[0], v[1], v[2]);
    }
  }
  return out;
}

}  // namespace lunarnav::mapping
