// Fuzz targets: every parser of outside input, through the project's own entry points. Each
// takes one input (the bytes of a file, or for formats of two files both, split at the first
// NUL byte) and returns whether the input parsed (true) or was refused with an InputError
// (false: a bad file is an exit code 3, not a bug). Anything else escapes: another exception, a crash,
// a sanitizer report. libFuzzer drives them (tests/fuzz/fuzz_main.cc, scripts/fuzz); the test
// corpus_test runs every one over its seed corpus and the inputs fuzzing once found
// (testdata/fuzz/TARGET/), in every build.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace lunarnav::fuzz {

using Target = bool (*)(const std::uint8_t* data, std::size_t size);

bool TelemetryCsv(const std::uint8_t* data, std::size_t size);  ///< posfilter's CSV, then screening
bool SensorJson(const std::uint8_t* data, std::size_t size);    ///< posfilter's --sensors
bool RigJson(const std::uint8_t* data, std::size_t size);       ///< every tool's --rig
bool VehicleJson(const std::uint8_t* data, std::size_t size);   ///< rig-check's vehicle file
/// calibrate --from: the first byte picks the format (opencv, ros, kalibr, middlebury, kitti).
bool RigImport(const std::uint8_t* data, std::size_t size);
/// Images: the first byte picks the reader and extension (PNG, TIFF, PGM as grey or colour,
/// PFM, EXR).
bool Image(const std::uint8_t* data, std::size_t size);
bool RequestsCsv(const std::uint8_t* data, std::size_t size);   ///< stereo-batch --requests
bool TrajectoryCsv(const std::uint8_t* data, std::size_t size); ///< evaluate's trajectories
/// terrain-map's and plan-windows' --poses (and a map's frames.csv), then the planner on the
/// poses read; or (first byte odd) a frame-times file.
bool PosesCsv(const std::uint8_t* data, std::size_t size);
/// shard-merge: two shard summaries (split at the first NUL) merged.
bool ShardSummary(const std::uint8_t* data, std::size_t size);
/// KITTI's trajectories (--trajectory, --frame-times): the first byte picks a pose file with its
/// times.txt (split at the first NUL), a frame-times file, an oxts/ packet with its timestamps
/// (split likewise), or a LiDAR calibration (evaluate map --lidar-calib).
bool KittiTrajectory(const std::uint8_t* data, std::size_t size);
/// evaluate map --lidar's clouds: the first byte picks .bin (KITTI), .pcd or .ply.
bool PointCloud(const std::uint8_t* data, std::size_t size);
/// A map's rasters: the first byte picks plan-windows --map's reading of elevation.tif or a
/// stored state's (terrain-map --merge, --resume; plan-windows' exact times).
bool MapRaster(const std::uint8_t* data, std::size_t size);
/// A trajectory (posfilter's CSV or TUM, the first byte picks) and frame times, split at a NUL.
bool TrajectoryFrameTimes(const std::uint8_t* data, std::size_t size);
/// A stereo-batch sidecar as --resume reads it (its outputs present, its own options the run's).
bool BatchSidecar(const std::uint8_t* data, std::size_t size);

struct NamedTarget {
  const char* name;  ///< also the folder of its corpus under testdata/fuzz
  Target run;
};
const std::vector<NamedTarget>& AllTargets();

}  // namespace lunarnav::fuzz
