#include "positioning/posfilter.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <deque>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <tuple>
#include <utility>

#include "io/atomic_file.h"
#include "positioning/baseline.h"
#include "util/check.h"
#include "util/format.h"

namespace lunarnav::positioning {
namespace {

using telemetry::Channel;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// The tilt's low-pass cut-off is at most this fraction of the sample rate.
constexpr double kTiltCutoffMaxFraction = 0.4;
constexpr double kGravity = 9.80665;  // m/s^2
// The fixed-lag smoother's blocks: its backward pass runs over this many rows and `lag` more.
constexpr std::size_t kSmootherBlockRows = 1024;
// The heading smoother's blocks: its backward pass runs over this many rows and the lag more.
constexpr std::size_t kHeadingBlockRows = 8192;

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
  LN_CHECK_ARG(tilt_cutoff_hz >= 0 && std::isfinite(tilt_cutoff_hz)) << "tilt cutoff: must be > 0 Hz (0: the default)";
  LN_CHECK_ARG(stationary_min_s > 0) << "stationary time: must be > 0";
  LN_CHECK_ARG(heading_lag_s >= 0 && std::isfinite(heading_lag_s) && heading_lag_s <= 3600)
      << "heading lag: must be in [0, 3600] s";
  LN_CHECK_ARG(block_rows >= 1) << "block rows: must be >= 1";
  LN_CHECK_ARG(baseline_interval_s > 0 && baseline_drift_fraction > 0 && baseline_heading_drift_dps >= 0)
      << "baseline: interval and drift fraction must be > 0, heading drift >= 0";
  dead_reckoning.Validate();
}

nlohmann::json PosfilterOptions::ToJson() const {
  return {{"screening", screening.ToJson()},
          {"filter", {{"type", telemetry::ToString(filter)}, {"order", filter_order}, {"cutoff_hz", cutoff_hz},
                      {"tilt_cutoff_hz", TiltCutoffHz()}, {"mode", ToString(mode)}}},
          {"attitude", smooth_attitude ? "smoothed" : "filtered"},
          {"heading", ToString(heading)},
          {"heading_lag_s", heading_lag_s},
          {"kalman", kalman.ToJson()},
          {"slip", {{"fraction", dead_reckoning.slip_fraction}, {"min_m", dead_reckoning.slip_min_m},
                    {"window_s", dead_reckoning.slip_window_s},
                    {"resolution_counts", dead_reckoning.slip_resolution_counts}}},
          {"stationary_min_s", stationary_min_s},
          {"baseline", {{"interval_s", baseline_interval_s}, {"drift_fraction", baseline_drift_fraction},
                        {"heading_drift_dps", baseline_heading_drift_dps}}}};
}

namespace {

using telemetry::ScreeningStream;

// A screened channel read row by row, in order, with its gaps filled (linear interpolation in
// time between the valid samples around a gap, the end values held) and scaled: the same
// numbers as a filled copy of the channel, without one. Reads the stream's held rows, bound
// by Bind() after each change of them.
class FilledChannel {
 public:
  FilledChannel(Channel c, double scale) : c_(static_cast<int>(c)), scale_(scale) {}
  void Bind(const ScreeningStream& stream) {
    rows_ = stream.rows();
    finished_ = stream.finished();
  }
  // Rows before the result can be read: the gap a row is in has both its ends known (or the
  // log has ended). Scans each row once.
  std::size_t ReadyEnd(std::size_t final_end) {
    if (finished_ && final_end == rows_.end) return final_end;
    scanned_ = std::max(scanned_, rows_.begin);
    for (; scanned_ < final_end; ++scanned_) {
      if (!std::isnan(rows_.value[c_][scanned_ - rows_.begin])) ready_end_ = scanned_ + 1;
    }
    return ready_end_;
  }
  double At(std::size_t k) {
    const double value = rows_.value[c_][k - rows_.begin];
    if (!std::isnan(value)) {
      have_last_ = true;
      last_t_ = rows_.t_s[k - rows_.begin];
      last_v_ = value;
      return value * scale_;
    }
    if (next_ <= k) {  // the valid sample after this gap
      next_ = k + 1;
      while (next_ < rows_.end && std::isnan(rows_.value[c_][next_ - rows_.begin])) ++next_;
      if (next_ < rows_.end) {
        next_t_ = rows_.t_s[next_ - rows_.begin];
        next_v_ = rows_.value[c_][next_ - rows_.begin];
      }
    }
    if (!have_last_) return next_v_ * scale_;
    if (next_ >= rows_.end) return last_v_ * scale_;  // none: the log has ended
    const double f = (rows_.t_s[k - rows_.begin] - last_t_) / (next_t_ - last_t_);
    return (last_v_ + f * (next_v_ - last_v_)) * scale_;
  }

 private:
  int c_;
  double scale_;
  ScreeningStream::Rows rows_;
  bool finished_ = false;
  std::size_t scanned_ = 0, ready_end_ = 0;
  bool have_last_ = false;
  double last_t_ = 0, last_v_ = 0, next_t_ = 0, next_v_ = 0;
  std::size_t next_ = 0;
};

// A channel as dead reckoning takes it: filled, then low-passed, causally sample by sample
// or (zero phase) from an array filtered beforehand over the whole log, which is then held.
class FilteredChannel {
 public:
  FilteredChannel(const ScreeningStream& stream, Channel c, const telemetry::LowPassDesign& design, FilterMode mode)
      : filled_(c, 1.0) {
    filled_.Bind(stream);
    if (mode == FilterMode::kZeroPhase) {
      LN_CHECK(stream.begin() == 0) << "posfilter: zero-phase filtering needs the whole log held";
      std::vector<double> filled(stream.end());
      for (std::size_t k = 0; k < filled.size(); ++k) filled[k] = filled_.At(k);
      zero_phase_ = telemetry::FilterZeroPhase(design, filled);
    } else {
      causal_.emplace(design, filled_.At(0));  // starts in the steady state of the first sample
    }
  }
  void Bind(const ScreeningStream& stream) { filled_.Bind(stream); }
  std::size_t ReadyEnd(std::size_t final_end) { return causal_ ? filled_.ReadyEnd(final_end) : final_end; }
  double At(std::size_t k) { return causal_ ? (*causal_)(filled_.At(k)) : zero_phase_[k]; }

