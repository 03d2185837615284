#include "positioning/posfilter.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>

#include "io/atomic_file.h"
#include "util/check.h"

namespace lunarnav::positioning {
namespace {

using telemetry::Channel;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

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

namespace {

// A screened channel read row by row, in order, with its gaps filled
// (linear interpolation in time between the valid samples around a gap, the end values held)
// and scaled: the same numbers, without a filled copy of the channel. Needs two valid samples.
class FilledChannel {
 public:
  FilledChannel(const std::vector<double>& t, const std::vector<double>& v, double scale)
      : t_(t), v_(v), scale_(scale) {}
  double At(std::size_t k) {
    const double value = v_[k];
    if (!std::isnan(value)) {
      last_valid_ = k;
      return value * scale_;
    }
    if (next_valid_ <= k) {  // the valid sample after this gap
      next_valid_ = k + 1;
      while (next_valid_ < v_.size() && std::isnan(v_[next_valid_])) ++next_valid_;
    }
    const std::size_t a = last_valid_, b = next_valid_;
    if (a == kNone) return v_[b] * scale_;
    if (b == v_.size()) return v_[a] * scale_;
    const double f = (t_[k] - t_[a]) / (t_[b] - t_[a]);
    return (v_[a] + f * (v_[b] - v_[a])) * scale_;
  }

 private:
  static constexpr std::size_t kNone = static_cast<std::size_t>(-1);
  const std::vector<double>& t_;
  const std::vector<double>& v_;
  double scale_;
  std::size_t last_valid_ = kNone, next_valid_ = 0;
};

// A channel as dead reckoning takes it: filled, then low-passed, causally sample by sample
// or (zero phase) from an array filtered beforehand.
class FilteredChannel {
 public:
  FilteredChannel(const std::vector<double>& t, const std::vector<double>& v, const telemetry::LowPassDesign& design,
                  FilterMode mode)
      : filled_(t, v, 1.0) {
    if (mode == FilterMode::kZeroPhase) {
      std::vector<double> filled(t.size());
      for (std::size_t k = 0; k < t.size(); ++k) filled[k] = filled_.At(k);
      zero_phase_ = telemetry::FilterZeroPhase(design, filled);
    } else {
      causal_.emplace(design, filled_.At(0));  // starts in the steady state of the first sample
    }
  }
  double At(std::size_t k) { return causal_ ? (*causal_)(filled_.At(k)) : zero_phase_[k]; }

