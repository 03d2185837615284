// Simulated rover telemetry with exact ground truth (`simulate telemetry`): the commanded
// trials of Krotkov & Hebert sec. 4.2 (Figure 7) and a long traverse, driven by a
// skid-steered rover over a height field and read by its sensors (sec. 4.1).
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "sim/rover_motion.h"
#include "sim/rover_sensors.h"
#include "sim/telemetry_faults.h"
#include "sim/ground_surface.h"
#include "telemetry/sensor_model.h"

namespace lunarnav::sim {

/// The paper's setups (docs/simulate.md describes each).
enum class TelemetryPreset {
  kTrialA,   ///< Straight lines on a slag heap, motion control not yet tuned.
  kTrialB,   ///< Straight lines and turns in place on the slag heap, tuned motion control.
  kTrialC,   ///< Curved arcs on a flat, grassy field.
  kTraverse,  ///< A long drive over rough, sloping terrain, stopping now and then.
  /// A small skid-steered rover with MEMS sensors, like the logs of real rovers: encoders at
  /// 10 Hz, gyro and accelerometer-derived pitch and roll at 50 Hz, abrupt turns; no compass.
  kSkidSteer,
  kSkidSteerCompass  ///< The same with a compass at 10 Hz.
};
std::string ToString(TelemetryPreset preset);
/// Names for the command line: "trial-a", "trial-b", "trial-c", "traverse", "skid-steer",
/// "skid-steer-compass".
std::map<std::string, TelemetryPreset> TelemetryPresetNames();

/// Everything a preset fixes: ground, vehicle, sensors and the commanded motions.
struct TelemetryScenario {
  std::string name, description;
  GroundSurfaceOptions ground;
  RoverOptions rover;
  SensorErrorOptions sensor_errors;
  double initial_heading_deg = 0;
  std::vector<MotionCommand> commands;
  std::optional<double> duration_s;  ///< Default log length; unset: until the commands end.
  /// The skid-steer presets: MEMS sensors (MemsRoverSensorModel) sampled at imu_rate_hz, the
  /// encoders (and the compass) only every encoder_decimation-th row; `compass`: whether
  /// the rover has one.
  bool mems = false;
  bool compass = true;
  double imu_rate_hz = 50.0;
  int encoder_decimation = 5;
  nlohmann::json ToJson() const;
};

/// The scenario of a preset. The traverse's route (and every preset's initial heading for
/// the traverse) comes from `seed`; it is long enough for `duration_s` (default 1800 s).
TelemetryScenario PresetScenario(TelemetryPreset preset, std::uint64_t seed, std::optional<double> duration_s);

struct RoverTelemetryOptions {
  TelemetryPreset preset = TelemetryPreset::kTrialA;
  std::uint64_t seed = 1;             ///< Every output is a function of the options and this.
  int bits = 10;                      ///< Digitisation, 6..16: 10, or 7 as in old telemetry.
  std::optional<double> duration_s;   ///< Log length, s, > 0; default: the preset's.
  /// Samples per second, [1, 1000]. The skid-steer presets have their sensors' own rates
  /// (encoders 10 Hz, IMU 50 Hz) and take only the default.
  double rate_hz = 10.0;
  double noise_scale = 1.0;           ///< Multiplies every sensor error, [0, 10]; 0 = ideal sensors.
  double slip_scale = 1.0;            ///< Multiplies every slip and wander term, [0, 10]; 0 = none.
  std::vector<FaultSpec> faults;
  void Validate() const;
  nlohmann::json ToJson() const;
};

/// A simulated run: truth, raw log and the record of its faults.
struct RoverTelemetry {
  TelemetryScenario scenario;           ///< As driven (scales applied).
  telemetry::SensorModel sensor_model;  ///< What sensors.json says.
  RoverDrive drive;                     ///< Ground truth, one sample per row of the log.
  SensorErrorDraws draws;
  RawTelemetry raw;                     ///< With the faults.
  std::vector<InjectedFault> faults;
  /// rows, duration_s, distance_m, commands, trials, faults by kind, final pose.
  nlohmann::json CountsJson() const;
  std::string BriefReport() const;
};

/// Simulates the run the options describe. @throws std::invalid_argument for bad options.
RoverTelemetry SimulateRoverTelemetry(const RoverTelemetryOptions& options);

/// The sensor half of SimulateRoverTelemetry: with `run->scenario` and `run->drive` given
/// (sampled at the scenario's IMU rate for MEMS scenarios, else at options.rate_hz), fills the
/// sensor model, the raw log (encoders and compass decimated for MEMS), the error draws and
/// the injected faults (options.seed, bits, faults).
void SenseDrive(const RoverTelemetryOptions& options, RoverTelemetry* run);

/// truth.csv: the ground truth per sample, in the columns of posfilter's trajectory.csv
/// (t_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg,speed_mps: positioning::ReadTrajectoryCsv
/// reads it) followed by pitch_left_deg,pitch_right_deg,turn_rate_dps,accel_mps2,distance_m
/// and each wheel's rim travel wheel_fl_m,wheel_fr_m,wheel_rl_m,wheel_rr_m. Written
/// atomically; 6 decimals.
void WriteTruthCsv(const std::filesystem::path& path, const std::vector<RoverSample>& samples);

/// trials.json: each commanded motion from rest to rest with its true start and end pose and
/// what a tape measure and a protractor would give (straight-line distance, heading change).
nlohmann::json TrialsJson(const RoverTelemetry& run);

/// Writes telemetry.csv, sensors.json, truth.csv, trials.json and faults.csv into `dir`
/// (created), each atomically. summary.json is the caller's (it knows the command line).
/// With `truth_dir`, the truth goes there instead: trajectory.csv (truth.csv's content),
/// trials.json, faults.csv.
void WriteRoverTelemetry(const std::filesystem::path& dir, const RoverTelemetry& run,
                         const RoverTelemetryOptions& options, const std::filesystem::path& truth_dir = {});

}  // namespace lunarnav::sim
