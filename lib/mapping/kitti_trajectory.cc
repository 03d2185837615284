#include "mapping/kitti_trajectory.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <limits>
#include <locale>
#include <sstream>

#include "calib/key_value_text.h"
#include "calib/stereo_rig.h"
#include "positioning/trajectory_io.h"
#include "util/check.h"
#include "util/errors.h"
#include "util/format.h"
#include "util/parse.h"

namespace lunarnav::mapping {
namespace fs = std::filesystem;

namespace {

constexpr double kDeg = M_PI / 180.0;
// The largest file of poses, times or packets read, lines: a drive of 28 hours at 10 Hz.
constexpr long kMaxLines = 1000000;

using util::Trim;

// The whitespace-separated numbers of a line; false when a token is not a finite number.
bool LineNumbers(const std::string& line, std::vector<double>* values, std::string* bad_field = nullptr) {
  values->clear();
  std::istringstream in(line);
  in.imbue(std::locale::classic());
  std::string token;
  while (in >> token) {
    char* end = nullptr;
    const double v = std::strtod(token.c_str(), &end);
    if (end == token.c_str() || *end != '\0' || !std::isfinite(v)) {
      if (bad_field != nullptr) *bad_field = token;
      return false;
    }
    values->push_back(v);
  }
  return true;
}

// Calls fn(line_text, line_number) for each line that is not blank or a '#' comment.
template <typename Fn>
void ForEachDataLine(const fs::path& path, Fn fn) {
  std::ifstream in(path);
  LN_CHECK_INPUT(in.good()) << path.string() << ": cannot open";
  std::string line;
  long data = 0;
  for (long number = 1; std::getline(in, line); ++number) {
    if (number == 1) util::DropUtf8Bom(&line);
    const std::string t = Trim(line);
    if (t.empty() || t[0] == '#') continue;
    LN_CHECK_INPUT(++data <= kMaxLines) << path.string() << ":" << number << ": more than " << kMaxLines << " lines";
    fn(t, number);
  }
}

// The first line that is not blank or a comment ("" when none).
std::string FirstDataLine(const fs::path& path) {
  std::ifstream in(path);
  LN_CHECK_INPUT(in.good()) << path.string() << ": cannot open";
  std::string line;
  for (long number = 1; number <= 1000 && std::getline(in, line); ++number) {
    if (number == 1) util::DropUtf8Bom(&line);
    const std::string t = Trim(line);
    if (!t.empty() && t[0] != '#') return t;
  }
  return "";
}

// "YYYY-MM-DD HH:MM:SS[.fraction]" as seconds since 1970 UTC; false when not such a date.
bool ParseDate(const std::string& text, double* seconds) {
  int year = 0, month = 0, day = 0, hour = 0, minute = 0, consumed = 0;
  if (std::sscanf(text.c_str(), "%4d-%2d-%2d %2d:%2d:%n", &year, &month, &day, &hour, &minute, &consumed) != 5 ||
      consumed == 0) {
    return false;
  }
  const std::string rest = text.substr(static_cast<std::size_t>(consumed));
  if (rest.empty() || !std::isdigit(static_cast<unsigned char>(rest[0]))) return false;
  char* end = nullptr;
  const double second = std::strtod(rest.c_str(), &end);
  if (*end != '\0' || !(second >= 0 && second < 61)) return false;
  if (year < 1970 || year > 9999 || month < 1 || month > 12 || day < 1 || day > 31 || hour > 23 || minute > 59) {
    return false;
  }
  std::tm tm{};
  tm.tm_year = year - 1900;
  tm.tm_mon = month - 1;
  tm.tm_mday = day;
  tm.tm_hour = hour;
  tm.tm_min = minute;
  tm.tm_sec = 0;
  *seconds = static_cast<double>(timegm(&tm)) + second;
  return true;
}

std::string Stem(long index, int digits) {
  char text[32];
  std::snprintf(text, sizeof(text), "%0*ld", digits, index);
  return text;
}

Eigen::Isometry3d RigidFrom12(const std::vector<double>& v, const std::string& where) {
  Eigen::Matrix3d r;
  Eigen::Vector3d t;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) r(i, j) = v[static_cast<std::size_t>(4 * i + j)];
    t(i) = v[static_cast<std::size_t>(4 * i + 3)];
  }
  std::vector<std::string> notes;
  calib::RepairPrintedRotation(&r, where, &notes);
  Eigen::Isometry3d m = Eigen::Isometry3d::Identity();
  m.linear() = r;
  m.translation() = t;
  return m;
}

