#include "mapping/frame_poses.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include "mapping/kitti_trajectory.h"
#include "positioning/trajectory_io.h"
#include "util/check.h"
#include "util/text_lines.h"
#include "util/errors.h"
#include "util/parse.h"

namespace lunarnav::mapping {
namespace fs = std::filesystem;

namespace {

constexpr double kDeg = M_PI / 180.0;

using util::Trim;

std::vector<std::string> SplitCells(const std::string& line) {
  std::vector<std::string> cells;
  std::string cell;
  std::istringstream in(line);
  while (std::getline(in, cell, ',')) cells.push_back(Trim(cell));
  if (!line.empty() && line.back() == ',') cells.emplace_back();
  return cells;
}

// A number cell; "nan", "inf" accepted (reported where the pose is used).
double Number(const std::string& cell, const std::string& where) {
  std::size_t used = 0;
  double v = 0;
  try {
    v = std::stod(cell, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  LN_CHECK_INPUT(used > 0 && used == cell.size()) << where << ": '" << cell << "' is not a number";
  return v;
}

// Rows of a CSV whose header starts with `columns`: calls fn(cells, "file:line").
template <typename Fn>
void ForEachRow(const fs::path& path, const std::vector<std::string>& columns, Fn fn) {
  util::TextLines lines(path);
  std::string t;
  bool header = false;
  while (lines.Next(&t)) {
    const std::string where = lines.Where();
    std::vector<std::string> cells = SplitCells(t);
    if (!header) {
      bool ok = cells.size() >= columns.size();
      for (std::size_t i = 0; ok && i < columns.size(); ++i) ok = cells[i] == columns[i];
      std::string expected;
      for (const std::string& c : columns) expected += (expected.empty() ? "" : ",") + c;
      LN_CHECK_INPUT(ok) << where << ": expected a header starting '" << expected << "'";
      header = true;
      continue;
    }
    LN_CHECK_INPUT(cells.size() >= columns.size())
        << where << ": " << cells.size() << " cells, expected at least " << columns.size();
    LN_CHECK_INPUT(!cells[0].empty()) << where << ": empty stem";
    fn(cells, where);
  }
  LN_CHECK_INPUT(header) << path.string() << ": no header";
}

double WrapPi(double a) { return std::remainder(a, 2 * M_PI); }

}  // namespace

Eigen::Isometry3d WorldFromVehicle(double x_m, double y_m, double z_m, double heading_rad, double pitch_rad,
                                   double roll_rad) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = (Eigen::AngleAxisd(-heading_rad, Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(pitch_rad, Eigen::Vector3d::UnitX()) *
                Eigen::AngleAxisd(roll_rad, Eigen::Vector3d::UnitY()))
                   .toRotationMatrix();
  t.translation() = Eigen::Vector3d(x_m, y_m, z_m);
  return t;
}

Eigen::Vector2d HeadingDirection(const Eigen::Isometry3d& world_from_vehicle) {
  const Eigen::Vector3d forward = world_from_vehicle.linear() * Eigen::Vector3d::UnitY();
  const Eigen::Vector2d level = forward.head<2>();
  const double n = level.norm();
  return n > 0 ? Eigen::Vector2d(level / n) : Eigen::Vector2d(0, 1);  // pitched 90 deg: no heading to speak of
}

Eigen::Isometry3d FramePose::WorldFromVehicle() const {
  return mapping::WorldFromVehicle(x_m, y_m, z_m, heading_rad, pitch_rad, roll_rad);
}

bool FramePose::IsFinite() const {
  return std::isfinite(t_s) && std::isfinite(x_m) && std::isfinite(y_m) && std::isfinite(z_m) &&
         std::isfinite(heading_rad) && std::isfinite(pitch_rad) && std::isfinite(roll_rad);
}

void FramePose::Validate(const std::string& source) const {
  const std::string from = source.empty() ? "" : " (" + source + ")";
  LN_CHECK_INPUT(IsFinite()) << "stem " << stem << ": the pose is not finite" << from;
  const double far = std::max({std::abs(x_m), std::abs(y_m), std::abs(z_m)});
  LN_CHECK_INPUT(far <= kMaxWorldCoordinateM)
      << "stem " << stem << ": the pose (" << x_m << ", " << y_m << ", " << z_m << ") m lies beyond "
      << kMaxWorldCoordinateM / 1000 << " km of the world origin, the maps' limit" << from;
  const double turn = std::max({std::abs(heading_rad), std::abs(pitch_rad), std::abs(roll_rad)}) / kDeg;
  LN_CHECK_INPUT(turn <= kMaxPoseAngleDeg)
      << "stem " << stem << ": an angle of " << turn << " deg, beyond " << kMaxPoseAngleDeg << from;
}

std::vector<FramePose> ReadPosesCsv(const fs::path& path) {
  std::vector<FramePose> poses;
  std::set<std::string> seen;
  ForEachRow(path, {"stem", "t_s", "x_m", "y_m", "z_m", "heading_deg", "pitch_deg", "roll_deg"},
             [&](const std::vector<std::string>& c, const std::string& where) {
               FramePose p;
               p.stem = c[0];
               LN_CHECK_INPUT(seen.insert(p.stem).second) << where << ": stem " << p.stem << " listed twice";
               p.t_s = Number(c[1], where);
               p.x_m = Number(c[2], where);
               p.y_m = Number(c[3], where);
               p.z_m = Number(c[4], where);
               p.heading_rad = Number(c[5], where) * kDeg;
               p.pitch_rad = Number(c[6], where) * kDeg;
               p.roll_rad = Number(c[7], where) * kDeg;
               poses.push_back(p);
             });
  return poses;
}

std::vector<FramePose> ReadFrameTimes(const fs::path& path) {
  if (IsKittiFrameTimes(path)) return ReadKittiFrameTimes(path);
  std::vector<FramePose> times;
  std::set<std::string> seen;
  ForEachRow(path, {"stem", "t_s"}, [&](const std::vector<std::string>& c, const std::string& where) {
    FramePose p;
    p.stem = c[0];
    LN_CHECK_INPUT(seen.insert(p.stem).second) << where << ": stem " << p.stem << " listed twice";
    p.t_s = Number(c[1], where);
    LN_CHECK_INPUT(std::isfinite(p.t_s)) << where << ": stem " << p.stem << ": time is not finite";
    times.push_back(p);
  });
  return times;
}

std::vector<positioning::TrajectorySample> ReadTrajectory(const fs::path& trajectory, const TrajectoryContext& context) {
  const TrajectoryFormat format = DetectTrajectoryFormat(trajectory);
  std::vector<positioning::TrajectorySample> samples;
  const bool kitti = format == TrajectoryFormat::kKittiPoses || format == TrajectoryFormat::kKittiOxts;
  LN_CHECK_ARG(!kitti || context.vehicle_from_camera.has_value())
      << trajectory.string() << ": KITTI's poses are the cameras': give --rig, whose mast places them on the vehicle";
  switch (format) {
    case TrajectoryFormat::kPosfilterCsv: samples = positioning::ReadTrajectoryCsv(trajectory); break;
    case TrajectoryFormat::kTum: samples = positioning::ReadTrajectoryTum(trajectory); break;
    case TrajectoryFormat::kKittiPoses:
      samples = ReadKittiPoseTrajectory(trajectory, context.frame_times, *context.vehicle_from_camera);
      break;
    case TrajectoryFormat::kKittiOxts: samples = ReadKittiOxtsTrajectory(trajectory, *context.vehicle_from_camera); break;
  }
  LN_CHECK_INPUT(!samples.empty()) << trajectory.string() << ": no poses";
  for (std::size_t i = 1; i < samples.size(); ++i) {
    LN_CHECK_INPUT(samples[i].t_s > samples[i - 1].t_s)
        << trajectory.string() << ": time stamps must increase (row " << i + 1 << ")";
  }
  return samples;
}

std::vector<FramePose> InterpolateTrajectory(const fs::path& trajectory, const std::vector<FramePose>& frame_times,
                                             const TrajectoryContext& context) {
  const std::vector<positioning::TrajectorySample> samples = ReadTrajectory(trajectory, context);
  std::vector<FramePose> out;
  for (const FramePose& f : frame_times) {
    const double t = f.t_s;
    LN_CHECK_INPUT(t >= samples.front().t_s && t <= samples.back().t_s)
        << "stem " << f.stem << ": time " << t << " s is outside the trajectory " << trajectory.string() << " ("
        << samples.front().t_s << " to " << samples.back().t_s << " s)";
    auto after = std::lower_bound(samples.begin(), samples.end(), t,
                                  [](const positioning::TrajectorySample& s, double v) { return s.t_s < v; });
    const positioning::TrajectorySample& b = *after;
    const positioning::TrajectorySample& a = after == samples.begin() ? b : *(after - 1);
    const double w = b.t_s > a.t_s ? (t - a.t_s) / (b.t_s - a.t_s) : 0.0;
    FramePose p = f;
    p.x_m = a.x_m + w * (b.x_m - a.x_m);
    p.y_m = a.y_m + w * (b.y_m - a.y_m);
    p.z_m = a.z_m + w * (b.z_m - a.z_m);
    p.heading_rad = a.heading_rad + w * WrapPi(b.heading_rad - a.heading_rad);
    p.pitch_rad = a.pitch_rad + w * WrapPi(b.pitch_rad - a.pitch_rad);
    p.roll_rad = a.roll_rad + w * WrapPi(b.roll_rad - a.roll_rad);
    out.push_back(p);
  }
  return out;
}

std::map<std::string, FramePose> IndexByStem(const std::vector<FramePose>& poses) {
  std::map<std::string, FramePose> m;
  for (const FramePose& p : poses) m.emplace(p.stem, p);
  return m;
}

std::vector<FramePose> PosesOfPairs(const std::filesystem::path& poses_csv, const std::filesystem::path& trajectory,
                                    const std::filesystem::path& frame_times, const std::vector<std::string>& stems,
                                    const std::optional<Eigen::Isometry3d>& vehicle_from_camera) {
  const std::filesystem::path& pose_file = poses_csv.empty() ? frame_times : poses_csv;
  std::vector<FramePose> listed = poses_csv.empty() ? ReadFrameTimes(frame_times) : ReadPosesCsv(poses_csv);
  const auto by_stem = IndexByStem(listed);
  for (const std::string& stem : stems) {
    LN_CHECK_INPUT(by_stem.count(stem) > 0) << "stem " << stem << ": no pose in " << pose_file.string();
  }
  const std::set<std::string> wanted(stems.begin(), stems.end());
  listed.erase(std::remove_if(listed.begin(), listed.end(), [&](const FramePose& p) { return wanted.count(p.stem) == 0; }),
               listed.end());
  if (!trajectory.empty()) listed = InterpolateTrajectory(trajectory, listed, {frame_times, vehicle_from_camera});
  for (const FramePose& p : listed) p.Validate(pose_file.string());
  std::stable_sort(listed.begin(), listed.end(), [](const FramePose& a, const FramePose& b) { return a.t_s < b.t_s; });
  return listed;
}

}  // namespace lunarnav::mapping
