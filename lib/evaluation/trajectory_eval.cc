#include "evaluation/trajectory_eval.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <initializer_list>
#include <optional>
#include <sstream>

#include <Eigen/Geometry>
#include <Eigen/SVD>

#include "evaluation/table.h"
#include "evaluation/trials_eval.h"
#include "io/atomic_file.h"
#include "io/json_io.h"
#include "positioning/attitude.h"
#include "positioning/trajectory_io.h"
#include "util/check.h"
#include "util/text_lines.h"
#include "util/errors.h"
#include "util/log.h"
#include "util/parse.h"
#include "util/timer.h"

namespace lunarnav::evaluation {
namespace fs = std::filesystem;

namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

double AngleDeg(const Eigen::Matrix3d& r) {
  return kRadToDeg * Eigen::AngleAxisd(r).angle();
}

std::vector<StampedPose> ReadTum(const fs::path& path) {
  std::vector<StampedPose> poses;
  for (const positioning::TumPose& tum : positioning::ReadTumPoses(path)) {
    StampedPose p;
    p.t_s = tum.t_s;
    p.world_from_body.linear() = tum.world_from_body.toRotationMatrix();
    p.world_from_body.translation() = tum.position_m;
    poses.push_back(p);
  }
  return poses;
}

// Cumulative path length of the positions.
std::vector<double> PathLengths(const std::vector<Eigen::Isometry3d>& poses) {
  std::vector<double> s(poses.size(), 0.0);
  for (std::size_t i = 1; i < poses.size(); ++i) {
    s[i] = s[i - 1] + (poses[i].translation() - poses[i - 1].translation()).norm();
  }
  return s;
}

// Umeyama's least-squares rigid transform taking `from` points onto `to` points.
Eigen::Isometry3d RigidAlignment(const std::vector<Eigen::Isometry3d>& from,
                                 const std::vector<Eigen::Isometry3d>& to) {
  Eigen::Matrix3Xd a(3, from.size()), b(3, to.size());
  for (std::size_t i = 0; i < from.size(); ++i) {
    a.col(i) = from[i].translation();
    b.col(i) = to[i].translation();
  }
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.matrix() = Eigen::umeyama(a, b, false);
  return t;
}

// The same in the horizontal plane: rotation about z and translation in x and y, in closed
// form (the angle that best turns the centred points onto each other is the atan2 of their
// summed cross and dot products). With `scale`, first the least-squares scale of `from`'s
// positions (Umeyama's in 2-D: the length of that cross and dot vector over from's centred
// sum of squares), which is then applied to `from`: the similarity's rotation and translation
// are the rigid alignment of the scaled points (a scale changes neither the angle nor, once
// applied, the centroids' relation).
Eigen::Isometry3d HorizontalAlignment(std::vector<Eigen::Isometry3d>* from_poses,
                                      const std::vector<Eigen::Isometry3d>& to, double* scale) {
  std::vector<Eigen::Isometry3d>& from = *from_poses;
  Eigen::Vector2d from_mean = Eigen::Vector2d::Zero(), to_mean = Eigen::Vector2d::Zero();
  for (std::size_t i = 0; i < from.size(); ++i) {
    from_mean += from[i].translation().head<2>();
    to_mean += to[i].translation().head<2>();
  }
  from_mean /= static_cast<double>(from.size());
  to_mean /= static_cast<double>(to.size());
  double cross = 0, dot = 0, squares = 0;
  for (std::size_t i = 0; i < from.size(); ++i) {
    const Eigen::Vector2d a = from[i].translation().head<2>() - from_mean;
    const Eigen::Vector2d b = to[i].translation().head<2>() - to_mean;
    cross += a.x() * b.y() - a.y() * b.x();
    dot += a.dot(b);
    squares += a.squaredNorm();
  }
  if (scale != nullptr) {
    *scale = squares > 0 ? std::hypot(cross, dot) / squares : 1.0;
    for (Eigen::Isometry3d& pose : from) pose.translation() *= *scale;
    from_mean *= *scale;
  }
  const Eigen::Rotation2Dd rotation(std::atan2(cross, dot));
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear().topLeftCorner<2, 2>() = rotation.toRotationMatrix();
  t.translation().head<2>() = to_mean - rotation * from_mean;
  return t;
}

}  // namespace

