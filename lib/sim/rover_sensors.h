// The rover's state sensors (Krotkov & Hebert sec. 4.1) read from a simulated drive: four
// drive encoders, a flux-gate compass, three inclinometers and a turn-rate gyro, each with
// its own errors, digitised to the raw integer counts of a telemetry log.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "sim/rover_motion.h"
#include "telemetry/sensor_model.h"

namespace lunarnav::sim {

/// The sensors' errors. Biases and the gyro's scale error are drawn once per run from
/// normal distributions with the given RMS; the rest are processes in time.
struct SensorErrorOptions {
  // Flux-gate compass.
  double compass_bias_deg = 1.0;          ///< RMS of the constant bias (mounting, declination).
  /// RMS of the fast noise: white noise high-passed at compass_noise_corner_hz, so most of
  /// its power lies above the paper's 0.25 Hz cut-off.
  double compass_noise_deg = 2.0;
  double compass_noise_corner_hz = 0.25;  ///< > 0.
  double compass_wander_deg = 0.5;        ///< RMS of slow magnetic disturbances (Gauss-Markov).
  double compass_wander_tau_s = 30.0;     ///< Their correlation time, > 0.
  /// Dynamic transients: degrees of deflection per deg/s of turn rate, per deg/s^2 of turn
  /// acceleration and per m/s^2 of acceleration, smoothed with a time constant
  /// compass_transient_tau_s. The turn term is negative: the damping fluid swirls round with
  /// a turn and drags the gimballed sensor along, so the compass reads behind the true
  /// heading while the rover turns (on top of the noise filter's own lag; the Kalman filter
  /// of sec. 4.1 exists because of this). The other terms are the jolts of the drive motors
  /// starting and stopping.
  double compass_turn_deg_per_dps = -1.5;
  double compass_turn_accel_deg_per_dps2 = 0.5;
  double compass_accel_deg_per_mps2 = 5.0;
  double compass_transient_tau_s = 1.0;   ///< >= 0.
  // Turn-rate gyro.
  double gyro_bias_dps = 1.0;             ///< RMS of the constant bias.
  double gyro_bias_walk_dps_per_sqrt_s = 0.002;  ///< Random walk of the bias.
  double gyro_noise_dps = 0.3;            ///< White noise, RMS per sample.
  double gyro_scale_error = 0.02;         ///< RMS of the scale-factor error (fraction).
  /// Bias instability of a MEMS gyro: a Gauss-Markov bias of this RMS and correlation time
  /// on top of the constant bias and the random walk (0: none).
  double gyro_bias_instability_dps = 0.0;
  double gyro_bias_instability_tau_s = 100.0;  ///< > 0.
  // Inclinometers (left body pitch, right body pitch, roll).
  double tilt_bias_deg = 0.2;             ///< RMS of each sensor's constant bias.
  double tilt_noise_deg = 0.3;            ///< White noise, RMS per sample.
  double tilt_vibration_deg_per_mps = 0.3;  ///< Extra white noise per m/s of speed (rough ground).
  /// An inclinometer reads the direction of gravity minus acceleration: pitch reads
  /// atan(a / g) high while accelerating, roll atan(v w / g) towards the outside of a turn.
  /// 1 is that physics; 0 removes it.
  double tilt_accel_gain = 1.0;
  double tilt_tau_s = 0.3;                ///< The pendulum's lag on those transients, >= 0.

