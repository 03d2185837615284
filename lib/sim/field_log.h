// `simulate field-log`: both halves of one simulated drive, as a rover records them: the
// stereo pairs of its mast cameras and the raw telemetry of its state sensors (encoders, gyro,
// inclinometers, optionally a compass), of the same vehicle motion over the same rocky
// terrain, with the frames' times on the telemetry's clock and the exact truth (Krotkov &
// Hebert sec. 3 and 4 together). docs/simulate.md#field-log describes options and outputs.
//
// The vehicle drives sim::DriveRover's model over the stereo renderer's sim::Terrain; its
// body rests on the ground under its wheels (each wheel a disc of radius wheel_radius_m
// riding over the surface), so the pitch and roll the inclinometers read, the cameras' view
// and the true poses are one attitude. World frame: x east, y north, z up, origin at the start
// pose's vehicle frame (heading north): where a rover's own map starts.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "sim/rover_motion.h"
#include "sim/rover_telemetry.h"
#include "sim/stereo_sim.h"
#include "sim/terrain.h"
#include "sim/vehicle_pose.h"

namespace lunarnav::sim {

/// The vehicles a field log can come from.
enum class FieldVehicle {
  /// The paper's Ratler: 10- or 7-bit telemetry at 10 Hz of four encoders, a flux-gate
  /// compass, inclinometers (a pendulum: acceleration reads as tilt) and a turn-rate gyro;
  /// trial B's tuned motion control; 0.15 m/s and 10 deg/s, a stereo pair every 3.2 s.
  kPaper,
  /// The small skid-steered rover of `simulate telemetry --preset skid-steer`: MEMS gyro and
  /// accelerometer tilt at 50 Hz, encoders at 10 Hz, no compass unless asked; 0.3 m/s and
  /// 20 deg/s, a stereo pair every second.
  kSkidSteer
};
std::string ToString(FieldVehicle vehicle);
/// "paper" or "skid-steer"; std::invalid_argument otherwise.
FieldVehicle FieldVehicleFromString(const std::string& name);

enum class FieldRoute {
  kStraight,  ///< Straight ahead after the start pause.
  kTurns      ///< Legs of straights, arcs and turns in place, with stops (the default).
};
std::string ToString(FieldRoute route);
FieldRoute FieldRouteFromString(const std::string& name);

struct FieldLogOptions {
  /// The rig, the scene and the rendering as `simulate stereo` (frames, interval_s, faults,
  /// seed, threads, the realism switches). Its speed_mps and turn_radius_m are not used:
  /// the route moves the vehicle. interval_s <= 0: the vehicle's default.
  StereoSimOptions stereo;
  FieldVehicle vehicle = FieldVehicle::kPaper;
  FieldRoute route = FieldRoute::kTurns;
  std::optional<bool> compass;    ///< Default: the paper vehicle has one, the skid-steer not.
  double speed_mps = 0;           ///< Cruise speed, (0, 2] m/s; 0: the vehicle's default.
  double turn_rate_dps = 0;       ///< Turns in place, (0, 90] deg/s; 0: the vehicle's default.
  double slope_deg = 2.0;         ///< Mean slope of the terrain, [0, 20) deg.
  double slope_azimuth_deg = 30;  ///< Its direction of steepest ascent, clockwise from north.
  double start_rest_s = 5.0;      ///< At rest before the first motion (the gyro's bias), >= 1 s.
  /// The first frame's time on the telemetry clock (frames then every interval_s); the
  /// cameras' clock ticks apart from the telemetry's, so frames fall between its samples.
  double first_frame_s = 2.037;
  int bits = 10;                  ///< The paper vehicle's telemetry: 10 or 7 bits.
  double noise_scale = 1.0;       ///< Multiplies every sensor error, [0, 10].
  double slip_scale = 1.0;        ///< Multiplies every wheel slip and path wander term, [0, 10].
  std::vector<FaultSpec> telemetry_faults;

  /// The vehicle's defaults filled in: speed, turn rate, interval, compass.
  FieldLogOptions Resolved() const;
  void Validate() const;  ///< std::invalid_argument naming the option.
  nlohmann::json ToJson() const;
};

/// The route of a field log: the commands, starting with a pause of options.start_rest_s, long
/// enough for `duration_s` (from the seed's "route" stream).
std::vector<MotionCommand> FieldRouteCommands(const FieldLogOptions& options, double duration_s);

/// A field log in memory.
struct FieldLog {
  FieldLogOptions options;            ///< Resolved.
  RoverTelemetry telemetry;           ///< Scenario (as driven), drive (truth), raw log, faults.
  std::vector<VehiclePose> frame_poses;  ///< World poses at the frame times, z relative to the start.
  std::vector<double> frame_times_s;  ///< On the telemetry clock.
  double start_z_m = 0;               ///< The start's vehicle-frame height on the terrain's datum.
  double wheel_radius_m = 0;
};

struct FieldLogSummary {
  int frames = 0;
  std::size_t telemetry_rows = 0;
  double distance_m = 0, duration_s = 0, seconds = 0;
  std::filesystem::path summary_path;
  std::string BriefReport() const;
};

/// Simulates and writes a field log into `output_dir`: left/, right/, rig.json (the raw rig, as
/// `simulate stereo`), telemetry.csv and sensors.json (as `simulate telemetry`),
/// frame_times.csv (stem,t_s), and truth/: poses.csv (the frames' true poses), trajectory.csv
/// (every telemetry sample's, simulate telemetry's truth.csv), trials.json, faults.csv,
/// terrain.tif, rocks.csv, disparity/, xyz/, labels/, boxes.json; summary.json. Every file atomic.
/// @throws std::invalid_argument for bad options or an unusable output directory.
FieldLogSummary RunFieldLogSimulation(const FieldLogOptions& options, const std::filesystem::path& output_dir,
                                      const nlohmann::json& invocation = nullptr);

}  // namespace lunarnav::sim