 private:
  FilledChannel filled_;
  std::optional<telemetry::CausalLowPass> causal_;
  std::vector<double> zero_phase_;
};

// A series low-passed forward and backward as it streams (zero phase: the magnitude squared,
// no delay), a fixed-lag smoother: the forward pass runs row by row as the values come; the
// backward pass over blocks of kSmootherBlockRows rows (or `lag`, if more), each started `lag`
// rows beyond the block's end (at the log's end: from its last row) in the steady state of
// the forward output there, so that the rows differ from a whole-log forward-backward filter
// only by what the backward start leaves after `lag` rows. The blocks are fixed rows of the
// log, so the values do not depend on how the log is read. `input(k)` gives row k's value,
// called once per row, in order.
class SmoothedSeries {
 public:
  SmoothedSeries(const telemetry::LowPassDesign& design, std::size_t lag, std::function<double(std::size_t)> input)
      : design_(design),
        lag_(std::max<std::size_t>(lag, 1)),
        block_(std::max(lag_, kSmootherBlockRows)),
        input_(std::move(input)) {}
  // Takes rows up to `end` (all readable by input) forward; the rows whose smoothed value
  // can be read end at the result (every row once the log is complete).
  std::size_t ReadyEnd(std::size_t end, bool log_complete) {
    for (; forward_end_ < end; ++forward_end_) {
      const double x = input_(forward_end_);
      if (!forward_filter_) forward_filter_.emplace(design_, x);
      forward_.push_back((*forward_filter_)(x));
    }
    complete_ = log_complete;
    if (complete_) return ready_end_ = forward_end_;
    // Whole blocks whose backward start (lag rows beyond them) has come.
    ready_end_ = forward_end_ >= lag_ ? (forward_end_ - lag_) / block_ * block_ : 0;
    return ready_end_;
  }
  // Row k's smoothed value: k not before the last row read, before ReadyEnd's result.
  double At(std::size_t k) {
    if (k >= block_end_) Smooth(k);
    return smoothed_[k - block_begin_];
  }

 private:
  void Smooth(std::size_t k) {
    LN_CHECK(k >= forward_begin_ && k < ready_end_) << "posfilter: smoothed row " << k << " not ready";
    block_begin_ = k / block_ * block_;
    block_end_ = std::min(block_begin_ + block_, forward_end_);
    const std::size_t start = std::min(block_end_ + lag_, forward_end_);  // one past the backward start
    LN_CHECK(block_begin_ >= forward_begin_ && (complete_ || start == block_end_ + lag_))
        << "posfilter: smoothed block at row " << block_begin_ << " not ready";
    forward_.erase(forward_.begin(), forward_.begin() + static_cast<std::ptrdiff_t>(block_begin_ - forward_begin_));
    forward_begin_ = block_begin_;
    smoothed_.assign(block_end_ - block_begin_, 0.0);
    telemetry::CausalLowPass backward(design_, forward_[start - 1 - forward_begin_]);
    for (std::size_t i = start; i-- > block_begin_;) {
      const double y = backward(forward_[i - forward_begin_]);
      if (i < block_end_) smoothed_[i - block_begin_] = y;
    }
  }
  telemetry::LowPassDesign design_;
  std::size_t lag_, block_;
  std::function<double(std::size_t)> input_;
  std::optional<telemetry::CausalLowPass> forward_filter_;
  std::vector<double> forward_;  // rows [forward_begin_, forward_end_)
  std::size_t forward_begin_ = 0, forward_end_ = 0, ready_end_ = 0;
  bool complete_ = false;
  std::vector<double> smoothed_;  // rows [block_begin_, block_end_)
  std::size_t block_begin_ = 0, block_end_ = 0;
};

// The attitude reported with smooth_attitude: each tilt's readings and the wheels' mean speed
// smoothed (SmoothedSeries, each through readers of the stream of its own), then the
// vehicle's acceleration, which an inclinometer reads as tilt, taken out: speeding up reads as
// nose up (pitch + atan(a / g)), a right turn's centripetal acceleration as the left side down
// (roll - atan(v r / g)).
class SmoothedAttitude {
 public:
  // `lag`: rows the smoother looks ahead; `tilts`: pitch left, pitch right, roll (present or
  // not); `wheels` with their metres per count.
  SmoothedAttitude(const telemetry::LowPassDesign& design, std::size_t lag, const std::array<bool, 3>& tilts,
                   const std::vector<std::pair<Channel, double>>& wheels) {
    const Channel tilt_channels[3] = {Channel::kPitchLeft, Channel::kPitchRight, Channel::kRoll};
    for (int i = 0; i < 3; ++i) {
      if (!tilts[i]) continue;
      auto t = std::make_unique<Tilt>(tilt_channels[i]);
      Tilt* raw = t.get();
      t->series.emplace(design, lag, [raw](std::size_t k) { return raw->filled.At(k); });
      tilt_[i] = std::move(t);
    }
    for (const auto& [channel, metres_per_count] : wheels) wheels_.emplace_back(channel, metres_per_count);
    // The speed over [t_k, t_k+1] (the log's last row: the one before).
    speed_.emplace(design, lag, [this](std::size_t k) {
      if (k == 0) distance_next_ = Distance(0);
      if (k + 1 < distance_end_) {
        const double d0 = distance_next_, t0 = T(k);
        distance_next_ = Distance(k + 1);
        const double dt = T(k + 1) - t0;
        if (dt > 0) last_speed_ = (distance_next_ - d0) / dt;
      }
      return last_speed_;
    });
  }

  // Binds the readers to the stream's rows; the rows whose attitude can be read end at the result.
  std::size_t ReadyEnd(const ScreeningStream& s) {
    rows_ = s.rows();
    std::size_t ready = s.final_end();
    for (auto& t : tilt_) {
      if (!t) continue;
      t->filled.Bind(s);
      const std::size_t filled_end = t->filled.ReadyEnd(s.final_end());
      ready = std::min(ready, t->series->ReadyEnd(filled_end, s.finished() && filled_end == s.end()));
    }
    std::size_t wheels_end = s.final_end();
    for (FilledChannel& w : wheels_) {
      w.Bind(s);
      wheels_end = std::min(wheels_end, w.ReadyEnd(s.final_end()));
    }
    const bool complete = s.finished() && wheels_end == s.end();
    // A row's speed needs the next row's distance (the log's last row has none).
    distance_end_ = wheels_end;
    return std::min(ready, speed_->ReadyEnd(complete || wheels_end == 0 ? wheels_end : wheels_end - 1, complete));
  }