  /// Every magnitude multiplied by `scale` (0: ideal sensors that read their quantity
  /// exactly, up to digitisation).
  SensorErrorOptions Scaled(double scale) const;
  void Validate() const;
  nlohmann::json ToJson() const;
};

/// The per-run draws of SensorErrorOptions (recorded in summary.json).
struct SensorErrorDraws {
  double compass_bias_deg = 0, gyro_bias_dps = 0, gyro_scale_error = 0;
  double pitch_left_bias_deg = 0, pitch_right_bias_deg = 0, roll_bias_deg = 0;
  std::array<std::int64_t, 4> encoder_initial_counts{};  ///< Counters at the start.
  nlohmann::json ToJson() const;
};

/// The sensor model of the simulated rover, as written to sensors.json: that of a Ratler-like
/// rover at 10 bits (the values of testdata/telemetry/ratler_sensors.json: 256 counts per
/// revolution of 0.25 m wheels on 10-bit counters, compass 360 deg, inclinometers +-45 deg,
/// gyro +-60 deg/s over the counts), with the right-side encoders counting down when driving
/// forward (their motors are mounted mirrored: sign -1). Other bit depths are the same
/// sensors read with fewer bits (telemetry::SensorModel::OverrideBits).
telemetry::SensorModel SimulatedSensorModel(int bits);

/// The sensor model of a small skid-steered rover with MEMS sensors (the `skid-steer`
/// presets): 10-bit wrapping encoder counters, 1024 counts per revolution of 0.11 m wheels,
/// the left wheels counting down when driving forward (sign -1); a MEMS gyro of +-1 rad/s
/// over 10 bits; pitch (column `pitch`, the pitch_left channel) and roll derived from an
/// accelerometer, +-30 deg over 10 bits; with `compass`, a 10-bit compass over 360 deg. The
/// sensor file also states the sensors' noise (noise_rms) and the vehicle's limits
/// (docs/formats.md): what screening derives its thresholds from.
telemetry::SensorModel MemsRoverSensorModel(bool compass);

/// A cell with no sample.
inline constexpr std::int64_t kEmptyCell = std::numeric_limits<std::int64_t>::min();

/// A raw telemetry log in memory: integer time stamps and counts, exactly as written.
struct RawTelemetry {
  std::vector<std::int64_t> t_us;  ///< Time stamps, microseconds.
  /// Counts per row, indexed by static_cast<int>(telemetry::Channel); kEmptyCell = missing.
  std::vector<std::array<std::int64_t, telemetry::kNumChannels>> counts;
  std::size_t size() const { return t_us.size(); }
};

/// Line of telemetry.csv holding row `row` (0-based): two comment lines and the header
/// come first.
inline long TelemetryCsvLine(std::size_t row) { return static_cast<long>(row) + 4; }

/// An analog reading (radians; rad/s for the gyro) as the channel's count: rounded to the
/// nearest count and clamped to [0, 2^bits - 1], or for the compass wrapped modulo 2^bits.
std::int64_t DigitiseAnalog(const telemetry::ChannelModel& model, double value_rad, bool wraps);
/// A wheel's rim travel (metres, forward positive) as its encoder's count: whole counts
/// turned (floor), times the channel's sign, from `initial_count`, modulo 2^counter_bits.
std::int64_t DigitiseEncoder(const telemetry::ChannelModel& model, double travel_m, std::int64_t initial_count);

/// Reads every sensor at every sample of `samples` and digitises with `model` (channels the
/// model does not have are left empty). The noise of
/// each sensor comes from its own stream of `seed`, so the same seed gives the same counts
/// whatever else changes (faults, other sensors' settings).
RawTelemetry SimulateSensors(const std::vector<RoverSample>& samples, const SensorErrorOptions& errors,
                             const telemetry::SensorModel& model, double rate_hz, std::uint64_t seed,
                             SensorErrorDraws* draws);

/// Writes the log as CSV atomically: two '#' lines (the second is `description`), the header
/// `t,enc_fl,enc_fr,enc_rl,enc_rr,compass,pitch_left,pitch_right,roll,gyro_z`, one row per
/// sample; time stamps in seconds with up to 6 decimals, counts as integers, missing cells
/// empty.
void WriteTelemetryCsv(const std::filesystem::path& path, const RawTelemetry& raw, const std::string& description);
/// The same with the columns `model` names, in channel order (channels it lacks left out).
void WriteTelemetryCsv(const std::filesystem::path& path, const RawTelemetry& raw, const std::string& description,
                       const telemetry::SensorModel& model);

/// A time stamp in microseconds as the shortest exact decimal seconds ("12.3", "0.05").
std::string FormatMicroseconds(std::int64_t t_us);

}  // namespace lunarnav::sim
