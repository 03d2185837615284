#include "telemetry/sensor_model.h"

#include <cmath>
#include <set>

#include "io/json_io.h"
#include "util/check.h"

namespace lunarnav::telemetry {
namespace {

constexpr const char* kFormat = "lunarnav.sensors/1";

const char* kChannelNames[kNumChannels] = {"enc_fl",     "enc_fr",      "enc_rl",
                                           "enc_rr",     "compass",     "pitch_left",
                                           "pitch_right", "roll",       "gyro_z"};

// Typed access to one JSON member with errors that name the source and the key.
class Reader {
 public:
  Reader(const nlohmann::json& j, std::string where) : j_(j), where_(std::move(where)) {}

  bool Has(const char* key) const { return j_.contains(key); }

  double Number(const char* key) const {
    const auto& v = Get(key);
    LN_CHECK_INPUT(v.is_number()) << where_ << "." << key << ": expected a number";
    const double d = v.get<double>();
    LN_CHECK_INPUT(std::isfinite(d)) << where_ << "." << key << ": not finite";
    return d;
  }
  long long Integer(const char* key) const {
    const auto& v = Get(key);
    LN_CHECK_INPUT(v.is_number_integer()) << where_ << "." << key << ": expected an integer";
    return v.get<long long>();
  }
  std::string String(const char* key) const {
    const auto& v = Get(key);
    LN_CHECK_INPUT(v.is_string()) << where_ << "." << key << ": expected a string";
    return v.get<std::string>();
  }
  void OnlyKeys(const std::set<std::string>& allowed) const {
    for (const auto& [key, value] : j_.items()) {
      LN_CHECK_INPUT(allowed.count(key) > 0) << where_ << ": unknown field '" << key << "'";
    }
  }