  // Row k's pitch and roll, radians (0 for a tilt without inclinometers); `turn_rate`: the
  // heading's rate (rad/s, turning right positive; NaN: unknown, no centripetal correction).
  std::pair<double, double> At(std::size_t k, double turn_rate) {
    const double speed = speed_->At(k), speed_before = k == 0 ? speed : speed_before_;
    const double t = T(k), t_before = k == 0 ? t : t_before_;
    const double t_after = k + 1 < rows_.end ? T(k + 1) : t;
    speed_before_ = speed;
    t_before_ = t;
    // The speeds are the intervals' before and after row k.
    const double accel = t_after > t_before ? (speed - speed_before) / (0.5 * (t_after - t_before)) : 0.0;
    const double v = 0.5 * (speed + speed_before);
    double pitch = 0, roll = 0;
    if (tilt_[0] || tilt_[1]) {
      const double left = tilt_[0] ? tilt_[0]->series->At(k) : kNaN, right = tilt_[1] ? tilt_[1]->series->At(k) : kNaN;
      const double reading = !tilt_[0] ? right : !tilt_[1] ? left : 0.5 * (left + right);
      const double correction = std::atan(accel / kGravity);
      pitch = reading - correction;
      pitch_correction_max_ = std::max(pitch_correction_max_, std::abs(correction));
    }
    if (tilt_[2]) {
      const double correction = std::isfinite(turn_rate) ? std::atan(v * turn_rate / kGravity) : 0.0;
      roll = tilt_[2]->series->At(k) + correction;
      roll_correction_max_ = std::max(roll_correction_max_, std::abs(correction));
    }
    return {pitch, roll};
  }
  double pitch_correction_max() const { return pitch_correction_max_; }
  double roll_correction_max() const { return roll_correction_max_; }

 private:
  struct Tilt {
    explicit Tilt(Channel c) : filled(c, 1.0) {}
    FilledChannel filled;
    std::optional<SmoothedSeries> series;
  };
  double T(std::size_t k) const { return rows_.t_s[k - rows_.begin]; }
  double Distance(std::size_t k) {
    double sum = 0;
    for (FilledChannel& w : wheels_) sum += w.At(k);
    return sum / static_cast<double>(wheels_.size());
  }
  std::array<std::unique_ptr<Tilt>, 3> tilt_;
  std::vector<FilledChannel> wheels_;
  std::optional<SmoothedSeries> speed_;
  ScreeningStream::Rows rows_;
  std::size_t distance_end_ = 0;  // rows whose distance is known
  double distance_next_ = 0, last_speed_ = 0;
  double speed_before_ = 0, t_before_ = 0;
  double pitch_correction_max_ = 0, roll_correction_max_ = 0;
};

// The heading with heading_lag_s: the Kalman filter of sec. 4.1 runs forward as the rows come
// (the same filter, the same numbers as without the smoother), and the Rauch-Tung-Striebel
// smoother backward over fixed blocks of rows, each block's pass started `lag` rows beyond it
// (at the log's end, from its last row), as soon as those rows have come: the values do not
// depend on how the log is read (as SmoothedSeries). After a turn the compass, trusted again,
// corrects the heading and the gyro's scale; the smoother carries that back over the turn,
// where the filter had the gyro alone. The stationary periods (the gyro's bias) come from its
// own readers of the wheels. Held: the filter's steps from the first block not yet smoothed
// (a block and the lag), and the smoothed rows not yet read.
class SmoothedHeading {
 public:
  SmoothedHeading(const telemetry::HeadingKalmanOptions& options, double first_compass, std::size_t lag,
                  const std::vector<std::pair<Channel, double>>& wheels, double stationary_min_s, bool have_compass,
                  bool have_gyro)
      : filter_(options, first_compass),
        lag_(std::max<std::size_t>(lag, 1)),
        block_(std::max(lag_, kHeadingBlockRows)),
        stationary_min_s_(stationary_min_s),
        have_compass_(have_compass),
        have_gyro_(have_gyro) {
    for (const auto& [channel, metres_per_count] : wheels) wheels_.emplace_back(channel, metres_per_count);
    wheel_m_.assign(wheels_.size(), 0.0);
  }

  // Runs the filter over the rows whose readings are known and smooths the blocks whose
  // backward start has come; the rows whose smoothed heading can be read end at the result
  // (every row once the log is complete).
  std::size_t ReadyEnd(const ScreeningStream& s) {
    const ScreeningStream::Rows rows = s.rows();
    std::size_t end = s.final_end();
    for (FilledChannel& w : wheels_) {
      w.Bind(s);
      end = std::min(end, w.ReadyEnd(s.final_end()));
    }
    const bool complete = s.finished() && end == s.end();
    const double* compass = s.Has(Channel::kCompass) ? rows.value[static_cast<int>(Channel::kCompass)] : nullptr;
    const double* gyro = s.Has(Channel::kGyroZ) ? rows.value[static_cast<int>(Channel::kGyroZ)] : nullptr;
    for (; forward_end_ < end; ++forward_end_) {
      const std::size_t k = forward_end_, i = k - rows.begin;
      const double t = rows.t_s[i];
      // Stationary: no wheel has moved over the last stationary_min_s.
      bool moved = false;
      for (std::size_t w = 0; w < wheels_.size(); ++w) {
        const double metres = wheels_[w].At(k);
        if (k > 0 && std::abs(metres - wheel_m_[w]) > 1e-9) moved = true;
        wheel_m_[w] = metres;
      }
      if (moved || k == 0) still_since_t_ = t;
      const bool stationary = k > 0 && !moved && t - still_since_t_ >= stationary_min_s_;
      steps_.emplace_back();
      const telemetry::HeadingKalman::Output e =
          filter_.Update(t, have_compass_ && compass != nullptr ? compass[i] : kNaN,
                         have_gyro_ && gyro != nullptr ? gyro[i] : kNaN, stationary, &steps_.back());
      sigma_.push_back(e.heading_sigma_rad);
      if (forward_end_ + 1 == smoothed_end_ + block_ + lag_) SmoothBlocks(forward_end_ + 1, false);
    }
    SmoothBlocks(forward_end_, complete);
    return smoothed_end_;
  }

