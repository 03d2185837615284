#include "fuzz/targets.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string_view>

#include <Eigen/Geometry>

#include "calib/rig_import.h"
#include "calib/stereo_rig_io.h"
#include "calib/vehicle.h"
#include "io/float_array_io.h"
#include "io/geotiff_io.h"
#include "io/image_io.h"
#include "io/shard_merge.h"
#include "io/point_cloud_io.h"
#include "mapping/frame_poses.h"
#include "mapping/kitti_trajectory.h"
#include "mapping/terrain_grid.h"
#include "mapping/window_planner.h"
#include "positioning/posfilter.h"
#include "positioning/trajectory_io.h"
#include "stereo/batch.h"
#include "stereo/window_requests.h"
#include "telemetry/screening.h"
#include "telemetry/sensor_model.h"
#include "telemetry/telemetry_csv.h"
#include "util/errors.h"

namespace lunarnav::fuzz {
namespace {
namespace fs = std::filesystem;

// A folder of this process's own for the files the readers are given.
// Removed when the process exits normally (a crash leaves it, with the input that did it).
struct Scratch {
  fs::path dir = fs::temp_directory_path() / ("lunarnav-fuzz-" + std::to_string(::getpid()));
  Scratch() { fs::create_directories(dir); }
  ~Scratch() {
    std::error_code ignored;
    fs::remove_all(dir, ignored);
  }
};

const fs::path& ScratchDir() {
  static const Scratch scratch;
  return scratch.dir;
}

// An empty directory `name` in the scratch directory (what an earlier input left there removed).
fs::path FreshScratchDir(const std::string& name) {
  const fs::path dir = ScratchDir() / name;
  std::error_code ignored;
  fs::remove_all(dir, ignored);
  fs::create_directories(dir);
  return dir;
}

fs::path WriteScratch(const std::string& name, std::string_view bytes) {
  const fs::path path = ScratchDir() / name;
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  return path;
}

std::string_view Bytes(const std::uint8_t* data, std::size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

// Two files in one input: split at the first NUL byte (none: the same bytes for both).
std::pair<std::string_view, std::string_view> SplitTwo(std::string_view bytes) {
  const std::size_t nul = bytes.find('\0');
  if (nul == std::string_view::npos) return {bytes, bytes};
  return {bytes.substr(0, nul), bytes.substr(nul + 1)};
}

// Runs a reader: a refusal of the input (InputError) is the expected way to fail.
template <typename F>
bool Refusing(F&& read) {
  try {
    read();
    return true;
  } catch (const InputError&) {
    return false;
  }
}

// posfilter's reference sensor model (the Ratler's, a compass and inclinometers included).
const telemetry::SensorModel& Model() {
  static const telemetry::SensorModel model =
      telemetry::ReadSensorModel(fs::path(LUNARNAV_TESTDATA_DIR) / "telemetry" / "ratler_sensors.json");
  return model;
}

}  // namespace

bool TelemetryCsv(const std::uint8_t* data, std::size_t size) {
  return Refusing([&] {
    const telemetry::TelemetryLog log = telemetry::ParseTelemetryCsv(Bytes(data, size), "fuzz.csv", Model());
    telemetry::ScreenTelemetry(log, Model(), telemetry::ScreeningOptions{});
    // The whole pipeline on what parses: filters, the heading filter, the attitude's smoother
    // (which holds rows until its look-ahead comes) and the dead reckoning, streamed in small
    // blocks so that the look-ahead crosses them.
    positioning::PosfilterOptions options;
    options.block_rows = 7;
    positioning::RunPosfilter(log, Model(), options);
  });
}

bool SensorJson(const std::uint8_t* data, std::size_t size) {
  const fs::path path = WriteScratch("sensors.json", Bytes(data, size));
  return Refusing([&] { telemetry::ReadSensorModel(path); });
}

bool RigJson(const std::uint8_t* data, std::size_t size) {
  const fs::path path = WriteScratch("rig.json", Bytes(data, size));
  return Refusing([&] { calib::ReadStereoRig(path); });
}

bool VehicleJson(const std::uint8_t* data, std::size_t size) {
  const fs::path path = WriteScratch("vehicle.json", Bytes(data, size));
  return Refusing([&] { calib::ReadVehicleSpec(path); });
}

bool RigImport(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return false;
  const std::string_view bytes = Bytes(data + 1, size - 1);
  const calib::MastPose mast;
  switch (data[0] % 5) {
    case 0: {
      const auto [intrinsics, extrinsics] = SplitTwo(bytes);
      const fs::path a = WriteScratch("intrinsics.yml", intrinsics), b = WriteScratch("extrinsics.yml", extrinsics);
      return Refusing([&] { calib::ReadOpenCvCalibration(a, b, 640, 480, 0.025, mast); });
    }
    case 1: {
      const auto [left, right] = SplitTwo(bytes);
      const fs::path a = WriteScratch("left.yaml", left), b = WriteScratch("right.yaml", right);
      return Refusing([&] { calib::ReadRosCameraInfoPair(a, b, mast); });
    }
    case 2: {
      const fs::path path = WriteScratch("camchain.yaml", bytes);
      return Refusing([&] { calib::ReadKalibrCamchain(path, mast); });
    }
    case 3: {
      const fs::path path = WriteScratch("calib.txt", bytes);
      return Refusing([&] { calib::ReadMiddleburyCalib(path, mast); });
    }
    default: {
      const fs::path path = WriteScratch("calib_cam_to_cam.txt", bytes);
      return Refusing([&] {
        calib::ReadKittiCalib(path, mast, calib::KittiPair::kColour, std::pair<int, int>{1242, 375});
      });
    }
  }
}

bool Image(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return false;
  const std::string_view bytes = Bytes(data + 1, size - 1);
  // Fuzzed headers claim large sizes: keep what a reader may allocate small.
  io::SetMaxImagePixels(1 << 20);
  switch (data[0] % 6) {
    case 0: {
      const fs::path path = WriteScratch("image.png", bytes);
      return Refusing([&] {
        io::SignificantBits bits;
        io::ReadGreyImage(path, &bits);
      });
    }
    case 1: {
      const fs::path path = WriteScratch("image.tif", bytes);
      return Refusing([&] { io::ReadImage(path); });
    }
    case 2: {
      const fs::path path = WriteScratch("image.pgm", bytes);
      return Refusing([&] { io::ReadGreyImage(path); });
    }
    case 3: {
      const fs::path path = WriteScratch("image.png", bytes);
      return Refusing([&] { io::ReadImage(path); });
    }
    case 4: {
      const fs::path path = WriteScratch("disparity.pfm", bytes);
      return Refusing([&] { io::ReadPfm(path); });
    }
    default: {
      const fs::path path = WriteScratch("xyz.exr", bytes);
      return Refusing([&] { io::ReadExr(path); });
    }
  }
}

bool RequestsCsv(const std::uint8_t* data, std::size_t size) {
  const fs::path path = WriteScratch("requests.csv", Bytes(data, size));
  return Refusing([&] { stereo::ReadWindowRequests(path); });
}

bool TrajectoryCsv(const std::uint8_t* data, std::size_t size) {
  const fs::path path = WriteScratch("trajectory.csv", Bytes(data, size));
  return Refusing([&] { positioning::ReadTrajectoryCsv(path); });
}

bool PosesCsv(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return false;
  const fs::path path = WriteScratch("poses.csv", Bytes(data + 1, size - 1));
  if (data[0] % 2 == 1) return Refusing([&] { mapping::ReadFrameTimes(path); });
  return Refusing([&] {
    std::vector<mapping::FramePose> poses = mapping::ReadPosesCsv(path);
    if (poses.size() > 1000) poses.resize(1000);  // the planner's cost, not its checks, grows with more
    mapping::PlanWindows(poses, calib::VehicleSpec(), mapping::WindowPlannerOptions{});
  });
}

bool ShardSummary(const std::uint8_t* data, std::size_t size) {
  const auto [first, second] = SplitTwo(Bytes(data, size));
  const fs::path dir = FreshScratchDir("shards");
  WriteScratch("shards/summary.shard-0-of-2.json", first);
  WriteScratch("shards/summary.shard-1-of-2.json", second);
  io::ShardMergeOptions options;
  options.num_threads = 1;
  options.relist = [](const std::string&, const fs::path&) { return std::optional<std::vector<std::string>>(); };
  return Refusing([&] { io::MergeShardSummaries(dir, options, nlohmann::json::object()); });
}

bool KittiTrajectory(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return false;
  const std::string_view bytes = Bytes(data + 1, size - 1);
  // A level camera 1.65 m up, as KITTI's: the vehicle's pose from the camera's.
  const Eigen::Isometry3d vehicle_from_camera =
      Eigen::Translation3d(-0.27, 0, 1.65) * Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitX());
  switch (data[0] % 4) {
    case 0: {  // a pose file at the times of a times.txt: the two files split at the first NUL
      const auto [poses, times] = SplitTwo(bytes);
      const fs::path a = WriteScratch("poses.txt", poses), b = WriteScratch("times.txt", times);
      return Refusing([&] { mapping::ReadKittiPoseTrajectory(a, b, vehicle_from_camera); });
    }
    case 1: {  // frame times (times.txt or timestamps.txt)
      const fs::path path = WriteScratch("timestamps.txt", bytes);
      return Refusing([&] { mapping::ReadKittiFrameTimes(path); });
    }
    case 2: {  // a raw drive's oxts/ with one packet and its timestamps, beside identity calibrations
      const auto [packet, times] = SplitTwo(bytes);
      const fs::path drive = ScratchDir() / "drive";
      std::error_code ignored;
      fs::remove_all(drive, ignored);
      fs::create_directories(drive / "oxts" / "data");
      WriteScratch("drive/calib_imu_to_velo.txt", "R: 1 0 0 0 1 0 0 0 1\nT: 0 0 0\n");
      WriteScratch("drive/calib_velo_to_cam.txt", "R: 0 -1 0 0 0 -1 1 0 0\nT: 0 0 0\n");
      WriteScratch("drive/calib_cam_to_cam.txt", "R_rect_00: 1 0 0 0 1 0 0 0 1\n");
      WriteScratch("drive/oxts/data/0000000000.txt", packet);
      WriteScratch("drive/oxts/timestamps.txt", times);
      return Refusing([&] { mapping::ReadKittiOxtsTrajectory(drive / "oxts", vehicle_from_camera); });
    }
    default: {  // the LiDAR's mounting: an odometry calib.txt or a calib_velo_to_cam.txt
      const fs::path path = WriteScratch("calib.txt", bytes);
      return Refusing([&] { mapping::KittiLidarInVehicle(path, vehicle_from_camera); });
    }
  }
}

bool PointCloud(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return false;
  static const char* const kNames[] = {"sweep.bin", "cloud.pcd", "cloud.ply"};
  const fs::path path = WriteScratch(kNames[data[0] % 3], Bytes(data + 1, size - 1));
  return Refusing([&] { io::ReadPointCloud(path); });
}

// A map directory's rasters (GeoTIFF, or whatever GDAL would open): the first byte picks
// plan-windows' reading of elevation.tif, or terrain-map's (and plan-windows') reading of a
// stored state.
bool MapRaster(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return false;
  const std::string_view bytes = Bytes(data + 1, size - 1);
  const fs::path dir = FreshScratchDir("map");
  WriteScratch("map/elevation.tif", bytes);
  WriteScratch("map/state.tif", bytes);
  if (data[0] % 2 == 0) return Refusing([&] { mapping::ReadMapElevation(dir, false); });
  return Refusing([&] { mapping::TerrainGrid::FromStateRaster(io::ReadGeoTiff(dir / "state.tif"), "state.tif"); });
}

// A trajectory (posfilter's CSV, or TUM) and a frame-times file, split at the first NUL: the
// poses every tool's --trajectory --frame-times reads.
bool TrajectoryFrameTimes(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return false;
  const auto [trajectory, times] = SplitTwo(Bytes(data + 1, size - 1));
  const fs::path a = WriteScratch(data[0] % 2 == 0 ? "trajectory.csv" : "trajectory.tum", trajectory);
  const fs::path b = WriteScratch("frame_times.csv", times);
  // As the tools read it: the frame times beside it (KITTI's pose files take their times from
  // there) and a rig's left camera 1.65 m over the vehicle's base, looking ahead (camera x
  // right, y down, z forward), which KITTI's camera poses need.
  mapping::TrajectoryContext context;
  context.frame_times = b;
  Eigen::Matrix3d vehicle_from_camera_rotation;
  vehicle_from_camera_rotation << 1, 0, 0, 0, 0, 1, 0, -1, 0;
  context.vehicle_from_camera = Eigen::Translation3d(0, 0, 1.65) * Eigen::Isometry3d(vehicle_from_camera_rotation);
  return Refusing([&] {
    std::vector<mapping::FramePose> frames = mapping::ReadFrameTimes(b);
    if (frames.size() > 1000) frames.resize(1000);
    for (const mapping::FramePose& p : mapping::InterpolateTrajectory(a, frames, context)) p.Validate(a.string());
  });
}

// A stereo-batch sidecar as --resume reads it: the pair's outputs present (empty files), the
// run's options those the sidecar records; when the pair counts as complete, the batch's
// summary reads its result.
bool BatchSidecar(const std::uint8_t* data, std::size_t size) {
  const fs::path dir = FreshScratchDir("batch");
  stereo::BatchOptions batch;
  const stereo::PairOutputPaths paths = stereo::OutputPathsFor(dir, "frame0000");
  for (const fs::path& p : {paths.disparity, paths.confidence, paths.rejections}) {
    fs::create_directories(p.parent_path());
    WriteScratch(fs::relative(p, ScratchDir()).string(), "");
  }
  WriteScratch(fs::relative(paths.sidecar, ScratchDir()).string(), Bytes(data, size));
  const nlohmann::json parsed = nlohmann::json::parse(Bytes(data, size), nullptr, false);
  const nlohmann::json options = parsed.is_object() && parsed.contains("options") ? parsed["options"] : nlohmann::json();
  nlohmann::json sidecar;
  if (!stereo::OutputsComplete(batch, paths, options, &sidecar)) return false;
  const nlohmann::json& result = sidecar["result"];
  long long total = result.value("pixels_evaluated", 0LL) + result.value("pixels_accepted", 0LL) +
                    result.value("points", 0LL);
  if (result.contains("bit_depth")) total += result["bit_depth"].get<int>();
  return total >= 0;
}

const std::vector<NamedTarget>& AllTargets() {
  static const std::vector<NamedTarget> targets = {
      {"telemetry_csv", TelemetryCsv}, {"sensor_json", SensorJson},   {"rig_json", RigJson},
      {"vehicle_json", VehicleJson},   {"rig_import", RigImport},     {"image", Image},
      {"requests_csv", RequestsCsv},   {"trajectory_csv", TrajectoryCsv}, {"poses_csv", PosesCsv},
      {"shard_summary", ShardSummary}, {"kitti_trajectory", KittiTrajectory}, {"point_cloud", PointCloud},
      {"map_raster", MapRaster},       {"trajectory_frame_times", TrajectoryFrameTimes},
      {"batch_sidecar", BatchSidecar}};
  return targets;
}

}  // namespace lunarnav::fuzz