std::string ToString(Alignment alignment) {
  switch (alignment) {
    case Alignment::kNone: return "none";
    case Alignment::kStart: return "start";
    case Alignment::kOrigin: return "origin";
    case Alignment::kRigid: return "rigid";
    case Alignment::kRigid2d: return "rigid-2d";
    case Alignment::kSimilarity2d: return "similarity-2d";
  }
  return "?";
}

bool IsHorizontal(Alignment alignment) {
  return alignment == Alignment::kRigid2d || alignment == Alignment::kSimilarity2d;
}

Alignment AlignmentFromString(const std::string& text) {
  for (Alignment a : {Alignment::kNone, Alignment::kStart, Alignment::kOrigin, Alignment::kRigid, Alignment::kRigid2d,
                      Alignment::kSimilarity2d}) {
    if (text == ToString(a)) return a;
  }
  throw std::invalid_argument("alignment: none, start, origin, rigid, rigid-2d or similarity-2d, got '" + text + "'");
}

void TrajectoryEvalOptions::Validate() const {
  LN_CHECK_ARG(rpe_delta_m > 0) << "RPE delta: must be > 0 m";
  for (double s : drift_segments_m) LN_CHECK_ARG(s > 0) << "drift segments: must be > 0 m";
  LN_CHECK_ARG(drift_step >= 1) << "drift step: must be >= 1";
}

ErrorStats ErrorStats::Of(std::vector<double> values) {
  ErrorStats s;
  s.count = static_cast<long>(values.size());
  if (values.empty()) return s;
  double sum = 0, sum_sq = 0;
  for (double v : values) {
    sum += v;
    sum_sq += v * v;
  }
  const double n = static_cast<double>(values.size());
  s.mean = sum / n;
  s.rmse = std::sqrt(sum_sq / n);
  s.std = std::sqrt(std::max(0.0, sum_sq / n - s.mean * s.mean));  // evo: population std
  std::sort(values.begin(), values.end());
  const std::size_t mid = values.size() / 2;
  s.median = values.size() % 2 ? values[mid] : 0.5 * (values[mid - 1] + values[mid]);
  s.min = values.front();
  s.max = values.back();
  return s;
}

// The farthest a position track's coordinate may lie from its origin, metres (beyond the Earth).
constexpr double kMaxTrackCoordinateM = 1e7;

// A position track: a CSV whose header names time, east (x) and north (y), optionally up (z);
// nullopt when the header is not one.
std::optional<std::vector<StampedPose>> ReadPositionTrack(const fs::path& path) {
  util::TextLines lines(path);
  std::string line;
  lines.Next(&line);
  std::vector<std::string> names;
  {
    std::stringstream header(line);
    for (std::string cell; std::getline(header, cell, ',');) names.push_back(cell);
  }
  auto is = [&](std::size_t k, std::initializer_list<const char*> options) {
    return k < names.size() && std::any_of(options.begin(), options.end(), [&](const char* o) { return names[k] == o; });
  };
  if (!(is(0, {"t", "t_s"}) && is(1, {"east", "x", "x_m"}) && is(2, {"north", "y", "y_m"}))) return std::nullopt;
  if (names.size() > 3 && names[3] == "z_m" && names.size() > 4 && names[4] == "heading_deg") return std::nullopt;
  const bool has_up = is(3, {"up", "z", "z_m"});
  std::vector<StampedPose> poses;
  const long header_line = lines.number();
  while (lines.Next(&line)) {
    const long number = lines.number();
    std::stringstream row(line);
    row.imbue(std::locale::classic());
    double v[4] = {0, 0, 0, 0};
    const int wanted = has_up ? 4 : 3;
    for (int k = 0; k < wanted; ++k) {
      std::string cell;
      std::getline(row, cell, ',');
      char* end = nullptr;
      v[k] = std::strtod(cell.c_str(), &end);
      LN_CHECK_INPUT(!cell.empty() && end != cell.c_str() && std::isfinite(v[k]))
          << path.string() << ":" << number << ": '" << cell << "' is not a number (" << names[k] << ")";
      // A position beyond the Earth (1e308 made every error infinite and every score null).
      LN_CHECK_INPUT(k == 0 || std::abs(v[k]) <= kMaxTrackCoordinateM)
          << path.string() << ":" << number << ": " << names[k] << " " << cell << " m is farther than "
          << kMaxTrackCoordinateM << " m from the track's origin";
    }
    LN_CHECK_INPUT(poses.empty() || v[0] > poses.back().t_s)
        << path.string() << ":" << number << ": time stamps must increase";
    StampedPose p;
    p.t_s = v[0];
    p.world_from_body.translation() = Eigen::Vector3d(v[1], v[2], v[3]);
    p.has_attitude = false;
    poses.push_back(p);
  }
  LN_CHECK_INPUT(!poses.empty()) << path.string() << ":" << header_line << ": a position track without rows";
  return poses;
}

