// The sensor model of a rover's telemetry: how raw integer counts become physical units.
//
// Krotkov & Hebert sec. 4.1: four drive encoders, a flux-gate compass, three inclinometers
// (left body pitch, right body pitch, roll) and a turn-rate gyro, digitised to 10 bits (7 in
// old telemetry). The model is read from JSON (docs/formats.md, "Sensor model").
#pragma once

#include <array>
#include <filesystem>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

namespace lunarnav::telemetry {

/// The channels posfilter knows, by role. Any of them may be absent from a log.
enum class Channel {
  kEncoderFrontLeft,
  kEncoderFrontRight,
  kEncoderRearLeft,
  kEncoderRearRight,
  kCompass,
  kPitchLeft,
  kPitchRight,
  kRoll,
  kGyroZ
};
inline constexpr int kNumChannels = 9;
inline constexpr std::array<Channel, kNumChannels> kAllChannels = {
    Channel::kEncoderFrontLeft, Channel::kEncoderFrontRight, Channel::kEncoderRearLeft,
    Channel::kEncoderRearRight, Channel::kCompass,           Channel::kPitchLeft,
    Channel::kPitchRight,       Channel::kRoll,              Channel::kGyroZ};

/// The channel's name in sensor files and default CSV column ("enc_fl", "compass", ...).
std::string ToString(Channel channel);
/// Inverse of ToString; std::nullopt for an unknown name.
std::optional<Channel> ChannelFromString(const std::string& name);
bool IsEncoder(Channel channel);

/// One channel's conversion from counts to units.
struct ChannelModel {
  bool present = false;        ///< Configured in the sensor file.
  std::string column;          ///< CSV column holding its counts (default: the channel name).
  int bits = 10;               ///< Digitisation: counts are integers in [0, 2^bits - 1].
  /// Analog channels: value = offset + scale * count, in `units` (deg for the compass and
  /// inclinometers, deg/s for the gyro).
  double scale = 1.0;
  double offset = 0.0;
  std::string units;          ///< "deg" or "rad"; the gyro "deg/s" or "rad/s".
  /// Analog channels: the sensor's noise per sample, RMS, in `units` (vibration included:
  /// an inclinometer derived from an accelerometer on a driving rover reads a degree or more;
  /// a gyro's is its noise density times sqrt(sample rate / 2)). >= 0; 0 = unknown (the
  /// rate limit then allows only its slack of counts). Screening's rate limit adds
  /// ScreeningOptions::rate_noise_sigmas x sqrt(2) of it per sample.
  double noise_rms = 0.0;
  /// Counts outside [valid_min, valid_max] are out of range (screening). Default: the full
  /// digitisation range [0, 2^bits - 1].
  long long valid_min = 0;
  long long valid_max = 1023;
  /// Encoders: the counter wraps modulo 2^counter_bits; one wheel revolution is
  /// counts_per_revolution counts; the wheel radius is wheel_radius_m; `sign` is +1 or -1 so
  /// that forward motion increases the distance.
  int counter_bits = 10;
  double counts_per_revolution = 1024;
  double wheel_radius_m = 0.25;
  int sign = 1;

  /// Metres of travel per encoder count (encoders only).
  double MetresPerCount() const;
  /// Analog channels: the value of `count` in radians (or rad/s for the gyro).
  double ToRadians(double count) const;
};

/// The vehicle's physical limits, from which screening's rate limits derive (unset: the
/// ScreeningOptions defaults, docs/posfilter.md). Generous bounds of what the vehicle can do,
/// not typical values: a sample beyond them is not a measurement of motion.
struct VehicleLimits {
  std::optional<double> max_speed_mps;        ///< Any wheel's rim speed. > 0.
  std::optional<double> max_turn_rate_dps;    ///< Heading rate. > 0.
  /// Angular acceleration about the vertical: a skid-steered rover starts and stops turning
  /// abruptly (several hundred deg/s^2). > 0.
  std::optional<double> max_turn_accel_dps2;
  std::optional<double> max_tilt_rate_dps;    ///< Pitch and roll rate of the body. > 0.
  bool empty() const {
    return !max_speed_mps && !max_turn_rate_dps && !max_turn_accel_dps2 && !max_tilt_rate_dps;
  }
};

/// Units of the time column: seconds, milliseconds, microseconds or nanoseconds (Unix epoch
/// time stamps are any of these; they are converted to seconds as read).
enum class TimeUnits { kSeconds, kMilliseconds, kMicroseconds, kNanoseconds };
std::string ToString(TimeUnits units);
double SecondsPer(TimeUnits units);

/// The whole sensor model.
struct SensorModel {
  std::array<ChannelModel, kNumChannels> channels;
  std::string time_column = "t";  ///< Time stamps, in time_units.
  TimeUnits time_units = TimeUnits::kSeconds;
  VehicleLimits vehicle;

  const ChannelModel& operator[](Channel c) const { return channels[static_cast<int>(c)]; }
  ChannelModel& operator[](Channel c) { return channels[static_cast<int>(c)]; }

  /// Reads every channel with `bits` instead (posfilter --bits 7: the paper's old telemetry
  /// carried 7-bit values of the same 10-bit sensors). Each channel keeps its full-scale
  /// range: a count spans 2^(old - new) old counts, so analog scales grow by that factor,
  /// encoders count that many times fewer counts per revolution on a counter that many bits
  /// narrower, and valid ranges shrink alike.
  void OverrideBits(int bits);
  nlohmann::json ToJson() const;
};

/// Parses a sensor model. @param source  named in errors (the file path).
/// @throws InputError naming the source, the key and the reason (unknown channel or field,
///         missing field, wrong type, impossible value).
SensorModel SensorModelFromJson(const nlohmann::json& j, const std::string& source);

/// Reads a sensor-model file. @throws InputError.
SensorModel ReadSensorModel(const std::filesystem::path& path);

}  // namespace lunarnav::telemetry
