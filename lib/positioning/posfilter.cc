#include "positioning/posfilter.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "io/atomic_file.h"
#include "util/check.h"

namespace lunarnav::positioning {
namespace {

using telemetry::Channel;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Linear interpolation in time over NaN gaps of `v`, in place, holding the end values; false
// (and `v` untouched) when fewer than two samples are valid.
bool FillGaps(const std::vector<double>& t, std::vector<double>* values) {
  std::vector<double>& v = *values;
  const std::size_t n = v.size();
  const std::size_t valid = static_cast<std::size_t>(
      std::count_if(v.begin(), v.end(), [](double x) { return !std::isnan(x); }));
  if (valid < 2) return false;
  for (std::size_t k = 0; k < n;) {
    if (!std::isnan(v[k])) {
      ++k;
      continue;
    }
    std::size_t b = k;  // the run of missing samples [k, b), between valid samples k - 1 and b
    while (b < n && std::isnan(v[b])) ++b;
    for (std::size_t q = k; q < b; ++q) {
      if (k == 0) {
        v[q] = v[b];
      } else if (b == n) {
        v[q] = v[k - 1];
      } else {
        const std::size_t a = k - 1;
        const double f = (t[q] - t[a]) / (t[b] - t[a]);
        v[q] = v[a] + f * (v[b] - v[a]);
      }
    }
    k = b;
  }
  return true;
}

// Whether `v` has at least `count` valid (not NaN) samples.
bool HasValid(const std::vector<double>& v, std::size_t count) {
  std::size_t valid = 0;
  for (double x : v) {
    if (!std::isnan(x) && ++valid >= count) return true;
  }
  return false;
}

// The median sampling interval (from at most 65536 evenly spread intervals).
double MedianInterval(const std::vector<double>& t) {
  const std::size_t stride = std::max<std::size_t>(1, t.size() / 65536);
  std::vector<double> dt;
  for (std::size_t k = 1; k < t.size(); k += stride) dt.push_back(t[k] - t[k - 1]);
  std::nth_element(dt.begin(), dt.begin() + dt.size() / 2, dt.end());
  return dt[dt.size() / 2];
}

}  // namespace

std::string ToString(FilterMode mode) { return mode == FilterMode::kCausal ? "causal" : "zero-phase"; }
std::string ToString(HeadingMethod method) {
  return method == HeadingMethod::kKalman ? "kalman" : "lowpass";
}

void PosfilterOptions::Validate() const {
  screening.Validate();
  kalman.Validate();
  LN_CHECK_ARG(filter_order >= 1 && filter_order <= 8) << "order: must be in 1..8";
  LN_CHECK_ARG(cutoff_hz > 0 && std::isfinite(cutoff_hz)) << "cutoff: must be > 0 Hz";
  LN_CHECK_ARG(stationary_min_s > 0) << "stationary time: must be > 0";
  dead_reckoning.Validate();
}

nlohmann::json PosfilterOptions::ToJson() const {
  return {{"screening", screening.ToJson()},
          {"filter", {{"type", telemetry::ToString(filter)}, {"order", filter_order}, {"cutoff_hz", cutoff_hz},
                      {"mode", ToString(mode)}}},
          {"heading", ToString(heading)},
          {"kalman", kalman.ToJson()},
          {"slip", {{"fraction", dead_reckoning.slip_fraction}, {"min_m", dead_reckoning.slip_min_m},
                    {"window_s", dead_reckoning.slip_window_s},
                    {"resolution_counts", dead_reckoning.slip_resolution_counts}}},
          {"stationary_min_s", stationary_min_s}};
}

PosfilterResult RunPosfilter(const telemetry::TelemetryLog& log, const telemetry::SensorModel& model,
                             const PosfilterOptions& options) {
  options.Validate();
  PosfilterResult r;
  r.screened = telemetry::ScreenTelemetry(log, model, options.screening);
  telemetry::ScreenedLog& s = r.screened;
  const std::vector<double>& t = s.t_s;
  LN_CHECK_INPUT(t.size() >= 2) << log.source.string() << ": fewer than two usable rows";
  r.sample_rate_hz = 1.0 / MedianInterval(t);
  LN_CHECK_INPUT(options.cutoff_hz < 0.5 * r.sample_rate_hz)
      << log.source.string() << ": the cut-off " << options.cutoff_hz
      << " Hz is not below half the sample rate (" << r.sample_rate_hz << " Hz)";
  r.design = telemetry::DesignLowPass(options.filter, options.filter_order, options.cutoff_hz, r.sample_rate_hz);
  // Channels are filtered in place.
  auto lowpass = [&](std::vector<double>* v) {
    if (options.mode == FilterMode::kCausal) {
      telemetry::FilterCausalInPlace(r.design, v->data(), v->size());
    } else {
      *v = telemetry::FilterZeroPhase(r.design, *v);
    }
  };
  // A channel's screened values with the gaps filled, or empty when it has fewer than two.
  auto filled = [&](Channel c) -> std::vector<double> {
    if (!s.Has(c)) return {};
    std::vector<double> v = s.value[static_cast<int>(c)];
    if (!FillGaps(t, &v)) return {};
    r.channels_used.push_back(telemetry::ToString(c));
    return v;
  };

  DeadReckoningInputs in;
  // Wheels: cumulative metres.
  const Channel wheels[4] = {Channel::kEncoderFrontLeft, Channel::kEncoderFrontRight,
                             Channel::kEncoderRearLeft, Channel::kEncoderRearRight};
  int wheel_count = 0;
  for (int i = 0; i < 4; ++i) {
    std::vector<double> counts = filled(wheels[i]);
    if (counts.empty()) continue;
    const double mpc = model[wheels[i]].MetresPerCount();
    for (double& c : counts) c *= mpc;
    in.wheel_m[i] = std::move(counts);
    in.wheel_resolution_m[i] = std::abs(mpc);
    ++wheel_count;
  }
  LN_CHECK_INPUT(wheel_count > 0) << log.source.string() << ": no usable encoder channel";

  // Pitch: the mean of the filtered left and right inclinometers.
  std::vector<double> pitch_left = filled(Channel::kPitchLeft);
  std::vector<double> pitch_right = filled(Channel::kPitchRight);
  if (!pitch_left.empty() && !pitch_right.empty()) {
    lowpass(&pitch_left);
    lowpass(&pitch_right);
    for (std::size_t k = 0; k < t.size(); ++k) pitch_left[k] = 0.5 * (pitch_left[k] + pitch_right[k]);
    in.pitch_rad = std::move(pitch_left);
  } else if (!pitch_left.empty() || !pitch_right.empty()) {
    in.pitch_rad = std::move(pitch_left.empty() ? pitch_right : pitch_left);
    lowpass(&in.pitch_rad);
    r.notes.push_back("one pitch inclinometer: pitch from the other");
  } else {
    r.notes.push_back("no pitch inclinometers: flat ground (z = 0)");
  }
  pitch_right = {};  // freed now, not at the end
  std::vector<double> roll = filled(Channel::kRoll);
  if (!roll.empty()) {
    lowpass(&roll);
    in.roll_rad = std::move(roll);
  }

  // Heading.
  const int compass = static_cast<int>(Channel::kCompass), gyro = static_cast<int>(Channel::kGyroZ);
  const bool have_compass = s.Has(Channel::kCompass) && HasValid(s.value[compass], 2);
  if (have_compass) r.channels_used.push_back(telemetry::ToString(Channel::kCompass));
  const bool have_gyro = s.Has(Channel::kGyroZ) && HasValid(s.value[gyro], 1);
  if (have_gyro) r.channels_used.push_back("gyro_z");
  if (options.heading == HeadingMethod::kLowPass && have_compass) {
    in.heading_rad = s.value[compass];
    FillGaps(t, &in.heading_rad);
    lowpass(&in.heading_rad);
  } else if (have_compass || have_gyro) {
    if (options.heading == HeadingMethod::kLowPass) {
      r.notes.push_back("no compass: heading from the gyro by the Kalman filter");
    }
    if (!have_compass) r.notes.push_back("no compass: heading from the gyro, relative to the start");
    telemetry::HeadingInputs h;
    // Stationary: no wheel has moved over the last stationary_min_s.
    h.stationary.assign(t.size(), 0);
    std::size_t since = 0;  // first index of the current still stretch
    for (std::size_t k = 1; k < t.size(); ++k) {
      bool moved = false;
      for (const auto& w : in.wheel_m) {
        if (!w.empty() && std::abs(w[k] - w[k - 1]) > 1e-9) moved = true;
      }
      if (moved) since = k;
      h.stationary[k] = !moved && t[k] - t[since] >= options.stationary_min_s;
    }
    // The filter's inputs hold their arrays by value: the screened arrays are lent to it
    // (moved in and back), not copied.
    h.t_s = std::move(s.t_s);
    if (have_compass) h.compass_rad = std::move(s.value[compass]);
    if (have_gyro) h.gyro_radps = std::move(s.value[gyro]);
    r.heading = telemetry::FilterHeading(h, options.kalman);
    s.t_s = std::move(h.t_s);
    if (have_compass) s.value[compass] = std::move(h.compass_rad);
    if (have_gyro) s.value[gyro] = std::move(h.gyro_radps);
    r.kalman_used = true;
  } else {
    r.notes.push_back("no compass and no gyro: constant heading");
    in.heading_rad.assign(t.size(), options.kalman.initial_heading_deg * M_PI / 180.0);
  }
  // Lent likewise: the time stamps, and the Kalman filter's heading.
  in.t_s = std::move(s.t_s);
  if (r.kalman_used) in.heading_rad = std::move(r.heading.heading_rad);
  r.motion = DeadReckon(in, options.dead_reckoning);
  s.t_s = std::move(in.t_s);
  if (r.kalman_used) r.heading.heading_rad = std::move(in.heading_rad);
  return r;
}

void WriteHeadingStreamsCsv(const std::filesystem::path& path, const telemetry::TelemetryLog& log,
                            const telemetry::SensorModel& model, const PosfilterResult& result) {
  const telemetry::ScreenedLog& s = result.screened;
  const std::vector<double>* compass = log.Has(Channel::kCompass) ? &log.counts[static_cast<int>(Channel::kCompass)] : nullptr;
  const std::vector<double>* gyro = log.Has(Channel::kGyroZ) ? &log.counts[static_cast<int>(Channel::kGyroZ)] : nullptr;
  const double deg = 180.0 / M_PI;
  auto angle = [](double d) { d = std::fmod(d, 360.0); return d < 0 ? d + 360.0 : d; };
  std::string text = "# lunarnav heading streams: raw sensors and filtered estimates (deg, deg/s)\n"
                     "t_s,compass_raw_deg,heading_deg,gyro_raw_dps,heading_rate_dps\n";
  char buf[160];
  for (std::size_t k = 0; k < s.t_s.size(); ++k) {
    const std::size_t row = s.row[k];
    std::string c, g, r;
    if (compass != nullptr && !std::isnan((*compass)[row])) {
      std::snprintf(buf, sizeof(buf), "%.4f", angle(model[Channel::kCompass].ToRadians((*compass)[row]) * deg));
      c = buf;
    }
    if (gyro != nullptr && !std::isnan((*gyro)[row])) {
      std::snprintf(buf, sizeof(buf), "%.4f", model[Channel::kGyroZ].ToRadians((*gyro)[row]) * deg);
      g = buf;
    }
    if (result.kalman_used) {
      std::snprintf(buf, sizeof(buf), "%.4f", result.heading.rate_radps[k] * deg);
      r = buf;
    }
    std::snprintf(buf, sizeof(buf), "%.4f", angle(result.motion.trajectory[k].heading_rad * deg));
    text += std::to_string(s.t_s[k]) + "," + c + "," + buf + "," + g + "," + r + "\n";
  }
  io::WriteFileAtomic(path, text);
}

nlohmann::json PosfilterResult::SummaryJson() const {
  nlohmann::json j;
  j["rows_used"] = screened.t_s.size();
  j["sample_rate_hz"] = sample_rate_hz;
  j["channels_used"] = channels_used;
  j["notes"] = notes;
  j["screening"] = screened.ReportJson();
  j["lowpass"] = design.ToJson();
  if (kalman_used) {
    j["heading_kalman"] = {{"compass_updates", heading.compass_updates},
                           {"gyro_updates", heading.gyro_updates},
                           {"gyro_bias_dps", heading.gyro_bias_radps * 180.0 / M_PI},
                           {"gyro_scale_error", heading.gyro_scale_error},
                           {"gyro_scale_sigma", heading.gyro_scale_sigma}};
  }
  const double duration = screened.t_s.empty() ? 0.0 : screened.t_s.back() - screened.t_s.front();
  j["motion"] = {{"distance_m", motion.distance_m},
                 {"duration_s", duration},
                 {"slip_events", motion.slip_events},
                 {"steps_without_odometry", motion.steps_without_odometry}};
  if (!motion.trajectory.empty()) {
    const TrajectorySample& last = motion.trajectory.back();
    j["motion"]["final_position_m"] = {last.x_m, last.y_m, last.z_m};
  }
  return j;
}

}  // namespace lunarnav::positioning