// A rotation (9 numbers, row-major) and translation (3; none: zero) of a "key: numbers"
// calibration file.
Eigen::Isometry3d RigidFromKeys(const std::map<std::string, calib::TextEntry>& entries, const char* r_key,
                                const char* t_key, const fs::path& path) {
  const std::vector<double> r = calib::TextNumbers(calib::TextField(entries, r_key, path), r_key, path, 9);
  const std::vector<double> t = t_key == nullptr ? std::vector<double>(3, 0.0)
                                                 : calib::TextNumbers(calib::TextField(entries, t_key, path), t_key,
                                                                      path, 3);
  std::vector<double> v(12);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) v[static_cast<std::size_t>(4 * i + j)] = r[static_cast<std::size_t>(3 * i + j)];
    v[static_cast<std::size_t>(4 * i + 3)] = t[static_cast<std::size_t>(i)];
  }
  return RigidFrom12(v, path.string() + ": " + r_key);
}

// R_rect_00 of a calib_cam_to_cam.txt as a transform.
Eigen::Isometry3d RectifyingRotation(const fs::path& cam_to_cam) {
  return RigidFromKeys(calib::ReadKeyValues(cam_to_cam, ':'), "R_rect_00", nullptr, cam_to_cam);
}

positioning::TrajectorySample SampleOf(const Eigen::Isometry3d& world_from_vehicle, double t_s) {
  const FramePose p = FramePoseOf(world_from_vehicle);
  positioning::TrajectorySample s;
  s.t_s = t_s;
  s.x_m = p.x_m;
  s.y_m = p.y_m;
  s.z_m = p.z_m;
  s.heading_rad = p.heading_rad;
  s.pitch_rad = p.pitch_rad;
  s.roll_rad = p.roll_rad;
  return s;
}

}  // namespace

std::string ToString(TrajectoryFormat format) {
  switch (format) {
    case TrajectoryFormat::kPosfilterCsv:
      return "posfilter-csv";
    case TrajectoryFormat::kTum:
      return "tum";
    case TrajectoryFormat::kKittiPoses:
      return "kitti-poses";
    case TrajectoryFormat::kKittiOxts:
      return "kitti-oxts";
  }
  return "?";
}

TrajectoryFormat DetectTrajectoryFormat(const fs::path& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    LN_CHECK_INPUT(fs::is_directory(path / "data", ec) && fs::is_regular_file(path / "timestamps.txt", ec))
        << path.string() << ": a directory, but not KITTI's oxts/ (data/ and timestamps.txt)";
    return TrajectoryFormat::kKittiOxts;
  }
  LN_CHECK_INPUT(fs::is_regular_file(path, ec)) << path.string() << ": no such file";
  if (path.extension() == ".csv") return TrajectoryFormat::kPosfilterCsv;
  // Twelve numbers on the first line: KITTI's; anything else is read as TUM, whose reader names
  // the line that is not.
  std::vector<double> values;
  const bool numbers = LineNumbers(FirstDataLine(path), &values);
  LN_CHECK_INPUT(!numbers || values.size() == 12 || values.size() == 8)
      << path.string() << ": its first line holds " << values.size()
      << " numbers: a KITTI pose file has 12 a line (a 3 x 4 pose), a TUM trajectory 8 (time, position, quaternion)";
  return numbers && values.size() == 12 ? TrajectoryFormat::kKittiPoses : TrajectoryFormat::kTum;
}