std::vector<StampedPose> ReadPoses(const fs::path& path) {
  if (path.extension() != ".csv") return ReadTum(path);
  if (auto track = ReadPositionTrack(path)) return *std::move(track);
  std::vector<StampedPose> poses;
  for (const auto& sample : positioning::ReadTrajectoryCsv(path)) {
    StampedPose p;
    p.t_s = sample.t_s;
    p.world_from_body.linear() =
        positioning::EnuFromBody(sample.heading_rad, sample.pitch_rad, sample.roll_rad).toRotationMatrix();
    p.world_from_body.translation() = Eigen::Vector3d(sample.x_m, sample.y_m, sample.z_m);
    poses.push_back(p);
  }
  return poses;
}

Eigen::Isometry3d InterpolatePose(const std::vector<StampedPose>& truth, double t_s) {
  LN_CHECK(!truth.empty() && t_s >= truth.front().t_s && t_s <= truth.back().t_s) << "t outside the truth";
  auto after = std::lower_bound(truth.begin(), truth.end(), t_s,
                                [](const StampedPose& p, double t) { return p.t_s < t; });
  if (after == truth.begin()) return after->world_from_body;
  const StampedPose& b = *after;
  const StampedPose& a = *(after - 1);
  const double w = (t_s - a.t_s) / (b.t_s - a.t_s);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = (1 - w) * a.world_from_body.translation() + w * b.world_from_body.translation();
  pose.linear() = Eigen::Quaterniond(a.world_from_body.linear())
                      .slerp(w, Eigen::Quaterniond(b.world_from_body.linear()))
                      .toRotationMatrix();
  return pose;
}