 private:
  const nlohmann::json& Get(const char* key) const {
    LN_CHECK_INPUT(j_.contains(key)) << where_ << ": missing field '" << key << "'";
    return j_.at(key);
  }
  const nlohmann::json& j_;
  std::string where_;
};

}  // namespace

std::string ToString(Channel channel) { return kChannelNames[static_cast<int>(channel)]; }

std::optional<Channel> ChannelFromString(const std::string& name) {
  for (Channel c : kAllChannels) {
    if (name == kChannelNames[static_cast<int>(c)]) return c;
  }
  return std::nullopt;
}

std::string ToString(TimeUnits units) {
  switch (units) {
    case TimeUnits::kSeconds: return "s";
    case TimeUnits::kMilliseconds: return "ms";
    case TimeUnits::kMicroseconds: return "us";
    case TimeUnits::kNanoseconds: return "ns";
  }
  return "s";
}

double SecondsPer(TimeUnits units) {
  switch (units) {
    case TimeUnits::kSeconds: return 1.0;
    case TimeUnits::kMilliseconds: return 1e-3;
    case TimeUnits::kMicroseconds: return 1e-6;
    case TimeUnits::kNanoseconds: return 1e-9;
  }
  return 1.0;
}

bool IsEncoder(Channel channel) {
  return channel == Channel::kEncoderFrontLeft || channel == Channel::kEncoderFrontRight ||
         channel == Channel::kEncoderRearLeft || channel == Channel::kEncoderRearRight;
}

double ChannelModel::MetresPerCount() const {
  return sign * 2.0 * M_PI * wheel_radius_m / counts_per_revolution;
}

double ChannelModel::ToRadians(double count) const {
  const double value = offset + scale * count;
  return units == "rad" || units == "rad/s" ? value : value * (M_PI / 180.0);
}

void SensorModel::OverrideBits(int bits) {
  LN_CHECK_ARG(bits >= 1 && bits <= 24) << "bits: must be in 1..24, got " << bits;
  for (ChannelModel& m : channels) {
    if (!m.present || m.bits == bits) continue;
    // The same sensor read with fewer (or more) bits: each count spans `factor` old counts.
    const double factor = std::ldexp(1.0, m.bits - bits);
    const bool default_range = m.valid_min == 0 && m.valid_max == (1LL << m.bits) - 1;
    m.scale *= factor;
    m.counts_per_revolution /= factor;
    m.counter_bits = std::max(2, m.counter_bits - (m.bits - bits));
    if (default_range) {
      m.valid_max = (1LL << bits) - 1;
    } else {
      m.valid_min = static_cast<long long>(std::floor(m.valid_min / factor));
      m.valid_max = static_cast<long long>(std::ceil(m.valid_max / factor));
    }
    m.bits = bits;
  }
}

nlohmann::json SensorModel::ToJson() const {
  nlohmann::json j;
  j["format"] = kFormat;
  j["time_column"] = time_column;
  if (time_units != TimeUnits::kSeconds) j["time_units"] = ToString(time_units);
  if (!vehicle.empty()) {
    nlohmann::json v = nlohmann::json::object();
    if (vehicle.max_speed_mps) v["max_speed_mps"] = *vehicle.max_speed_mps;
    if (vehicle.max_turn_rate_dps) v["max_turn_rate_dps"] = *vehicle.max_turn_rate_dps;
    if (vehicle.max_turn_accel_dps2) v["max_turn_accel_dps2"] = *vehicle.max_turn_accel_dps2;
    if (vehicle.max_tilt_rate_dps) v["max_tilt_rate_dps"] = *vehicle.max_tilt_rate_dps;
    j["vehicle"] = v;
  }
  nlohmann::json chans = nlohmann::json::object();
  for (Channel c : kAllChannels) {
    const ChannelModel& m = (*this)[c];
    if (!m.present) continue;
    nlohmann::json cj = {{"column", m.column}, {"bits", m.bits}, {"valid_range", {m.valid_min, m.valid_max}}};
    if (IsEncoder(c)) {
      cj["counter_bits"] = m.counter_bits;
      cj["counts_per_revolution"] = m.counts_per_revolution;
      cj["wheel_radius_m"] = m.wheel_radius_m;
      cj["sign"] = m.sign;
    } else {
      cj["scale"] = m.scale;
      cj["offset"] = m.offset;
      cj["units"] = m.units;
      if (m.noise_rms > 0) cj["noise_rms"] = m.noise_rms;
    }
    chans[ToString(c)] = cj;
  }
  j["channels"] = chans;
  return j;
}

SensorModel SensorModelFromJson(const nlohmann::json& j, const std::string& source) {
  LN_CHECK_INPUT(j.is_object()) << source << ": a sensor model is a JSON object";
  Reader top(j, source);
  top.OnlyKeys({"format", "time_column", "time_units", "vehicle", "bits", "channels", "description"});
  LN_CHECK_INPUT(top.String("format") == kFormat)
      << source << ".format: expected \"" << kFormat << "\"";
  SensorModel model;
  if (top.Has("time_column")) model.time_column = top.String("time_column");
  if (top.Has("time_units")) {
    const std::string units = top.String("time_units");
    bool known = false;
    for (TimeUnits u : {TimeUnits::kSeconds, TimeUnits::kMilliseconds, TimeUnits::kMicroseconds,
                        TimeUnits::kNanoseconds}) {
      if (units == ToString(u)) {
        model.time_units = u;
        known = true;
      }
    }
    LN_CHECK_INPUT(known) << source << ".time_units: '" << units << "' (expected s, ms, us or ns)";
  }
  if (top.Has("vehicle")) {
    const nlohmann::json& vj = j["vehicle"];
    LN_CHECK_INPUT(vj.is_object()) << source << ".vehicle: expected an object";
    Reader v(vj, source + ".vehicle");
    v.OnlyKeys({"max_speed_mps", "max_turn_rate_dps", "max_turn_accel_dps2", "max_tilt_rate_dps", "description"});
    auto limit = [&](const char* key, std::optional<double>* out) {
      if (!v.Has(key)) return;
      *out = v.Number(key);
      LN_CHECK_INPUT(**out > 0) << source << ".vehicle." << key << ": must be > 0";
    };
    limit("max_speed_mps", &model.vehicle.max_speed_mps);
    limit("max_turn_rate_dps", &model.vehicle.max_turn_rate_dps);
    limit("max_turn_accel_dps2", &model.vehicle.max_turn_accel_dps2);
    limit("max_tilt_rate_dps", &model.vehicle.max_tilt_rate_dps);
  }
  const int default_bits = top.Has("bits") ? static_cast<int>(top.Integer("bits")) : 10;
  LN_CHECK_INPUT(default_bits >= 1 && default_bits <= 24)
      << source << ".bits: must be in 1..24, got " << default_bits;
  LN_CHECK_INPUT(j.contains("channels") && j["channels"].is_object())
      << source << ": missing object 'channels'";
  std::set<std::string> columns;
  for (const auto& [name, cj] : j["channels"].items()) {
    const std::string where = source + ".channels." + name;
    const std::optional<Channel> channel = ChannelFromString(name);
    LN_CHECK_INPUT(channel.has_value())
        << where << ": unknown channel (known: enc_fl enc_fr enc_rl enc_rr compass pitch_left "
        << "pitch_right roll gyro_z)";
    LN_CHECK_INPUT(cj.is_object()) << where << ": expected an object";
    Reader r(cj, where);
    ChannelModel& m = model[*channel];
    m.present = true;
    m.column = r.Has("column") ? r.String("column") : name;
    LN_CHECK_INPUT(!m.column.empty()) << where << ".column: empty";
    LN_CHECK_INPUT(m.column != model.time_column && columns.insert(m.column).second)
        << where << ".column: '" << m.column << "' is used twice";
    m.bits = r.Has("bits") ? static_cast<int>(r.Integer("bits")) : default_bits;
    LN_CHECK_INPUT(m.bits >= 1 && m.bits <= 24) << where << ".bits: must be in 1..24";
    m.valid_min = 0;
    m.valid_max = (1LL << m.bits) - 1;
    if (cj.contains("valid_range")) {
      const auto& range = cj["valid_range"];
      LN_CHECK_INPUT(range.is_array() && range.size() == 2 && range[0].is_number_integer() &&
                     range[1].is_number_integer())
          << where << ".valid_range: expected [MIN, MAX] counts";
      m.valid_min = range[0].get<long long>();
      m.valid_max = range[1].get<long long>();
      LN_CHECK_INPUT(m.valid_min <= m.valid_max) << where << ".valid_range: MIN > MAX";
    }
    if (IsEncoder(*channel)) {
      r.OnlyKeys({"column", "bits", "valid_range", "counter_bits", "counts_per_revolution",
                  "wheel_radius_m", "sign"});
      m.counter_bits = r.Has("counter_bits") ? static_cast<int>(r.Integer("counter_bits")) : m.bits;
      LN_CHECK_INPUT(m.counter_bits >= 2 && m.counter_bits <= 32)
          << where << ".counter_bits: must be in 2..32";
      if (!cj.contains("valid_range")) m.valid_max = (1LL << m.counter_bits) - 1;
      m.counts_per_revolution = r.Number("counts_per_revolution");
      LN_CHECK_INPUT(m.counts_per_revolution > 0 && m.counts_per_revolution <= 1e9)
          << where << ".counts_per_revolution: must be > 0 and at most 10^9, got " << m.counts_per_revolution;
      m.wheel_radius_m = r.Number("wheel_radius_m");
      // A wheel of 10 m is beyond any rover's; 1e300 m made positions of 10^297 m.
      LN_CHECK_INPUT(m.wheel_radius_m > 0 && m.wheel_radius_m <= 10)
          << where << ".wheel_radius_m: must be > 0 and at most 10 m, got " << m.wheel_radius_m;
      m.sign = r.Has("sign") ? static_cast<int>(r.Integer("sign")) : 1;
      LN_CHECK_INPUT(m.sign == 1 || m.sign == -1) << where << ".sign: must be 1 or -1";
    } else {
      r.OnlyKeys({"column", "bits", "valid_range", "scale", "offset", "units", "noise_rms"});
      m.scale = r.Number("scale");
      // Units a count: a compass or an inclinometer spans at most a turn, a gyro a few turns a
      // second, in some 2 to 2^24 counts.
      LN_CHECK_INPUT(m.scale != 0 && std::abs(m.scale) <= 1000)
          << where << ".scale: must be nonzero and at most 1000 units a count, got " << m.scale;
      m.offset = r.Has("offset") ? r.Number("offset") : 0.0;
      LN_CHECK_INPUT(std::abs(m.offset) <= 1e6) << where << ".offset: must be within 10^6 units, got " << m.offset;
      m.noise_rms = r.Has("noise_rms") ? r.Number("noise_rms") : 0.0;
      LN_CHECK_INPUT(m.noise_rms >= 0 && m.noise_rms <= 1e6)
          << where << ".noise_rms: must be >= 0 and at most 10^6 units, got " << m.noise_rms;
      const bool rate = *channel == Channel::kGyroZ;
      m.units = r.Has("units") ? r.String("units") : (rate ? "deg/s" : "deg");
      LN_CHECK_INPUT(rate ? (m.units == "deg/s" || m.units == "rad/s")
                          : (m.units == "deg" || m.units == "rad"))
          << where << ".units: '" << m.units << "' (expected " << (rate ? "deg/s or rad/s" : "deg or rad")
          << ")";
    }
  }
  return model;
}

SensorModel ReadSensorModel(const std::filesystem::path& path) {
  return SensorModelFromJson(io::ReadJson(path), path.string());
}

}  // namespace lunarnav::telemetry