 private:
  FilledChannel filled_;
  std::optional<telemetry::CausalLowPass> causal_;
  std::vector<double> zero_phase_;
};

}  // namespace

PosfilterResult RunPosfilter(const telemetry::TelemetryLog& log, const telemetry::SensorModel& model,
                             const PosfilterOptions& options, const PoseSink& sink) {
  options.Validate();
  PosfilterResult r;
  r.screened = telemetry::ScreenTelemetry(log, model, options.screening);
  const telemetry::ScreenedLog& s = r.screened;
  const std::vector<double>& t = s.t_s;
  const std::size_t n = t.size();
  LN_CHECK_INPUT(n >= 2) << log.source.string() << ": fewer than two usable rows";
  r.sample_rate_hz = 1.0 / MedianInterval(t);
  LN_CHECK_INPUT(options.cutoff_hz < 0.5 * r.sample_rate_hz)
      << log.source.string() << ": the cut-off " << options.cutoff_hz
      << " Hz is not below half the sample rate (" << r.sample_rate_hz << " Hz)";
  r.design = telemetry::DesignLowPass(options.filter, options.filter_order, options.cutoff_hz, r.sample_rate_hz);
  // The channels are read row by row below, gaps filled and low-passed on the way: a usable
  // channel has at least two valid samples.
  auto usable = [&](Channel c) {
    if (!s.Has(c) || !HasValid(s.value[static_cast<int>(c)], 2)) return false;
    r.channels_used.push_back(telemetry::ToString(c));
    return true;
  };
  auto filtered = [&](Channel c, std::optional<FilteredChannel>* channel) {
    channel->emplace(t, s.value[static_cast<int>(c)], r.design, options.mode);
  };

  // Wheels: cumulative metres.
  const Channel wheel_channels[4] = {Channel::kEncoderFrontLeft, Channel::kEncoderFrontRight,
                                     Channel::kEncoderRearLeft, Channel::kEncoderRearRight};
  std::array<std::optional<FilledChannel>, 4> wheels;
  std::array<bool, 4> have_wheel{};
  std::array<double, 4> wheel_resolution_m{};
  int wheel_count = 0;
  for (int i = 0; i < 4; ++i) {
    if (!usable(wheel_channels[i])) continue;
    const double mpc = model[wheel_channels[i]].MetresPerCount();
    wheels[i].emplace(t, s.value[static_cast<int>(wheel_channels[i])], mpc);
    have_wheel[i] = true;
    wheel_resolution_m[i] = std::abs(mpc);
    ++wheel_count;
  }
  LN_CHECK_INPUT(wheel_count > 0) << log.source.string() << ": no usable encoder channel";

  // Pitch: the mean of the filtered left and right inclinometers.
  std::optional<FilteredChannel> pitch_left, pitch_right, roll, heading_lowpass;
  if (usable(Channel::kPitchLeft)) filtered(Channel::kPitchLeft, &pitch_left);
  if (usable(Channel::kPitchRight)) filtered(Channel::kPitchRight, &pitch_right);
  if (pitch_left.has_value() != pitch_right.has_value()) {
    r.notes.push_back("one pitch inclinometer: pitch from the other");
  } else if (!pitch_left) {
    r.notes.push_back("no pitch inclinometers: flat ground (z = 0)");
  }
  if (usable(Channel::kRoll)) filtered(Channel::kRoll, &roll);

  // Heading.
  const int compass = static_cast<int>(Channel::kCompass), gyro = static_cast<int>(Channel::kGyroZ);
  const bool have_compass = s.Has(Channel::kCompass) && HasValid(s.value[compass], 2);
  if (have_compass) r.channels_used.push_back(telemetry::ToString(Channel::kCompass));
  const bool have_gyro = s.Has(Channel::kGyroZ) && HasValid(s.value[gyro], 1);
  if (have_gyro) r.channels_used.push_back("gyro_z");
  std::optional<telemetry::HeadingKalman> kalman;
  double constant_heading = 0;
  if (options.heading == HeadingMethod::kLowPass && have_compass) {
    filtered(Channel::kCompass, &heading_lowpass);
  } else if (have_compass || have_gyro) {
    if (options.heading == HeadingMethod::kLowPass) {
      r.notes.push_back("no compass: heading from the gyro by the Kalman filter");
    }
    if (!have_compass) r.notes.push_back("no compass: heading from the gyro, relative to the start");
    double first_compass = kNaN;
    for (std::size_t k = 0; have_compass && std::isnan(first_compass); ++k) first_compass = s.value[compass][k];
    kalman.emplace(options.kalman, first_compass);
    r.kalman_used = true;
  } else {
    r.notes.push_back("no compass and no gyro: constant heading");
    constant_heading = options.kalman.initial_heading_deg * M_PI / 180.0;
  }

  // Row by row: fill, filter, Kalman heading, dead reckoning, and the pose out.
  const bool keep = !sink;  // no sink: the result holds the trajectory and the heading streams
  if (keep) {
    r.motion.trajectory.resize(n);
    if (r.kalman_used) {
      r.heading.heading_rad.resize(n);
      r.heading.rate_radps.resize(n);
      r.heading.heading_sigma_rad.resize(n);
    }
  }
  DeadReckoner reckoner(options.dead_reckoning, have_wheel, wheel_resolution_m);
  std::array<double, 4> wheel_m{}, last_wheel_m{};
  std::size_t still_since = 0;  // first row of the current stretch with no wheel moving
  for (std::size_t k = 0; k < n; ++k) {
    bool moved = false;
    for (int i = 0; i < 4; ++i) {
      if (!have_wheel[i]) continue;
      wheel_m[i] = wheels[i]->At(k);
      if (k > 0 && std::abs(wheel_m[i] - last_wheel_m[i]) > 1e-9) moved = true;
    }
    last_wheel_m = wheel_m;
    double pitch = 0;
    if (pitch_left && pitch_right) {
      const double left = pitch_left->At(k);
      pitch = 0.5 * (left + pitch_right->At(k));
    } else if (pitch_left) {
      pitch = pitch_left->At(k);
    } else if (pitch_right) {
      pitch = pitch_right->At(k);
    }
    double heading = constant_heading;
    if (heading_lowpass) {
      heading = heading_lowpass->At(k);
    } else if (kalman) {
      // Stationary: no wheel has moved over the last stationary_min_s.
      if (moved) still_since = k;
      const bool stationary = k > 0 && !moved && t[k] - t[still_since] >= options.stationary_min_s;
      const telemetry::HeadingKalman::Output e = kalman->Update(
          t[k], have_compass ? s.value[compass][k] : kNaN, have_gyro ? s.value[gyro][k] : kNaN, stationary);
      heading = e.heading_rad;
      if (keep) {
        r.heading.heading_rad[k] = e.heading_rad;
        r.heading.rate_radps[k] = e.rate_radps;
        r.heading.heading_sigma_rad[k] = e.heading_sigma_rad;
      }
    }
    const TrajectorySample& pose = reckoner.Step(t[k], heading, pitch, roll ? roll->At(k) : 0.0, wheel_m);
    if (keep) {
      r.motion.trajectory[k] = pose;
    } else {  // the attitude from the half angles the dead reckoning has made already
      sink(pose, EnuFromBody(reckoner.half_heading(), reckoner.half_pitch(), HalfAngle::Of(pose.roll_rad)));
    }
    if (k + 1 == n) r.motion.last_pose = pose;
  }
  r.motion.distance_m = reckoner.distance_m();
  r.motion.slip_events = reckoner.slip_events();
  r.motion.steps_without_odometry = reckoner.steps_without_odometry();
  if (kalman) {
    r.heading.gyro_bias_radps = kalman->gyro_bias_radps();
    r.heading.gyro_scale_error = kalman->gyro_scale_error();
    r.heading.gyro_scale_sigma = kalman->gyro_scale_sigma();
    r.heading.compass_updates = kalman->compass_updates();
    r.heading.gyro_updates = kalman->gyro_updates();
  }
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
    const std::size_t row = s.Row(k);
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
  if (!screened.t_s.empty()) {
    const TrajectorySample& last = motion.last_pose;
    j["motion"]["final_position_m"] = {last.x_m, last.y_m, last.z_m};
  }
  return j;
}

}  // namespace lunarnav::positioning