  // Row k's smoothed heading and rate, and the filter's sigma: rows read in order, each
  // before ReadyEnd's result.
  telemetry::HeadingKalman::Output At(std::size_t k) {
    LN_CHECK(k >= out_begin_ && k < smoothed_end_) << "posfilter: smoothed heading row " << k << " not ready";
    while (out_begin_ < k) {  // the rows before k are done with
      out_.pop_front();
      ++out_begin_;
    }
    return out_.front();
  }
  const telemetry::HeadingKalman& filter() const { return filter_; }
  // The largest change of the heading the smoother made to the filter's, radians.
  double correction_max() const { return correction_max_; }

 private:
  // Smooths each block whose backward start (lag rows beyond it) is among the rows before
  // `forward_end`, or every row left when the log is complete.
  void SmoothBlocks(std::size_t forward_end, bool complete) {
    while (smoothed_end_ < forward_end && (complete || smoothed_end_ + block_ + lag_ <= forward_end)) {
      const std::size_t block_end = std::min(smoothed_end_ + block_, forward_end);
      const std::size_t start = std::min(block_end + lag_, forward_end);  // one past the backward start
      const std::size_t n = start - smoothed_end_, offset = smoothed_end_ - steps_begin_;
      heading_.resize(n);
      rate_.resize(n);
      telemetry::SmoothHeadingSteps(std::span(steps_).subspan(offset, n), heading_, rate_);
      for (std::size_t j = 0; j < block_end - smoothed_end_; ++j) {
        out_.push_back({heading_[j], rate_[j], sigma_[offset + j]});
        correction_max_ = std::max(correction_max_, std::abs(heading_[j] - steps_[offset + j].x[0]));
      }
      smoothed_end_ = block_end;
      // The steps of the block are done with.
      steps_.erase(steps_.begin(), steps_.begin() + static_cast<std::ptrdiff_t>(smoothed_end_ - steps_begin_));
      sigma_.erase(sigma_.begin(), sigma_.begin() + static_cast<std::ptrdiff_t>(smoothed_end_ - steps_begin_));
      steps_begin_ = smoothed_end_;
    }
  }

  telemetry::HeadingKalman filter_;
  std::size_t lag_, block_;
  double stationary_min_s_;
  bool have_compass_, have_gyro_;
  std::vector<FilledChannel> wheels_;
  std::vector<double> wheel_m_;
  double still_since_t_ = 0;
  std::vector<telemetry::HeadingKalmanStep> steps_;  // rows [steps_begin_, forward_end_)
  std::vector<double> sigma_;                        // the same rows
  std::size_t steps_begin_ = 0, forward_end_ = 0, smoothed_end_ = 0;
  std::vector<double> heading_, rate_;               // a backward pass's output
  std::deque<telemetry::HeadingKalman::Output> out_;  // rows [out_begin_, smoothed_end_)
  std::size_t out_begin_ = 0;
  double correction_max_ = 0;
};

// Rows from a source, screened as they come. Next() reads and screens one more block.
class ScreenedRows {
 public:
  using Source = ScreeningStream::Source;
  // `rows_at_most`: an upper bound on the rows still to come (for ReserveWholeLog).
  ScreenedRows(Source source, const std::array<bool, telemetry::kNumChannels>& present,
               const telemetry::SensorModel& model, const PosfilterOptions& options, const ProgressFn& progress,
               std::function<double()> fraction, std::function<std::size_t()> rows_at_most)
      : source_(std::move(source)),
        stream_(model, options.screening, present),
        block_rows_(options.block_rows),
        progress_(progress),
        fraction_(std::move(fraction)),
        rows_at_most_(std::move(rows_at_most)) {}
  ScreeningStream& stream() { return stream_; }
  // The whole log will be held: room for it at once (and a block more: a reader grows the
  // arrays by a block before it cuts them to the rows it read).
  void ReserveWholeLog() { stream_.Reserve(stream_.end() - stream_.begin() + rows_at_most_() + block_rows_); }
  // False when the log had already ended.
  bool Next() {
    if (stream_.finished()) return false;
    const std::size_t n = stream_.Read(source_, block_rows_);
    rows_read_ += n;
    if (n == 0) stream_.Finish();
    if (progress_) progress_(fraction_());
    return true;
  }
  std::size_t rows_read() const { return rows_read_; }