bool IsKittiFrameTimes(const fs::path& path) {
  const std::string first = FirstDataLine(path);
  std::vector<double> values;
  double date = 0;
  return (LineNumbers(first, &values) && values.size() == 1) || ParseDate(first, &date);
}

std::vector<FramePose> ReadKittiFrameTimes(const fs::path& path) {
  std::vector<FramePose> times;
  bool dates = false;
  ForEachDataLine(path, [&](const std::string& line, long number) {
    const std::string where = path.string() + ":" + std::to_string(number);
    FramePose p;
    std::vector<double> values;
    double t = 0;
    if (times.empty()) dates = !(LineNumbers(line, &values) && values.size() == 1);
    if (dates) {
      LN_CHECK_INPUT(ParseDate(line, &t)) << where << ": expected a date YYYY-MM-DD HH:MM:SS.fraction";
    } else {
      LN_CHECK_INPUT(LineNumbers(line, &values) && values.size() == 1) << where << ": expected one number (seconds)";
      t = values[0];
    }
    // KITTI lists its frames in order: a time that does not increase is damage, named here
    // (a pose file that takes its times from this file would otherwise be blamed for it).
    LN_CHECK_INPUT(times.empty() || t > times.back().t_s)
        << where << ": time " << util::Format("%.9g", t) << " s is not after the previous frame's ("
        << util::Format("%.9g", times.back().t_s) << " s)";
    p.stem = Stem(static_cast<long>(times.size()), dates ? 10 : 6);
    p.t_s = t;
    times.push_back(p);
  });
  LN_CHECK_INPUT(!times.empty()) << path.string() << ": no frame times";
  return times;
}

std::vector<Eigen::Isometry3d> ReadKittiPoses(const fs::path& path) {
  std::vector<Eigen::Isometry3d> poses;
  ForEachDataLine(path, [&](const std::string& line, long number) {
    const std::string where = path.string() + ":" + std::to_string(number);
    std::vector<double> v;
    std::string bad;
    const bool numbers = LineNumbers(line, &v, &bad);
    LN_CHECK_INPUT(numbers) << where << ": field " << v.size() + 1 << ", '" << bad.substr(0, 40)
                            << "', is not a finite number (a 3 x 4 pose is 12 numbers, row-major)";
    LN_CHECK_INPUT(v.size() == 12) << where << ": expected 12 numbers (a 3 x 4 pose, row-major), got " << v.size();
    const Eigen::Isometry3d pose = RigidFrom12(v, where);
    LN_CHECK_INPUT(pose.translation().cwiseAbs().maxCoeff() <= kMaxWorldCoordinateM)
        << where << ": a position beyond " << kMaxWorldCoordinateM / 1000 << " km";
    poses.push_back(pose);
  });
  LN_CHECK_INPUT(!poses.empty()) << path.string() << ": no poses";
  return poses;
}

std::vector<positioning::TrajectorySample> ReadKittiPoseTrajectory(const fs::path& poses_path,
                                                                   const fs::path& frame_times,
                                                                   const Eigen::Isometry3d& vehicle_from_camera) {
  LN_CHECK_ARG(!frame_times.empty())
      << poses_path.string() << ": KITTI's pose files hold no times: give the sequence's times.txt as --frame-times";
  LN_CHECK_INPUT(IsKittiFrameTimes(frame_times))
      << frame_times.string() << ": not KITTI's times.txt (a number of seconds per line), which the pose file "
      << poses_path.string() << " takes its times from";
  const std::vector<Eigen::Isometry3d> poses = ReadKittiPoses(poses_path);
  const std::vector<FramePose> times = ReadKittiFrameTimes(frame_times);
  LN_CHECK_INPUT(times.size() >= poses.size())
      << frame_times.string() << ": " << times.size() << " frame times for the " << poses.size() << " poses of "
      << poses_path.string();
  const Eigen::Isometry3d first_inverse = poses.front().inverse();
  const Eigen::Isometry3d camera_from_vehicle = vehicle_from_camera.inverse();
  std::vector<positioning::TrajectorySample> samples;
  samples.reserve(poses.size());
  for (std::size_t i = 0; i < poses.size(); ++i) {
    samples.push_back(SampleOf(vehicle_from_camera * first_inverse * poses[i] * camera_from_vehicle, times[i].t_s));
  }
  return samples;
}