TrajectoryErrors EvaluateTrajectory(const std::vector<StampedPose>& estimate,
                                    const std::vector<StampedPose>& truth,
                                    const TrajectoryEvalOptions& options) {
  options.Validate();
  std::vector<Eigen::Isometry3d> est, ref;
  TrajectoryErrors errors;
  for (const StampedPose& p : estimate) {
    if (truth.empty() || p.t_s < truth.front().t_s || p.t_s > truth.back().t_s) continue;
    est.push_back(p.world_from_body);
    ref.push_back(InterpolatePose(truth, p.t_s));
    errors.matched_t_s.push_back(p.t_s);
  }
  LN_CHECK_INPUT(est.size() >= 2) << "only " << est.size()
                                  << " estimated poses fall inside the truth's time span";
  errors.poses_matched = static_cast<long>(est.size());
  errors.truth_has_attitude =
      std::all_of(truth.begin(), truth.end(), [](const StampedPose& p) { return p.has_attitude; });
  const bool attitude = errors.truth_has_attitude;
  const bool horizontal = IsHorizontal(options.alignment);

  // Alignment, then APE.
  Eigen::Isometry3d align = Eigen::Isometry3d::Identity();
  switch (options.alignment) {
    case Alignment::kNone: break;
    case Alignment::kStart: align.translation() = ref[0].translation() - est[0].translation(); break;
    case Alignment::kOrigin: align = ref[0] * est[0].inverse(); break;
    case Alignment::kRigid: align = RigidAlignment(est, ref); break;
    case Alignment::kRigid2d: align = HorizontalAlignment(&est, ref, nullptr); break;
    case Alignment::kSimilarity2d: align = HorizontalAlignment(&est, ref, &errors.scale); break;
  }
  errors.alignment = align;
  std::vector<double> ape_t, ape_r;
  for (std::size_t i = 0; i < est.size(); ++i) {
    const Eigen::Isometry3d e = ref[i].inverse() * (align * est[i]);
    if (horizontal) {  // horizontal error
      ape_t.push_back(((align * est[i]).translation() - ref[i].translation()).head<2>().norm());
    } else {
      ape_t.push_back(e.translation().norm());
    }
    ape_r.push_back(AngleDeg(e.linear()));
  }
  errors.ape_translation_m = ErrorStats::Of(std::move(ape_t));
  if (attitude) errors.ape_rotation_deg = ErrorStats::Of(std::move(ape_r));

  // RPE over consecutive pairs rpe_delta_m apart along the true path.
  const std::vector<double> s = PathLengths(ref);
  errors.path_length_m = s.back();
  std::vector<double> rpe_t, rpe_r;
  auto relative_error = [&](std::size_t i, std::size_t j) {
    return (ref[i].inverse() * ref[j]).inverse() * (est[i].inverse() * est[j]);
  };
  // Without the truth's attitude: the aligned estimate's displacement against the truth's
  // (horizontal with the 2-D alignment).
  auto displacement_error = [&](std::size_t i, std::size_t j) {
    const Eigen::Vector3d d = (align * est[j]).translation() - (align * est[i]).translation() -
                              (ref[j].translation() - ref[i].translation());
    return horizontal ? d.head<2>().norm() : d.norm();
  };
  for (std::size_t i = 0; i < est.size();) {
    // From the next pose on: a step too small to move s[i] (1e-17 m) still advances.
    const auto j = static_cast<std::size_t>(
        std::lower_bound(s.begin() + static_cast<std::ptrdiff_t>(i) + 1, s.end(), s[i] + options.rpe_delta_m) -
        s.begin());
    if (j >= est.size()) break;
    if (attitude) {
      const Eigen::Isometry3d e = relative_error(i, j);
      rpe_t.push_back(e.translation().norm());
      rpe_r.push_back(AngleDeg(e.linear()));
    } else {
      rpe_t.push_back(displacement_error(i, j));
    }
    i = j;
  }
  errors.rpe_translation_m = ErrorStats::Of(std::move(rpe_t));
  if (attitude) errors.rpe_rotation_deg = ErrorStats::Of(std::move(rpe_r));

  // KITTI drift.
  double sum_t = 0, sum_r = 0;
  for (std::size_t i = 0; i < est.size(); i += static_cast<std::size_t>(options.drift_step)) {
    for (double length : options.drift_segments_m) {
      const auto j = static_cast<std::size_t>(
          std::lower_bound(s.begin() + static_cast<std::ptrdiff_t>(i) + 1, s.end(), s[i] + length) - s.begin());
      if (j >= est.size()) continue;
      if (attitude) {
        const Eigen::Isometry3d e = relative_error(i, j);
        sum_t += e.translation().norm() / length;
        sum_r += AngleDeg(e.linear()) / length;
      } else {
        sum_t += displacement_error(i, j) / length;
      }
      ++errors.drift_segments;
    }
  }
  if (errors.drift_segments > 0) {
    errors.drift_translation_pct = 100.0 * sum_t / errors.drift_segments;
    if (attitude) errors.drift_rotation_deg_per_m = sum_r / errors.drift_segments;
  }
  return errors;
}

double MeanPositionErrorAt(const std::vector<StampedPose>& estimate, const TrajectoryErrors& errors,
                           const std::vector<StampedPose>& truth, const TrajectoryEvalOptions& options,
                           const std::vector<double>& t_s, long* count) {
  const bool horizontal = IsHorizontal(options.alignment);
  double sum = 0;
  long n = 0;
  for (double t : t_s) {
    if (estimate.empty() || truth.empty() || t < estimate.front().t_s || t > estimate.back().t_s ||
        t < truth.front().t_s || t > truth.back().t_s) {
      continue;
    }
    Eigen::Isometry3d pose = InterpolatePose(estimate, t);
    pose.translation() *= errors.scale;
    const Eigen::Vector3d d = (errors.alignment * pose).translation() - InterpolatePose(truth, t).translation();
    sum += horizontal ? d.head<2>().norm() : d.norm();
    ++n;
  }
  *count = n;
  return n > 0 ? sum / static_cast<double>(n) : NAN;
}

