#include "sim/rover_sensors.h"

#include <algorithm>
#include <charconv>
#include <cmath>

#include "io/atomic_file.h"
#include "sim/portable_random.h"
#include "util/check.h"

namespace lunarnav::sim {
namespace {

using telemetry::Channel;
constexpr double kDeg = M_PI / 180.0;
constexpr double kGravity = 9.80665;  // m/s^2

int Index(Channel c) { return static_cast<int>(c); }

// One step of a first-order lag with time constant tau (tau = 0: no lag).
double LagStep(double y, double input, double tau, double dt) {
  return tau > 0 ? y + (1.0 - std::exp(-dt / tau)) * (input - y) : input;
}

}  // namespace

SensorErrorOptions SensorErrorOptions::Scaled(double scale) const {
  SensorErrorOptions o = *this;
  for (double* v : {&o.compass_bias_deg, &o.compass_noise_deg, &o.compass_wander_deg, &o.compass_turn_deg_per_dps,
                    &o.compass_turn_accel_deg_per_dps2, &o.compass_accel_deg_per_mps2, &o.gyro_bias_dps,
                    &o.gyro_bias_walk_dps_per_sqrt_s, &o.gyro_noise_dps,
                    &o.gyro_bias_instability_dps, &o.gyro_scale_error, &o.tilt_bias_deg,
                    &o.tilt_noise_deg, &o.tilt_vibration_deg_per_mps, &o.tilt_accel_gain}) {
    *v *= scale;
  }
  return o;
}

void SensorErrorOptions::Validate() const {
  for (double v : {compass_bias_deg, compass_noise_deg, compass_wander_deg, compass_transient_tau_s, gyro_bias_dps,
                   gyro_bias_walk_dps_per_sqrt_s, gyro_noise_dps, gyro_scale_error, gyro_bias_instability_dps,
                   tilt_bias_deg, tilt_noise_deg,
                   tilt_vibration_deg_per_mps, tilt_accel_gain, tilt_tau_s}) {
    LN_CHECK_ARG(v >= 0 && std::isfinite(v)) << "sensor errors: magnitudes and lags must be finite and >= 0";
  }
  for (double v : {compass_turn_deg_per_dps, compass_turn_accel_deg_per_dps2, compass_accel_deg_per_mps2}) {
    LN_CHECK_ARG(std::isfinite(v)) << "sensor errors: compass transient gains must be finite";
  }
  LN_CHECK_ARG(gyro_bias_instability_tau_s > 0) << "sensor errors: the gyro bias instability time must be > 0";
  LN_CHECK_ARG(compass_noise_corner_hz > 0 && compass_wander_tau_s > 0)
      << "sensor errors: the compass noise corner and wander time must be > 0";
}

nlohmann::json SensorErrorOptions::ToJson() const {
  return {{"compass_bias_deg", compass_bias_deg},
          {"compass_noise_deg", compass_noise_deg},
          {"compass_noise_corner_hz", compass_noise_corner_hz},
          {"compass_wander_deg", compass_wander_deg},
          {"compass_wander_tau_s", compass_wander_tau_s},
          {"compass_turn_deg_per_dps", compass_turn_deg_per_dps},
          {"compass_turn_accel_deg_per_dps2", compass_turn_accel_deg_per_dps2},
          {"compass_accel_deg_per_mps2", compass_accel_deg_per_mps2},
          {"compass_transient_tau_s", compass_transient_tau_s},
          {"gyro_bias_dps", gyro_bias_dps},
          {"gyro_bias_walk_dps_per_sqrt_s", gyro_bias_walk_dps_per_sqrt_s},
          {"gyro_noise_dps", gyro_noise_dps},
          {"gyro_scale_error", gyro_scale_error},
          {"gyro_bias_instability_dps", gyro_bias_instability_dps},
          {"gyro_bias_instability_tau_s", gyro_bias_instability_tau_s},
          {"tilt_bias_deg", tilt_bias_deg},
          {"tilt_noise_deg", tilt_noise_deg},
          {"tilt_vibration_deg_per_mps", tilt_vibration_deg_per_mps},
          {"tilt_accel_gain", tilt_accel_gain},
          {"tilt_tau_s", tilt_tau_s}};
}

nlohmann::json SensorErrorDraws::ToJson() const {
  return {{"compass_bias_deg", compass_bias_deg},
          {"gyro_bias_dps", gyro_bias_dps},
          {"gyro_scale_error", gyro_scale_error},
          {"pitch_left_bias_deg", pitch_left_bias_deg},
          {"pitch_right_bias_deg", pitch_right_bias_deg},
          {"roll_bias_deg", roll_bias_deg},
          {"encoder_initial_counts", encoder_initial_counts}};
}

telemetry::SensorModel SimulatedSensorModel(int bits) {
  LN_CHECK_ARG(bits >= 6 && bits <= 16) << "bits: must be in 6..16, got " << bits;
  telemetry::SensorModel model;
  for (Channel c : telemetry::kAllChannels) {
    telemetry::ChannelModel& m = model[c];
    m.present = true;
    m.column = telemetry::ToString(c);
    m.bits = 10;
    m.valid_min = 0;
    m.valid_max = 1023;
    if (telemetry::IsEncoder(c)) {
      m.counter_bits = 10;
      m.counts_per_revolution = 256;
      m.wheel_radius_m = 0.25;
      m.sign = (c == Channel::kEncoderFrontRight || c == Channel::kEncoderRearRight) ? -1 : 1;
    } else if (c == Channel::kCompass) {
      m.scale = 360.0 / 1024;
      m.offset = 0.0;
      m.units = "deg";
    } else if (c == Channel::kGyroZ) {
      m.scale = 120.0 / 1024;
      m.offset = -60.0;
      m.units = "deg/s";
    } else {
      m.scale = 90.0 / 1024;
      m.offset = -45.0;
      m.units = "deg";
    }
  }
  if (bits != 10) model.OverrideBits(bits);
  return model;
}

telemetry::SensorModel MemsRoverSensorModel(bool compass) {
  telemetry::SensorModel model;
  for (Channel c : telemetry::kAllChannels) {
    telemetry::ChannelModel& m = model[c];
    m.column = telemetry::ToString(c);
    m.bits = 10;
    m.valid_min = 0;
    m.valid_max = 1023;
    if (telemetry::IsEncoder(c)) {
      m.present = true;
      m.counter_bits = 10;
      m.counts_per_revolution = 1024;
      m.wheel_radius_m = 0.11;
      m.sign = (c == Channel::kEncoderFrontLeft || c == Channel::kEncoderRearLeft) ? -1 : 1;
    } else if (c == Channel::kCompass) {
      m.present = compass;
      m.scale = 360.0 / 1024;
      m.units = "deg";
      m.noise_rms = 2.0;
    } else if (c == Channel::kGyroZ) {
      m.present = true;
      m.scale = 2.0 / 1024;
      m.offset = -1.0;
      m.units = "rad/s";
      m.noise_rms = 0.006;  // rad/s per sample at 50 Hz: 0.07 deg/s/sqrt(Hz) x sqrt(25 Hz)
    } else if (c == Channel::kPitchRight) {
      m.present = false;  // one pitch from the accelerometer
    } else {
      m.present = true;
      if (c == Channel::kPitchLeft) m.column = "pitch";
      m.scale = 60.0 / 1024;
      m.offset = -30.0;
      m.units = "deg";
      m.noise_rms = 1.5;  // vibration of an accelerometer on a driving rover
    }
  }
  model.vehicle.max_speed_mps = 1.0;
  model.vehicle.max_turn_rate_dps = 90.0;
  model.vehicle.max_turn_accel_dps2 = 600.0;
  model.vehicle.max_tilt_rate_dps = 60.0;
  return model;
}

std::int64_t DigitiseAnalog(const telemetry::ChannelModel& m, double value_rad, bool wraps) {
  const bool degrees = m.units == "deg" || m.units == "deg/s";
  const double value = degrees ? value_rad / kDeg : value_rad;
  const double count = std::round((value - m.offset) / m.scale);
  const std::int64_t levels = std::int64_t{1} << m.bits;
  if (wraps) {
    const std::int64_t c = static_cast<std::int64_t>(std::fmod(count, static_cast<double>(levels)));
    return c < 0 ? c + levels : c;
  }
  return static_cast<std::int64_t>(std::clamp(count, 0.0, static_cast<double>(levels - 1)));
}

std::int64_t DigitiseEncoder(const telemetry::ChannelModel& m, double travel_m, std::int64_t initial_count) {
  const double per_count = std::abs(m.MetresPerCount());
  // A billionth of a count of slack, so that whole multiples of a count are not floored down
  // by rounding of the division.
  const std::int64_t turned = static_cast<std::int64_t>(std::floor(travel_m / per_count + 1e-9));
  const std::int64_t period = std::int64_t{1} << m.counter_bits;
  const std::int64_t c = (initial_count + m.sign * turned) % period;
  return c < 0 ? c + period : c;
}

RawTelemetry SimulateSensors(const std::vector<RoverSample>& samples, const SensorErrorOptions& e,
                             const telemetry::SensorModel& model, double rate_hz, std::uint64_t seed,
                             SensorErrorDraws* draws) {
  e.Validate();
  LN_CHECK_ARG(rate_hz > 0) << "sample rate: must be > 0 Hz";
  const double dt = 1.0 / rate_hz;
  // Independent streams: one per sensor, one for the per-run draws.
  PortableRandom draw_rng(seed, "sensor-draws"), compass_rng(seed, "compass"), gyro_rng(seed, "gyro");
  std::array<PortableRandom, 3> tilt_rng = {PortableRandom(seed, "pitch_left"), PortableRandom(seed, "pitch_right"),
                                            PortableRandom(seed, "roll")};
  SensorErrorDraws d;
  d.compass_bias_deg = draw_rng.Normal(0, e.compass_bias_deg);
  d.gyro_bias_dps = draw_rng.Normal(0, e.gyro_bias_dps);
  d.gyro_scale_error = draw_rng.Normal(0, e.gyro_scale_error);
  d.pitch_left_bias_deg = draw_rng.Normal(0, e.tilt_bias_deg);
  d.pitch_right_bias_deg = draw_rng.Normal(0, e.tilt_bias_deg);
  d.roll_bias_deg = draw_rng.Normal(0, e.tilt_bias_deg);
  const Channel wheels[4] = {Channel::kEncoderFrontLeft, Channel::kEncoderFrontRight, Channel::kEncoderRearLeft,
                             Channel::kEncoderRearRight};
  for (int i = 0; i < 4; ++i) {
    d.encoder_initial_counts[i] =
        static_cast<std::int64_t>(draw_rng.UniformInt(std::uint64_t{1} << model[wheels[i]].counter_bits));
  }
  if (draws != nullptr) *draws = d;

  // Compass fast noise: y_k = a (y_{k-1} + x_k - x_{k-1}) on white x, a first-order high-pass
  // whose output variance is 2 a^2 / (1 + a) times the input's.
  const double rc = 1.0 / (2.0 * M_PI * e.compass_noise_corner_hz);
  const double a = rc / (rc + dt);
  const double hp_gain = 1.0 / std::sqrt(2.0 * a * a / (1.0 + a));
  const double wander_phi = std::exp(-dt / e.compass_wander_tau_s);
  double hp_x = compass_rng.Normal(), hp_y = 0, wander = compass_rng.Normal(0, e.compass_wander_deg);
  double transient = 0, gyro_walk = 0;
  const double instability_phi = std::exp(-dt / e.gyro_bias_instability_tau_s);
  // (Drawn only when there is one: the other streams stay those of logs without it.)
  double instability = e.gyro_bias_instability_dps > 0 ? gyro_rng.Normal(0, e.gyro_bias_instability_dps) : 0.0;
  std::array<double, 3> tilt_transient{};

  RawTelemetry raw;
  raw.t_us.reserve(samples.size());
  raw.counts.reserve(samples.size());
  for (const RoverSample& s : samples) {
    raw.t_us.push_back(std::llround(s.t_s * 1e6));
    std::array<std::int64_t, telemetry::kNumChannels> row{};
    for (int i = 0; i < 4; ++i) {
      row[Index(wheels[i])] = DigitiseEncoder(model[wheels[i]], s.wheel_m[i], d.encoder_initial_counts[i]);
    }
    const double turn_dps = s.turn_rate_radps / kDeg, turn_accel_dps2 = s.turn_accel_radps2 / kDeg;

    // Compass.
    const double x = compass_rng.Normal();
    hp_y = a * (hp_y + x - hp_x);
    hp_x = x;
    wander = wander_phi * wander + e.compass_wander_deg * std::sqrt(1 - wander_phi * wander_phi) * compass_rng.Normal();
    transient = LagStep(transient,
                        e.compass_turn_deg_per_dps * turn_dps + e.compass_turn_accel_deg_per_dps2 * turn_accel_dps2 +
                            e.compass_accel_deg_per_mps2 * s.accel_mps2,
                        e.compass_transient_tau_s, dt);
    const double compass_deg =
        s.heading_rad / kDeg + d.compass_bias_deg + wander + e.compass_noise_deg * hp_gain * hp_y + transient;
    row[Index(Channel::kCompass)] = model[Channel::kCompass].present
                                        ? DigitiseAnalog(model[Channel::kCompass], compass_deg * kDeg, true)
                                        : kEmptyCell;

    // Gyro.
    gyro_walk += e.gyro_bias_walk_dps_per_sqrt_s * std::sqrt(dt) * gyro_rng.Normal();
    if (e.gyro_bias_instability_dps > 0) {
      instability = instability_phi * instability + e.gyro_bias_instability_dps *
                                                        std::sqrt(1 - instability_phi * instability_phi) *
                                                        gyro_rng.Normal();
    }
    const double gyro_dps = (1.0 + d.gyro_scale_error) * turn_dps + d.gyro_bias_dps + gyro_walk +
                            (e.gyro_bias_instability_dps > 0 ? instability : 0.0) +
                            e.gyro_noise_dps * gyro_rng.Normal();
    row[Index(Channel::kGyroZ)] = DigitiseAnalog(model[Channel::kGyroZ], gyro_dps * kDeg, false);

    // Inclinometers: gravity minus acceleration, lagged by the pendulum, plus noise.
    const double pitch_accel_deg = std::atan(s.accel_mps2 / kGravity) / kDeg;
    const double roll_accel_deg = -std::atan(s.speed_mps * s.turn_rate_radps / kGravity) / kDeg;
    const Channel tilts[3] = {Channel::kPitchLeft, Channel::kPitchRight, Channel::kRoll};
    const double truth_deg[3] = {s.pitch_left_rad / kDeg, s.pitch_right_rad / kDeg, s.roll_rad / kDeg};
    const double bias_deg[3] = {d.pitch_left_bias_deg, d.pitch_right_bias_deg, d.roll_bias_deg};
    const double accel_deg[3] = {pitch_accel_deg, pitch_accel_deg, roll_accel_deg};
    const double noise_deg = std::hypot(e.tilt_noise_deg, e.tilt_vibration_deg_per_mps * std::abs(s.speed_mps));
    for (int i = 0; i < 3; ++i) {
      tilt_transient[i] = LagStep(tilt_transient[i], e.tilt_accel_gain * accel_deg[i], e.tilt_tau_s, dt);
      const double reading = truth_deg[i] + bias_deg[i] + tilt_transient[i] + noise_deg * tilt_rng[i].Normal();
      row[Index(tilts[i])] =
          model[tilts[i]].present ? DigitiseAnalog(model[tilts[i]], reading * kDeg, false) : kEmptyCell;
    }
    raw.counts.push_back(row);
  }
  return raw;
}

std::string FormatMicroseconds(std::int64_t t_us) {
  const bool negative = t_us < 0;
  const std::uint64_t m = negative ? static_cast<std::uint64_t>(-(t_us + 1)) + 1 : static_cast<std::uint64_t>(t_us);
  std::string s = negative ? "-" : "";
  s += std::to_string(m / 1000000);
  std::uint64_t fraction = m % 1000000;
  if (fraction != 0) {
    char digits[7];
    for (int i = 5; i >= 0; --i) {
      digits[i] = static_cast<char>('0' + fraction % 10);
      fraction /= 10;
    }
    int n = 6;
    while (digits[n - 1] == '0') --n;
    s += '.';
    s.append(digits, static_cast<std::size_t>(n));
  }
  return s;
}

void WriteTelemetryCsv(const std::filesystem::path& path, const RawTelemetry& raw, const std::string& description) {
  telemetry::SensorModel all;
  for (Channel c : telemetry::kAllChannels) {
    all[c].present = true;
    all[c].column = telemetry::ToString(c);
  }
  WriteTelemetryCsv(path, raw, description, all);
}

void WriteTelemetryCsv(const std::filesystem::path& path, const RawTelemetry& raw, const std::string& description,
                       const telemetry::SensorModel& model) {
  io::AtomicOutputFile file(path);
  std::string s = "# lunarnav simulated telemetry: t in seconds, the rest raw integer counts (sensors.json converts them)\n";
  s += "# " + description + "\n";
  s += "t";
  for (Channel c : telemetry::kAllChannels) {
    if (model[c].present) s += "," + model[c].column;
  }
  s += '\n';
  char buf[32];
  for (std::size_t k = 0; k < raw.size(); ++k) {
    s += FormatMicroseconds(raw.t_us[k]);
    for (int c = 0; c < telemetry::kNumChannels; ++c) {
      if (!model.channels[c].present) continue;
      const std::int64_t v = raw.counts[k][c];
      s += ',';
      if (v != kEmptyCell) s.append(buf, std::to_chars(buf, buf + sizeof(buf), v).ptr);
    }
    s += '\n';
    if (s.size() > (1u << 20)) {
      file.Write(s);
      s.clear();
    }
  }
  file.Write(s);
  file.Commit();
}

}  // namespace lunarnav::sim