Eigen::Isometry3d KittiCameraFromImu(const fs::path& calib_dir) {
  const fs::path velo_to_cam = calib_dir / "calib_velo_to_cam.txt", imu_to_velo = calib_dir / "calib_imu_to_velo.txt";
  const Eigen::Isometry3d cam_from_velo = RigidFromKeys(calib::ReadKeyValues(velo_to_cam, ':'), "R", "T", velo_to_cam);
  const Eigen::Isometry3d velo_from_imu = RigidFromKeys(calib::ReadKeyValues(imu_to_velo, ':'), "R", "T", imu_to_velo);
  return RectifyingRotation(calib_dir / "calib_cam_to_cam.txt") * cam_from_velo * velo_from_imu;
}

fs::path KittiCalibDirOfOxts(const fs::path& oxts_dir) {
  const fs::path drive = fs::absolute(oxts_dir).lexically_normal().parent_path();
  std::error_code ec;
  for (const fs::path& dir : {drive, drive.parent_path()}) {
    if (fs::is_regular_file(dir / "calib_imu_to_velo.txt", ec)) return dir;
  }
  throw InputError(oxts_dir.string() + ": no calib_imu_to_velo.txt in the drive's folder or the date's above it " +
                   "(KITTI raw's calib_cam_to_cam.txt, calib_velo_to_cam.txt and calib_imu_to_velo.txt are needed " +
                   "to place the GPS/INS packets)");
}

std::vector<positioning::TrajectorySample> ReadKittiOxtsTrajectory(const fs::path& oxts_dir,
                                                                   const Eigen::Isometry3d& vehicle_from_camera) {
  const std::vector<FramePose> times = ReadKittiFrameTimes(oxts_dir / "timestamps.txt");
  const Eigen::Isometry3d camera_from_imu = KittiCameraFromImu(KittiCalibDirOfOxts(oxts_dir));
  const Eigen::Isometry3d imu_from_vehicle = camera_from_imu.inverse() * vehicle_from_camera.inverse();
  constexpr double kEarthRadiusM = 6378137.0;  // the devkit's
  double scale = 0;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  // The packets present in data/ (a copy may hold fewer than timestamps.txt lists), each at
  // the time of its line.
  std::vector<std::size_t> present;
  {
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(oxts_dir / "data", ec)) {
      const std::string stem = e.path().stem().string();
      if (e.path().extension() != ".txt" || stem.size() != 10 ||
          stem.find_first_not_of("0123456789") != std::string::npos) {
        continue;
      }
      const std::size_t index = std::stoul(stem);
      LN_CHECK_INPUT(index < times.size())
          << e.path().string() << ": packet " << index << " has no line in " << (oxts_dir / "timestamps.txt").string()
          << " (" << times.size() << " lines)";
      present.push_back(index);
    }
    std::sort(present.begin(), present.end());
    LN_CHECK_INPUT(!present.empty()) << (oxts_dir / "data").string() << ": no packets (NNNNNNNNNN.txt)";
  }
  std::vector<positioning::TrajectorySample> samples;
  double height = 0, last_t = 0, last_vu = std::numeric_limits<double>::quiet_NaN();
  for (const std::size_t i : present) {
    const fs::path packet = oxts_dir / "data" / (times[i].stem + ".txt");
    const std::string line = FirstDataLine(packet);
    const std::string where = packet.string() + ":1";
    std::vector<double> v;
    LN_CHECK_INPUT(LineNumbers(line, &v) && v.size() >= 6)
        << where << ": expected an OXTS packet (lat, lon, alt, roll, pitch, yaw, ...: 30 numbers)";
    const double lat = v[0], lon = v[1], alt = v[2];
    LN_CHECK_INPUT(std::abs(lat) < 85 && std::abs(lon) <= 180 && std::abs(alt) < 1e5)
        << where << ": latitude " << lat << ", longitude " << lon << ", altitude " << alt << " m out of range";
    if (samples.empty()) scale = std::cos(lat * kDeg);
    // The height: the INS's vertical velocity vu integrated, drawn to the altitude with a time
    // constant (KittiOxtsHeight); the altitude alone where a packet has no vu.
    const double t = times[i].t_s;
    const bool has_vu = v.size() > 10 && std::abs(v[10]) < 100;
    if (samples.empty() || !has_vu || !std::isfinite(last_vu)) {
      height = alt;
    } else {
      const double dt = t - last_t;
      height += 0.5 * (v[10] + last_vu) * dt;
      height += (alt - height) * std::clamp(dt / kOxtsAltitudeTimeConstantS, 0.0, 1.0);
    }
    last_t = t;
    last_vu = has_vu ? v[10] : std::numeric_limits<double>::quiet_NaN();
    Eigen::Isometry3d world_from_imu = Eigen::Isometry3d::Identity();
    world_from_imu.translation() =
        Eigen::Vector3d(scale * lon * M_PI * kEarthRadiusM / 180.0,
                        scale * kEarthRadiusM * std::log(std::tan((90.0 + lat) * M_PI / 360.0)), height);
    world_from_imu.linear() =
        (Eigen::AngleAxisd(v[5], Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(v[4], Eigen::Vector3d::UnitY()) *
         Eigen::AngleAxisd(v[3], Eigen::Vector3d::UnitX()))
            .toRotationMatrix();
    Eigen::Isometry3d world_from_vehicle = world_from_imu * imu_from_vehicle;
    if (samples.empty()) origin = world_from_vehicle.translation();
    world_from_vehicle.translation() -= origin;
    samples.push_back(SampleOf(world_from_vehicle, times[i].t_s));
  }
  return samples;
}