int RunTrajectoryCommand(const TrajectoryCommand& command, const nlohmann::json& summary_head) {
  util::Timer timer;
  TrajectoryEvalOptions options = command.options;
  options.alignment = AlignmentFromString(command.alignment);
  options.Validate();
  std::vector<std::pair<std::string, std::filesystem::path>> specs;
  for (const std::string& text : command.estimates) {
    const auto eq = text.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == text.size()) {
      throw std::invalid_argument("ESTIMATE: expected NAME=TRAJECTORY, got '" + text + "'");
    }
    const std::string name = text.substr(0, eq);
    // Each name once: the table's rows and --reference are by name.
    const bool repeated = std::any_of(specs.begin(), specs.end(), [&](const auto& s) { return s.first == name; });
    if (repeated) throw std::invalid_argument("ESTIMATE: the name '" + name + "' is given twice");
    specs.emplace_back(name, text.substr(eq + 1));
  }
  io::CreateOutputDirectory(command.output_dir);
  const auto truth = ReadPoses(command.truth);
  std::vector<std::pair<std::string, TrajectoryErrors>> errors;
  std::vector<std::vector<StampedPose>> estimates;
  nlohmann::json inputs = nlohmann::json::array();
  for (const auto& [name, path] : specs) {
    estimates.push_back(ReadPoses(path));
    try {
      errors.emplace_back(name, EvaluateTrajectory(estimates.back(), truth, options));
    } catch (const InputError& e) {  // named: which estimate against which truth
      throw InputError(path.string() + " against " + command.truth.string() + ": " + e.what());
    }
    inputs.push_back({{"name", name}, {"trajectory", path.string()}});
  }
  const Table table = TrajectoryErrorsTable(errors, options);
  WriteTable(command.output_dir, "trajectory_errors", table);
  nlohmann::json summary = summary_head;
  summary["inputs"] = {{"truth", command.truth.string()}, {"estimates", inputs}};
  summary["options"] = {{"alignment", command.alignment},
                        {"reference", command.reference},
                        {"rpe_delta_m", options.rpe_delta_m},
                        {"drift_segments_m", options.drift_segments_m}};
  summary["table"] = table.ToJson();
  std::size_t reference = errors.size();
  for (std::size_t i = 0; i < errors.size(); ++i) {
    if (errors[i].first == command.reference) reference = i;
  }
  // The ratio to the reference: both means at the same instants, the reference's own time
  // stamps (an estimate written every row and a reference written once a second are
  // otherwise averaged over different instants), those inside both spans.
  std::vector<double> ratios(errors.size(), NAN);
  std::vector<long> ratio_instants(errors.size(), 0);
  if (reference < errors.size()) {
    const TrajectoryErrors& ref = errors[reference].second;
    for (std::size_t i = 0; i < errors.size(); ++i) {
      std::vector<double> common;
      const auto& est = estimates[i];
      for (double t : ref.matched_t_s) {
        if (t >= est.front().t_s && t <= est.back().t_s) common.push_back(t);
      }
      long n_est = 0, n_ref = 0;
      const double mean_est = MeanPositionErrorAt(est, errors[i].second, truth, options, common, &n_est);
      const double mean_ref = MeanPositionErrorAt(estimates[reference], ref, truth, options, common, &n_ref);
      ratios[i] = mean_est / mean_ref;
      ratio_instants[i] = n_est;
    }
  }
  nlohmann::json per = nlohmann::json::object();
  for (std::size_t i = 0; i < errors.size(); ++i) {
    const auto& [name, e] = errors[i];
    per[name] = {{"ape_mean_m", e.ape_translation_m.mean},
                 {"ape_rmse_m", e.ape_translation_m.rmse},
                 {"ape_max_m", e.ape_translation_m.max},
                 {"poses_matched", e.poses_matched}};
    if (options.alignment == Alignment::kSimilarity2d) per[name]["scale"] = e.scale;
    if (reference < errors.size()) {
      per[name]["ape_mean_ratio"] = ratios[i];
      per[name]["ratio_instants"] = ratio_instants[i];
    }
  }
  summary["estimates"] = per;
  summary["timings_s"] = {{"total", timer.ElapsedSeconds()}};
  io::WriteJsonAtomic(command.output_dir / "summary.json", summary);
  for (std::size_t i = 0; i < errors.size(); ++i) {
    const auto& [name, e] = errors[i];
    std::ostringstream line;
    line << "evaluate trajectory: " << name << ": mean position error " << e.ape_translation_m.mean << " m ("
         << command.alignment << " alignment)";
    if (reference < errors.size() && i != reference) {
      line << ", " << ratios[i] << " x " << command.reference << "'s (at its " << ratio_instants[i] << " time stamps)";
    }
    LN_LOG(Info) << line.str();
  }
  return kExitOk;
}

}  // namespace lunarnav::evaluation
