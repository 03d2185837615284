#include "sim/field_log.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "io/float_array_io.h"
#include "io/geotiff_io.h"
#include "io/json_io.h"
#include "mapping/frame_poses.h"
#include "positioning/posfilter.h"
#include "positioning/trajectory_io.h"
#include "telemetry/sensor_model.h"
#include "telemetry/telemetry_csv.h"
#include "util/testing.h"

namespace lunarnav::sim {
namespace {
namespace fs = std::filesystem;

constexpr double kDeg = M_PI / 180.0;

// A short field log at a quarter of the rig's resolution, on a coarser terrain grid.
FieldLogOptions SmallLog(int frames = 8) {
  FieldLogOptions o;
  o.stereo.width_px = 160;
  o.stereo.height_px = 120;
  o.stereo.focal_px = 185;
  o.stereo.rays_per_pixel = 1;
  o.stereo.terrain_cell_m = 0.04;
  o.stereo.frames = frames;
  o.stereo.interval_s = 0;  // the vehicle's
  o.stereo.show_progress = false;
  o.stereo.num_threads = 2;
  o.stereo.seed = 4;  // its start stands 22 cm below the terrain's datum
  return o;
}

std::string ReadBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

double WrapDeg(double deg) { return std::remainder(deg, 360.0); }

// Linear interpolation of a trajectory at t (angles as stored: continuous).
positioning::TrajectorySample At(const std::vector<positioning::TrajectorySample>& tr, double t) {
  auto it = std::upper_bound(tr.begin(), tr.end(), t,
                             [](double v, const positioning::TrajectorySample& s) { return v < s.t_s; });
  const std::size_t i = std::clamp<std::size_t>(static_cast<std::size_t>(it - tr.begin()), 1, tr.size() - 1);
  const auto& a = tr[i - 1];
  const auto& b = tr[i];
  const double f = (t - a.t_s) / (b.t_s - a.t_s);
  positioning::TrajectorySample s;
  s.t_s = t;
  s.x_m = a.x_m + f * (b.x_m - a.x_m);
  s.y_m = a.y_m + f * (b.y_m - a.y_m);
  s.z_m = a.z_m + f * (b.z_m - a.z_m);
  s.heading_rad = a.heading_rad + f * std::remainder(b.heading_rad - a.heading_rad, 2 * M_PI);
  s.pitch_rad = a.pitch_rad + f * (b.pitch_rad - a.pitch_rad);
  s.roll_rad = a.roll_rad + f * (b.roll_rad - a.roll_rad);
  return s;
}

TEST(RunFieldLogSimulation, TheCamerasAndTheTelemetryShareOneMotionOverOneGround) {
  util::ScopedTempDir dir;
  const FieldLogSummary summary = RunFieldLogSimulation(SmallLog(), dir.path());
  EXPECT_EQ(summary.frames, 8);
  for (const char* f : {"left/000007.png", "right/000000.png", "rig.json", "telemetry.csv", "sensors.json",
                        "frame_times.csv", "truth/poses.csv", "truth/trajectory.csv", "truth/trials.json",
                        "truth/faults.csv", "truth/terrain.tif", "truth/rocks.csv", "truth/xyz/000003.exr",
                        "summary.json"}) {
    EXPECT_TRUE(fs::exists(dir.path() / f)) << f;
  }
  const nlohmann::json s = io::ReadJson(dir.path() / "summary.json");
  EXPECT_EQ(s["subcommand"], "field-log");
  // The seed's start stands well off the terrain's datum: the shift to the start's frame matters.
  const double start_z = s["field_log"]["start_z_m"].get<double>();
  ASSERT_GT(std::abs(start_z), 0.05);

  // The frames' true poses are the telemetry's true trajectory at the frames' times.
  const std::vector<mapping::FramePose> frames = mapping::ReadPosesCsv(dir.path() / "truth" / "poses.csv");
  const std::vector<mapping::FramePose> times = mapping::ReadFrameTimes(dir.path() / "frame_times.csv");
  const auto truth = positioning::ReadTrajectoryCsv(dir.path() / "truth" / "trajectory.csv");
  ASSERT_EQ(frames.size(), 8u);
  ASSERT_EQ(times.size(), 8u);
  EXPECT_NEAR(truth.front().z_m, 0.0, 1e-9);
  double moved = 0, turned = 0;
  for (std::size_t k = 0; k < frames.size(); ++k) {
    EXPECT_EQ(frames[k].stem, times[k].stem);
    EXPECT_NEAR(frames[k].t_s, times[k].t_s, 1e-3);
    const auto p = At(truth, times[k].t_s);
    EXPECT_NEAR(frames[k].x_m, p.x_m, 0.002) << k;
    EXPECT_NEAR(frames[k].y_m, p.y_m, 0.002) << k;
    EXPECT_NEAR(frames[k].z_m, p.z_m, 0.01) << k;
    EXPECT_NEAR(WrapDeg((frames[k].heading_rad - p.heading_rad) / kDeg), 0.0, 0.05) << k;
    EXPECT_NEAR(frames[k].pitch_rad / kDeg, p.pitch_rad / kDeg, 0.5) << k;
    EXPECT_NEAR(frames[k].roll_rad / kDeg, p.roll_rad / kDeg, 0.5) << k;
    moved = std::max(moved, std::hypot(frames[k].x_m, frames[k].y_m));
    turned = std::max(turned, std::abs(WrapDeg(frames[k].heading_rad / kDeg)));
  }
  EXPECT_GT(moved, 2.5);  // 22 s at 0.15 m/s after the start's rest

  // What the cameras saw lies on the true terrain in the same frame: each frame's true points,
  // placed by its true pose, against terrain.tif's cell heights.
  const io::GeoRaster dem = io::ReadGeoTiff(dir.path() / "truth" / "terrain.tif");
  const cv::Mat& elevation = dem.bands.at(dem.BandIndex("elevation_m")).pixels;
  for (std::size_t k : {std::size_t{0}, frames.size() - 1}) {
    const io::ExrImage xyz = io::ReadExr(dir.path() / "truth" / "xyz" / (frames[k].stem + ".exr"));
    const Eigen::Isometry3d world_from_vehicle = frames[k].WorldFromVehicle();
    std::vector<double> errors;
    for (int r = 0; r < xyz.pixels.rows; r += 3) {
      for (int c = 0; c < xyz.pixels.cols; c += 3) {
        const cv::Vec3f v = xyz.pixels.at<cv::Vec3f>(r, c);
        if (!std::isfinite(v[0])) continue;
        const Eigen::Vector3d w = world_from_vehicle * Eigen::Vector3d(v[0], v[1], v[2]);
        const int col = static_cast<int>(std::floor((w.x() - dem.x_west_m) / dem.cell_m));
        const int row = static_cast<int>(std::floor((dem.y_north_m - w.y()) / dem.cell_m));
        if (col < 0 || row < 0 || col >= elevation.cols || row >= elevation.rows) continue;
        errors.push_back(std::abs(w.z() - elevation.at<float>(row, col)));
      }
    }
    ASSERT_GT(errors.size(), 500u);
    std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
    EXPECT_LT(errors[errors.size() / 2], 0.02) << "frame " << k;
  }
}

TEST(RunFieldLogSimulation, IdealSensorsDeadReckonTheCamerasPoses) {
  // Without sensor errors or slip, posfilter on the log's telemetry finds each pair where the
  // truth has it: the telemetry reads the motion the cameras were rendered from.
  util::ScopedTempDir dir;
  FieldLogOptions o = SmallLog(10);
  o.noise_scale = 0;
  o.slip_scale = 0;
  o.stereo.width_px = 32;  // the images do not matter here
  o.stereo.height_px = 24;
  o.stereo.focal_px = 37;
  RunFieldLogSimulation(o, dir.path());
  const telemetry::SensorModel model = telemetry::ReadSensorModel(dir.path() / "sensors.json");
  const telemetry::TelemetryLog log = telemetry::ReadTelemetryCsv(dir.path() / "telemetry.csv", model);
  positioning::PosfilterOptions options;
  options.mode = positioning::FilterMode::kZeroPhase;
  const positioning::PosfilterResult result = positioning::RunPosfilter(log, model, options);
  const std::vector<mapping::FramePose> frames = mapping::ReadPosesCsv(dir.path() / "truth" / "poses.csv");
  double sum_tilt2 = 0;
  for (const mapping::FramePose& f : frames) {
    const auto p = At(result.motion.trajectory, f.t_s);
    EXPECT_NEAR(p.x_m, f.x_m, 0.02) << f.stem;
    EXPECT_NEAR(p.y_m, f.y_m, 0.02) << f.stem;
    EXPECT_NEAR(p.z_m, f.z_m, 0.05) << f.stem;  // the smoothed pitch integrated
    EXPECT_NEAR(WrapDeg((p.heading_rad - f.heading_rad) / kDeg), 0.0, 0.3) << f.stem;
    sum_tilt2 += std::pow((p.pitch_rad - f.pitch_rad) / kDeg, 2) + std::pow((p.roll_rad - f.roll_rad) / kDeg, 2);
  }
  // Pitch and roll pass the paper's 0.25 Hz low-pass: the rocks under the wheels are smoothed.
  EXPECT_LT(std::sqrt(sum_tilt2 / (2.0 * frames.size())), 1.0);
}

TEST(RunFieldLogSimulation, TheSameSeedGivesTheSameLogAndAnotherSeedAnotherRoute) {
  util::ScopedTempDir a, b, c;
  FieldLogOptions o = SmallLog(3);
  o.stereo.width_px = 32;
  o.stereo.height_px = 24;
  o.stereo.focal_px = 37;
  RunFieldLogSimulation(o, a.path());
  o.stereo.num_threads = 1;
  RunFieldLogSimulation(o, b.path());
  for (const char* f : {"telemetry.csv", "frame_times.csv", "truth/poses.csv", "truth/trajectory.csv",
                        "left/000002.png", "sensors.json"}) {
    EXPECT_EQ(ReadBytes(a.path() / f), ReadBytes(b.path() / f)) << f;
  }
  o.stereo.seed = 5;
  RunFieldLogSimulation(o, c.path());
  EXPECT_NE(ReadBytes(a.path() / "truth/trajectory.csv"), ReadBytes(c.path() / "truth/trajectory.csv"));
}

TEST(FieldRouteCommands, TurnsStopBeforeTurningInPlaceAndLastPastTheLog) {
  FieldLogOptions o = SmallLog();
  int turns_in_place = 0, arcs = 0;
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    o.stereo.seed = seed;
    const std::vector<MotionCommand> route = FieldRouteCommands(o, 200.0);
    ASSERT_GE(route.size(), 2u);
    EXPECT_EQ(route.front().kind, MotionKind::kPause);
    EXPECT_EQ(route[1].kind, MotionKind::kStraight);  // the map starts ahead
    double time = 0;
    for (std::size_t i = 0; i < route.size(); ++i) {
      const MotionCommand& m = route[i];
      if (m.kind == MotionKind::kTurnInPlace) {
        ++turns_in_place;
        EXPECT_TRUE(m.stop_at_end);
        EXPECT_TRUE(route[i - 1].kind == MotionKind::kPause || route[i - 1].stop_at_end);
      }
      if (m.kind == MotionKind::kArc) ++arcs;
      time += m.kind == MotionKind::kPause ? m.duration_s
              : m.kind == MotionKind::kTurnInPlace ? std::abs(m.angle_deg) / m.turn_rate_dps
                                                   : m.PathLength() / m.speed_mps;
    }
    EXPECT_GT(time, 200.0 * 0.9);
  }
  EXPECT_GT(turns_in_place, 0);
  EXPECT_GT(arcs, 20);
  o.route = FieldRoute::kStraight;
  const std::vector<MotionCommand> straight = FieldRouteCommands(o, 100.0);
  ASSERT_EQ(straight.size(), 2u);
  EXPECT_GT(straight[1].PathLength(), 0.15 * 95);
}

TEST(RunFieldLogSimulation, RefusesWhatNoVehicleDoes) {
  util::ScopedTempDir dir;
  FieldLogOptions o = SmallLog(2);
  o.vehicle = FieldVehicle::kSkidSteer;
  o.bits = 7;
  EXPECT_THROW(RunFieldLogSimulation(o, dir.path()), std::invalid_argument);
  o = SmallLog(2);
  o.compass = false;  // the paper's vehicle has one
  EXPECT_THROW(RunFieldLogSimulation(o, dir.path()), std::invalid_argument);
  o = SmallLog(2);
  o.stereo.preset = "boxes";
  EXPECT_THROW(RunFieldLogSimulation(o, dir.path()), std::invalid_argument);
  o = SmallLog(2);
  o.speed_mps = -1;
  EXPECT_THROW(RunFieldLogSimulation(o, dir.path()), std::invalid_argument);
  EXPECT_TRUE(fs::is_empty(dir.path()));
}

}  // namespace
}  // namespace lunarnav::sim