Eigen::Isometry3d KittiLidarInVehicle(const fs::path& calib_file, const Eigen::Isometry3d& vehicle_from_camera) {
  const auto entries = calib::ReadKeyValues(calib_file, ':');
  if (entries.count("Tr") > 0) {  // the odometry calib.txt: Velodyne to camera 0
    const std::vector<double> v = calib::TextNumbers(entries.at("Tr"), "Tr", calib_file, 12);
    return vehicle_from_camera * RigidFrom12(v, calib_file.string() + ": Tr");
  }
  LN_CHECK_INPUT(entries.count("R") > 0 && entries.count("T") > 0)
      << calib_file.string() << ": neither KITTI odometry's calib.txt (Tr) nor raw's calib_velo_to_cam.txt (R, T)";
  const Eigen::Isometry3d cam_from_velo = RigidFromKeys(entries, "R", "T", calib_file);
  return vehicle_from_camera * RectifyingRotation(calib_file.parent_path() / "calib_cam_to_cam.txt") * cam_from_velo;
}

FramePose FramePoseOf(const Eigen::Isometry3d& world_from_vehicle) {
  // R = Rz(-heading) Rx(pitch) Ry(roll): its Y column (the forward axis) is
  // (cos p sin h, cos p cos h, sin p), its last row (-cos p sin r, sin p, cos p cos r).
  const Eigen::Matrix3d r = world_from_vehicle.linear();
  FramePose p;
  p.x_m = world_from_vehicle.translation().x();
  p.y_m = world_from_vehicle.translation().y();
  p.z_m = world_from_vehicle.translation().z();
  p.pitch_rad = std::asin(std::clamp(r(2, 1), -1.0, 1.0));
  p.heading_rad = std::atan2(r(0, 1), r(1, 1));
  p.roll_rad = std::atan2(-r(2, 0), r(2, 2));
  return p;
}

}  // namespace lunarnav::mapping