 private:
  Source source_;
  ScreeningStream stream_;
  std::size_t block_rows_;
  ProgressFn progress_;
  std::function<double()> fraction_;
  std::function<std::size_t()> rows_at_most_;
  std::size_t rows_read_ = 0;
};

PosfilterResult Run(ScreenedRows& input, const std::string& source, const telemetry::SensorModel& model,
                    const PosfilterOptions& options, const PoseSink& sink) {
  PosfilterResult r;
  ScreeningStream& s = input.stream();
  // The statistics window first: it sets the sample rate and so the filters.
  while (!s.statistics_ready()) input.Next();
  LN_CHECK_INPUT(!s.finished() || s.end() >= 2) << source << ": fewer than two usable rows";
  r.sample_rate_hz = 1.0 / s.typical_interval_s();
  LN_CHECK_INPUT(options.cutoff_hz < 0.5 * r.sample_rate_hz)
      << source << ": the cut-off " << options.cutoff_hz << " Hz is not below half the sample rate ("
      << r.sample_rate_hz << " Hz)";
  r.design = telemetry::DesignLowPass(options.filter, options.filter_order, options.cutoff_hz, r.sample_rate_hz);
  // The tilt's cut-off, at most kTiltCutoffMaxFraction of the sample rate (slow telemetry,
  // e.g. 2.5 Hz: 1 Hz).
  r.tilt_design = telemetry::DesignLowPass(options.filter, options.filter_order,
                                           std::min(options.TiltCutoffHz(), kTiltCutoffMaxFraction * r.sample_rate_hz),
                                           r.sample_rate_hz);

  // Which channels are used: those with two valid samples (the gyro: one), which may take
  // reading on. The first compass reading starts the heading filter.
  const int compass = static_cast<int>(Channel::kCompass), gyro = static_cast<int>(Channel::kGyroZ);
  std::array<std::size_t, telemetry::kNumChannels> valid{};
  double first_compass = kNaN;
  auto needed = [&](int c) -> std::size_t { return s.Has(static_cast<Channel>(c)) ? (c == gyro ? 1 : 2) : 0; };
  for (std::size_t scanned = 0;;) {
    const ScreeningStream::Rows rows = s.rows();
    bool decided = true;
    for (int c = 0; c < telemetry::kNumChannels; ++c) {
      if (valid[c] >= needed(c)) continue;
      for (std::size_t k = scanned; k < s.final_end() && valid[c] < needed(c); ++k) {
        const double v = rows.value[c][k - rows.begin];
        if (std::isnan(v)) continue;
        if (c == compass && valid[c] == 0) first_compass = v;
        ++valid[c];
      }
      decided = decided && valid[c] >= needed(c);
    }
    scanned = s.final_end();
    if (decided || s.finished()) break;
    input.Next();
  }
  // Zero-phase filtering runs over the whole log.
  if (options.mode == FilterMode::kZeroPhase) {
    input.ReserveWholeLog();
    while (input.Next()) {
    }
  }
  LN_CHECK_INPUT(s.end() >= 2) << source << ": fewer than two usable rows";
  auto usable = [&](Channel c) {
    if (valid[static_cast<int>(c)] < 2) return false;
    r.channels_used.push_back(telemetry::ToString(c));
    return true;
  };
  std::vector<FilteredChannel*> look_ahead;  // channels whose gaps are filled
  std::vector<FilledChannel*> wheel_look_ahead;
  auto filtered = [&](Channel c, std::optional<FilteredChannel>* channel,
                      const telemetry::LowPassDesign& design) {
    channel->emplace(s, c, design, options.mode);
    look_ahead.push_back(&**channel);
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
    wheels[i].emplace(wheel_channels[i], mpc);
    wheel_look_ahead.push_back(&*wheels[i]);
    have_wheel[i] = true;
    wheel_resolution_m[i] = std::abs(mpc);
    ++wheel_count;
  }
  LN_CHECK_INPUT(wheel_count > 0) << source << ": no usable encoder channel";

  // Pitch: the mean of the filtered left and right inclinometers. Twice: through the paper's
  // low-pass for the dead reckoning (sec. 4.2: it integrates the path, where a rover's tilt
  // vibration would bias the cosine) and through the tilt's for the attitude reported.
  struct Tilt {
    std::optional<FilteredChannel> motion, attitude;
    explicit operator bool() const { return motion.has_value(); }
  };
  Tilt pitch_left, pitch_right, roll;
  std::optional<FilteredChannel> heading_lowpass;
  auto tilt = [&](Channel c, Tilt* t) {
    if (!usable(c)) return;
    filtered(c, &t->motion, r.design);
    if (!options.smooth_attitude) filtered(c, &t->attitude, r.tilt_design);
  };
  tilt(Channel::kPitchLeft, &pitch_left);
  tilt(Channel::kPitchRight, &pitch_right);
  if (static_cast<bool>(pitch_left) != static_cast<bool>(pitch_right)) {
    r.notes.push_back("one pitch inclinometer: pitch from the other");
  } else if (!pitch_left) {
    r.notes.push_back("no pitch inclinometers: flat ground (z = 0)");
  }
  tilt(Channel::kRoll, &roll);

  // The attitude smoothed (options.smooth_attitude).
  std::optional<SmoothedAttitude> smoothed;
  if (options.smooth_attitude) {
    r.attitude_lag_s = kSmootherLagCutoffs / r.tilt_design.cutoff_hz;
    std::vector<std::pair<Channel, double>> wheel_models;
    for (int i = 0; i < 4; ++i) {
      if (have_wheel[i]) wheel_models.emplace_back(wheel_channels[i], model[wheel_channels[i]].MetresPerCount());
    }
    smoothed.emplace(r.tilt_design, static_cast<std::size_t>(std::ceil(r.attitude_lag_s * r.sample_rate_hz)),
                     std::array<bool, 3>{static_cast<bool>(pitch_left), static_cast<bool>(pitch_right),
                                         static_cast<bool>(roll)},
                     wheel_models);
  }

  // Heading.
  const bool have_compass = valid[compass] >= 2;
  if (have_compass) r.channels_used.push_back(telemetry::ToString(Channel::kCompass));
  const bool have_gyro = valid[gyro] >= 1;
  if (have_gyro) r.channels_used.push_back("gyro_z");
  std::optional<telemetry::HeadingKalman> kalman;
  std::optional<SmoothedHeading> smoothed_heading;  // the heading smoothed (options.heading_lag_s)
  double constant_heading = 0;
  if (options.heading == HeadingMethod::kLowPass && have_compass) {
    filtered(Channel::kCompass, &heading_lowpass, r.design);
  } else if (have_compass || have_gyro) {
    if (options.heading == HeadingMethod::kLowPass) {
      r.notes.push_back("no compass: heading from the gyro by the Kalman filter");
    }
    if (!have_compass) r.notes.push_back("no compass: heading from the gyro, relative to the start");
    // Only observable states are estimated: the gyro's scale needs a heading reference.
    telemetry::HeadingKalmanOptions kalman_options = options.kalman;
    if (!have_compass) kalman_options.gyro_scale_sigma = 0;
    // The gyro's noise from the sensor file, when stated.
    const telemetry::ChannelModel& gyro_model = model[Channel::kGyroZ];
    if (gyro_model.noise_rms > 0) {
      kalman_options.gyro_sigma_dps =
          gyro_model.units == "rad/s" ? gyro_model.noise_rms * 180.0 / M_PI : gyro_model.noise_rms;
    } else if (s.rate_noise_from_log(Channel::kGyroZ) && s.rate_noise(Channel::kGyroZ) > 0) {
      kalman_options.gyro_sigma_dps = s.rate_noise(Channel::kGyroZ) * 180.0 / M_PI;  // as estimated from the log
    }
    // The heading rate changes as fast as the vehicle can turn: with its angular acceleration
    // stated, the rate state may change by that much per sample interval (one sigma), so that
    // an abrupt turn is followed, not lagged (a lagging rate would be taken for scale error).
    if (model.vehicle.max_turn_accel_dps2) {
      kalman_options.rate_walk_dps2 = std::max(kalman_options.rate_walk_dps2,
                                               *model.vehicle.max_turn_accel_dps2 * std::sqrt(s.typical_interval_s()));
    }
    r.kalman_rate_walk_dps2 = kalman_options.rate_walk_dps2;
    if (options.heading_lag_s > 0) {
      r.heading_lag_s = options.heading_lag_s;
      std::vector<std::pair<Channel, double>> wheel_models;
      for (int i = 0; i < 4; ++i) {
        if (have_wheel[i]) wheel_models.emplace_back(wheel_channels[i], model[wheel_channels[i]].MetresPerCount());
      }
      smoothed_heading.emplace(kalman_options, have_compass ? first_compass : kNaN,
                               static_cast<std::size_t>(std::ceil(options.heading_lag_s * r.sample_rate_hz)),
                               wheel_models, options.stationary_min_s, have_compass, have_gyro);
    } else {
      kalman.emplace(kalman_options, have_compass ? first_compass : kNaN);
    }
    r.kalman_used = true;
  } else {
    r.notes.push_back("no compass and no gyro: constant heading");
    constant_heading = options.kalman.initial_heading_deg * M_PI / 180.0;
  }

  // The plain baseline, from the same rows' raw counts, starting at the same heading.
  const double start_heading = (kalman || smoothed_heading) && have_compass ? first_compass
                               : heading_lowpass      ? first_compass
                                                      : options.kalman.initial_heading_deg * M_PI / 180.0;
  PlainDeadReckoner baseline(model, have_wheel, have_gyro, start_heading, options.stationary_min_s);
  double next_baseline_t = -std::numeric_limits<double>::infinity();
  std::array<int, 4> wheel_index{};
  for (int w = 0; w < 4; ++w) wheel_index[w] = static_cast<int>(wheel_channels[w]);

  // Row by row: fill, filter, Kalman heading, dead reckoning, and the row out, for the rows
  // whose look-ahead is known; then the next block.
  const bool keep = !sink;  // no sink: the result holds the trajectory and the heading streams
  DeadReckoner reckoner(options.dead_reckoning, have_wheel, wheel_resolution_m);
  std::array<double, 4> wheel_m{};  // this row's (the last row's until set)
  double still_since_t = 0;  // start of the current stretch with no wheel moving
  PoseOutput out;
  out.heading_rate_radps = kNaN;
  HalfAngleTracker pitch_half, roll_half;  // for the attitude
  std::size_t k = 0;
  while (true) {
    const ScreeningStream::Rows rows = s.rows();
    std::size_t ready = s.final_end();
    for (FilledChannel* c : wheel_look_ahead) {
      c->Bind(s);
      ready = std::min(ready, c->ReadyEnd(s.final_end()));
    }
    for (FilteredChannel* c : look_ahead) {
      c->Bind(s);
      ready = std::min(ready, c->ReadyEnd(s.final_end()));
    }
    if (smoothed) ready = std::min(ready, smoothed->ReadyEnd(s));
    if (smoothed_heading) ready = std::min(ready, smoothed_heading->ReadyEnd(s));
    const double* const compass_value = s.Has(Channel::kCompass) ? rows.value[compass] : nullptr;
    const double* const gyro_value = s.Has(Channel::kGyroZ) ? rows.value[gyro] : nullptr;
    const double* const compass_raw = s.Has(Channel::kCompass) ? rows.raw[compass] : nullptr;
    const double* const gyro_raw = s.Has(Channel::kGyroZ) ? rows.raw[gyro] : nullptr;
    for (; k < ready; ++k) {
      const std::size_t i = k - rows.begin;
      const double tk = rows.t_s[i];
      bool moved = false;
      for (int w = 0; w < 4; ++w) {
        if (!have_wheel[w]) continue;
        const double metres = wheels[w]->At(k);
        if (k > 0 && std::abs(metres - wheel_m[w]) > 1e-9) moved = true;
        wheel_m[w] = metres;
      }
      // The pitch through either low-pass.
      auto pitch_of = [&](std::optional<FilteredChannel> Tilt::*which) {
        if (pitch_left && pitch_right) {
          const double left = (pitch_left.*which)->At(k);
          return 0.5 * (left + (pitch_right.*which)->At(k));
        }
        if (pitch_left) return (pitch_left.*which)->At(k);
        if (pitch_right) return (pitch_right.*which)->At(k);
        return 0.0;
      };
      const double pitch = pitch_of(&Tilt::motion);
      const double attitude_pitch = options.smooth_attitude ? 0.0 : pitch_of(&Tilt::attitude);
      const double roll_motion = roll ? roll.motion->At(k) : 0.0;
      const double attitude_roll = roll && !options.smooth_attitude ? roll.attitude->At(k) : 0.0;
      double heading = constant_heading;
      if (heading_lowpass) {
        heading = heading_lowpass->At(k);
      } else if (kalman || smoothed_heading) {
        telemetry::HeadingKalman::Output e;
        if (smoothed_heading) {
          e = smoothed_heading->At(k);
        } else {
          // Stationary: no wheel has moved over the last stationary_min_s.
          if (moved || k == 0) still_since_t = tk;
          const bool stationary = k > 0 && !moved && tk - still_since_t >= options.stationary_min_s;
          e = kalman->Update(tk, have_compass ? compass_value[i] : kNaN, have_gyro ? gyro_value[i] : kNaN, stationary);
        }
        heading = e.heading_rad;
        out.heading_rate_radps = e.rate_radps;
        if (keep) {
          r.heading.heading_rad.push_back(e.heading_rad);
          r.heading.rate_radps.push_back(e.rate_radps);
          r.heading.heading_sigma_rad.push_back(e.heading_sigma_rad);
        }
      }
      TrajectorySample pose = reckoner.Step(tk, heading, pitch, roll_motion, wheel_m);
      if (smoothed) {
        std::tie(pose.pitch_rad, pose.roll_rad) = smoothed->At(k, out.heading_rate_radps);
      } else {
        pose.pitch_rad = attitude_pitch;
        pose.roll_rad = attitude_roll;
      }
      std::array<double, 4> counts;
      for (int w = 0; w < 4; ++w) counts[w] = have_wheel[w] ? rows.raw[wheel_index[w]][i] : kNaN;
      baseline.Step(tk, counts, have_gyro ? gyro_raw[i] : kNaN);
      out.baseline = nullptr;
      // The baseline moves at the encoders' samples: its pose is written at one (between
      // them it would be the last sample's position stamped later, up to an interval late).
      bool encoder_row = false;
      for (int w = 0; w < 4; ++w) encoder_row = encoder_row || !std::isnan(counts[w]);
      if (encoder_row && tk >= next_baseline_t) {
        next_baseline_t = (next_baseline_t < tk - options.baseline_interval_s ? tk : next_baseline_t) +
                          options.baseline_interval_s;
        if (keep) r.baseline_trajectory.push_back(baseline.pose());
        out.baseline = &baseline.pose();
      }
      if (keep) {
        r.motion.trajectory.push_back(pose);
      } else {  // the attitude from the half angles the dead reckoning has made already
        out.pose = pose;
        out.enu_from_body =
            EnuFromBody(reckoner.half_heading(), pitch_half(pose.pitch_rad), roll_half(pose.roll_rad));
        out.compass_count = compass_raw != nullptr ? compass_raw[i] : kNaN;
        out.gyro_count = gyro_raw != nullptr ? gyro_raw[i] : kNaN;
        sink(out);
      }
      r.motion.last_pose = pose;
    }
    if (options.mode == FilterMode::kCausal) s.Release(k);
    if (!input.Next()) {
      LN_CHECK(k == s.end()) << "posfilter: rows left at the end of the log";
      break;
    }
  }
  if (smoothed) {
    r.pendulum_pitch_max_rad = smoothed->pitch_correction_max();
    r.pendulum_roll_max_rad = smoothed->roll_correction_max();
  }
  r.motion.distance_m = reckoner.distance_m();
  r.motion.slip_events = reckoner.slip_events();
  r.motion.steps_without_odometry = reckoner.steps_without_odometry();
  if (smoothed_heading) r.heading_correction_max_rad = smoothed_heading->correction_max();
  if (kalman || smoothed_heading) {
    const telemetry::HeadingKalman& filter = kalman ? *kalman : smoothed_heading->filter();
    r.heading.gyro_bias_radps = filter.gyro_bias_radps();
    r.heading.gyro_scale_error = filter.gyro_scale_error();
    r.heading.gyro_scale_sigma = filter.gyro_scale_sigma();
    r.heading.compass_updates = filter.compass_updates();
    r.heading.gyro_updates = filter.gyro_updates();
  }
  r.rows_read = input.rows_read();
  r.screened = s.report();
  // The baseline: its last pose (also in the trajectory when it was not output there).
  r.baseline_last_pose = baseline.pose();
  if (keep && (r.baseline_trajectory.empty() || r.baseline_trajectory.back().t_s < baseline.pose().t_s)) {
    r.baseline_trajectory.push_back(baseline.pose());
  }
  r.baseline_distance_m = baseline.distance_m();
  r.baseline_gyro_bias_radps = baseline.gyro_bias_radps();
  r.baseline_bias_known = baseline.gyro_bias_known();
  r.baseline_end_difference_m = std::hypot(r.motion.last_pose.x_m - r.baseline_last_pose.x_m,
                                           r.motion.last_pose.y_m - r.baseline_last_pose.y_m);
  const double path_m = std::max(r.motion.distance_m, r.baseline_distance_m);
  const double duration_s = r.screened.rows == 0 ? 0.0 : r.screened.last_t_s - r.screened.first_t_s;
  const double heading_drift_rad =
      std::min(options.baseline_heading_drift_dps * M_PI / 180.0 * duration_s, M_PI / 2);
  r.baseline_expected_drift_m = path_m * (options.baseline_drift_fraction + 0.5 * heading_drift_rad);
  if (r.baseline_end_difference_m > r.baseline_expected_drift_m) {
    r.warnings.push_back(util::Format(
                  "the filtered trajectory ends %.2f m from the plain baseline's end, more than the %.2f m the two "
                  "may drift apart (%.0f %% of %.1f m, and %.1f deg of gyro drift in %.0f s): check the screening "
                  "counts and the heading filter's states (docs/posfilter.md, \"Baseline\")",
                  r.baseline_end_difference_m, r.baseline_expected_drift_m, 100 * options.baseline_drift_fraction,
                  path_m, heading_drift_rad * 180 / M_PI, duration_s));
  }
  for (const telemetry::ScreenedLog::Share& w : r.screened.Warnings()) r.warnings.push_back(w.Message());
  // Which states were estimated.
  if (kalman || smoothed_heading) {
    const telemetry::HeadingKalman& filter = kalman ? *kalman : smoothed_heading->filter();
    r.states["gyro_scale"] = have_compass && options.kalman.gyro_scale_sigma > 0
                                 ? "estimated (compass)"
                             : have_compass ? "held at prior 0 (no scale state configured)"
                                            : "held at prior 0 (no compass: the scale is not observable)";
    const long still = filter.stationary_samples();
    const std::string bias_sigma = util::Format("%.3f", filter.gyro_bias_sigma_radps() * 180.0 / M_PI);
    r.states["gyro_bias"] =
        !options.kalman.estimate_gyro_bias ? "held at prior 0 (bias estimation off)"
        : still > 0 ? "estimated from " + std::to_string(filter.stationary_periods()) + " stationary period(s), " +
                          std::to_string(still) + " samples" +
                          (filter.gyro_bias_prior_from_compass() ? " (the compass's estimate before the first as prior)" : "")
        : filter.gyro_bias_from_compass()
            ? std::string("estimated from the compass (no stationary period), sigma ") + bias_sigma + " deg/s"
            : std::string("held at prior 0 (no compass and no stationary period: the bias is not observable)");
  }
  return r;
}

}  // namespace

PosfilterResult RunPosfilter(telemetry::TelemetryReader& reader, const telemetry::SensorModel& model,
                             const PosfilterOptions& options, const PoseSink& sink, const ProgressFn& progress) {
  options.Validate();
  std::array<bool, telemetry::kNumChannels> present{};
  for (Channel c : telemetry::kAllChannels) present[static_cast<int>(c)] = reader.Has(c);
  ScreenedRows input([&reader](telemetry::TelemetryLog* out, std::size_t max_rows) { return reader.Read(out, max_rows); },
                     present, model, options, progress, [&reader] { return reader.FractionRead(); },
                     [&reader] { return reader.LinesLeft(); });
  return Run(input, reader.source().string(), model, options, sink);
}

PosfilterResult RunPosfilter(const telemetry::TelemetryLog& log, const telemetry::SensorModel& model,
                             const PosfilterOptions& options, const PoseSink& sink) {
  options.Validate();
  std::array<bool, telemetry::kNumChannels> present{};
  for (Channel c : telemetry::kAllChannels) present[static_cast<int>(c)] = log.Has(c);
  std::size_t next = 0;  // the log in blocks, as a reader gives it
  auto source = [&](telemetry::TelemetryLog* out, std::size_t max_rows) {
    const std::size_t n = std::min(max_rows, log.size() - next);
    out->t_s.insert(out->t_s.end(), log.t_s.begin() + next, log.t_s.begin() + next + n);
    out->line.insert(out->line.end(), log.line.begin() + next, log.line.begin() + next + n);
    for (Channel c : telemetry::kAllChannels) {
      const std::vector<double>& from = log.counts[static_cast<int>(c)];
      if (!from.empty()) out->counts[static_cast<int>(c)].insert(out->counts[static_cast<int>(c)].end(),
                                                                 from.begin() + next, from.begin() + next + n);
    }
    next += n;
    return n;
  };
  ScreenedRows input(source, present, model, options, {},
                     [&] { return log.size() == 0 ? 1.0 : static_cast<double>(next) / log.size(); },
                     [&] { return log.size() - next; });
  return Run(input, log.source.string(), model, options, sink);
}

struct HeadingStreamsWriter::Impl {
  explicit Impl(const std::filesystem::path& path) : file(path) {}
  io::AtomicOutputFile file;
  telemetry::ChannelModel compass, gyro;
  std::string text;
};

HeadingStreamsWriter::HeadingStreamsWriter(const std::filesystem::path& path, const telemetry::SensorModel& model)
    : impl_(std::make_unique<Impl>(path)) {
  impl_->compass = model[Channel::kCompass];
  impl_->gyro = model[Channel::kGyroZ];
  impl_->text = "# lunarnav heading streams: raw sensors and filtered estimates (deg, deg/s)\n"
                "t_s,compass_raw_deg,heading_deg,gyro_raw_dps,heading_rate_dps\n";
}

HeadingStreamsWriter::~HeadingStreamsWriter() = default;

void HeadingStreamsWriter::Add(const PoseOutput& row) {
  const double deg = 180.0 / M_PI;
  auto angle = [](double d) { d = std::fmod(d, 360.0); return d < 0 ? d + 360.0 : d; };
  // (util::Format: a sensor file's scale may make any value; a fixed buffer would cut the row.)
  std::string& text = impl_->text;
  text += std::to_string(row.pose.t_s);
  text += ',';
  if (!std::isnan(row.compass_count)) {
    text += util::Format("%.4f", angle(impl_->compass.ToRadians(row.compass_count) * deg));
  }
  text += util::Format(",%.4f,", angle(row.pose.heading_rad * deg));
  if (!std::isnan(row.gyro_count)) text += util::Format("%.4f", impl_->gyro.ToRadians(row.gyro_count) * deg);
  text += ',';
  if (!std::isnan(row.heading_rate_radps)) text += util::Format("%.4f", row.heading_rate_radps * deg);
  text += '\n';
  if (text.size() >= (1 << 20)) {
    impl_->file.Write(text);
    text.clear();
  }
}

void HeadingStreamsWriter::Commit() {
  impl_->file.Write(impl_->text);
  impl_->text.clear();
  impl_->file.Commit();
}

nlohmann::json PosfilterResult::SummaryJson() const {
  nlohmann::json j;
  j["rows_used"] = screened.rows;
  j["sample_rate_hz"] = sample_rate_hz;
  j["channels_used"] = channels_used;
  j["notes"] = notes;
  j["screening"] = screened.ReportJson();
  j["lowpass"] = design.ToJson();
  j["lowpass_tilt"] = tilt_design.ToJson();
  j["attitude"] = {{"smoothed", attitude_lag_s > 0}};
  if (attitude_lag_s > 0) {
    j["attitude"]["lag_s"] = attitude_lag_s;
    j["attitude"]["acceleration_correction_max_deg"] = {{"pitch", pendulum_pitch_max_rad * 180.0 / M_PI},
                                                        {"roll", pendulum_roll_max_rad * 180.0 / M_PI}};
  }
  if (kalman_used) {
    j["heading_kalman"] = {{"compass_updates", heading.compass_updates},
                           {"gyro_updates", heading.gyro_updates},
                           {"gyro_bias_dps", heading.gyro_bias_radps * 180.0 / M_PI},
                           {"gyro_scale_error", heading.gyro_scale_error},
                           {"gyro_scale_sigma", heading.gyro_scale_sigma},
                           {"rate_walk_dps2", kalman_rate_walk_dps2},
                           {"smoothed", heading_lag_s > 0}};
    if (heading_lag_s > 0) {
      j["heading_kalman"]["lag_s"] = heading_lag_s;
      j["heading_kalman"]["smoother_correction_max_deg"] = heading_correction_max_rad * 180.0 / M_PI;
    }
  }
  j["states"] = states;
  j["baseline"] = {{"file", "baseline.csv"},
                   {"distance_m", baseline_distance_m},
                   {"gyro_bias_dps", baseline_gyro_bias_radps * 180.0 / M_PI},
                   {"gyro_bias_from_stationary_period", baseline_bias_known},
                   {"final_position_m", {baseline_last_pose.x_m, baseline_last_pose.y_m}},
                   {"end_difference_m", baseline_end_difference_m},
                   {"expected_drift_m", baseline_expected_drift_m},
                   {"parted", baseline_end_difference_m > baseline_expected_drift_m}};
  j["warnings"] = warnings;
  const double duration = screened.rows == 0 ? 0.0 : screened.last_t_s - screened.first_t_s;
  j["motion"] = {{"distance_m", motion.distance_m},
                 {"duration_s", duration},
                 {"slip_events", motion.slip_events},
                 {"steps_without_odometry", motion.steps_without_odometry}};
  if (screened.rows > 0) {
    const TrajectorySample& last = motion.last_pose;
    j["motion"]["final_position_m"] = {last.x_m, last.y_m, last.z_m};
  }
  return j;
}

}  // namespace lunarnav::positioning
