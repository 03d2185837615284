#include "telemetry/screening.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <type_traits>

#include "io/atomic_file.h"
#include "util/check.h"
#include "util/small_median.h"

namespace lunarnav::telemetry {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr int kRowSlot = kNumChannels;
// A rate-limit rejection run this long means the signal really moved: accept it from there
// (and the run's samples too when they lead to it within the limit: the first samples of a
// real jolt, rejected only while it was not yet confirmed).
constexpr int kRebaselineAfter = 3;

// Median of value(0), ..., value(count - 1), for estimates of a typical interval or noise
// level: long sequences are subsampled evenly to at most 65536 values (plenty for a robust
// level, and linear time), and only those values are computed.
template <typename Value>
double SubsampledQuantile(std::size_t count, double fraction, Value value) {
  constexpr std::size_t kMaxSamples = 65536;
  const std::size_t stride = count > kMaxSamples ? (count + kMaxSamples - 1) / kMaxSamples : 1;
  std::vector<double> v;
  v.reserve(count / stride + 1);
  for (std::size_t i = 0; i < count; i += stride) v.push_back(value(i));
  if (v.empty()) return kNaN;
  const auto at = static_cast<std::size_t>(fraction * static_cast<double>(v.size() - 1) + 0.5);
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(at), v.end());
  return v[at];
}
template <typename Value>
double SubsampledMedian(std::size_t count, Value value) {
  return SubsampledQuantile(count, 0.5, value);
}

// A channel's white-noise sigma from `count` second differences d2(q) of its samples,
// robustly: their variance is 6 sigma^2, and 1.4826 x the median of |d2| estimates their
// sigma ignoring the few abrupt changes and faults (a smooth trend adds little).
template <typename SecondDifference>
double NoiseOfSecondDifferences(std::size_t count, SecondDifference d2) {
  return 1.4826 * SubsampledMedian(count, [&](std::size_t q) { return std::abs(d2(q)); }) / std::sqrt(6.0);
}

// The noise as the rate limit needs it: the larger of the sigma above and the sigma that the
// 90th percentile of |d2| implies for Gaussian noise (1.645 sqrt(6) sigma). For Gaussian noise
// both agree; a real accelerometer's tilt, whose vibration comes in bursts while driving (heavy
// tails: on a real rover's log the 99th percentile of its sample-to-sample change is 8 times the
// median), gets the scale of its bursts, so the rate limit rejects under 1 % of its samples
// rather than 2 %, and faults up to a tenth of the samples do not move it.
template <typename SecondDifference>
double RateNoiseOfSecondDifferences(std::size_t count, SecondDifference d2) {
  const double tail = SubsampledQuantile(count, 0.9, [&](std::size_t q) { return std::abs(d2(q)); }) /
                      (1.6449 * std::sqrt(6.0));
  return std::max(NoiseOfSecondDifferences(count, d2), tail);
}

// The spike test's shortcut for the interior samples q in [b, e) of a channel's queue (see
// HampelTests: the half window 3): the trend (the median of the six slopes joining the seven
// samples q - 3 ... q + 3) and the farthest of their residuals from sample q, into
// farthest_of[q - b]; slope[] (e - b + 5 values: the steps from q - 3 to q + 3 of every q) is
// scratch. Reads value[] and time[] at b - 3 ... e + 2 only. A branch-free loop the compiler
// vectorises, built twice on x86-64 (four lanes with AVX2, two with SSE2, chosen when the
// program starts); both do the same arithmetic (no fused multiply-add), so they decide alike.
#if defined(__x86_64__) && defined(__GNUC__)
__attribute__((target_clones("avx2", "default")))
#endif
void ShortcutDistances(const double* value, const double* time, std::size_t b, std::size_t e, double* slope,
                       double* farthest_of) {
  for (std::size_t q = b - 2; q < e + 3; ++q) {
    slope[q - (b - 2)] = (value[q] - value[q - 1]) / (time[q] - time[q - 1]);
  }
  for (std::size_t q = b; q < e; ++q) {
    double sl[6];
    for (std::size_t i = 0; i < 6; ++i) sl[i] = slope[q - b + i];
    const double trend = util::MedianOf6(sl);
    const double mine = value[q];
    double farthest = 0;
    for (std::size_t i = 0; i < 7; ++i) {
      const std::size_t w = q - 3 + i;
      farthest = std::max(farthest, std::abs(mine - (value[w] - trend * (time[w] - time[q]))));
    }
    farthest_of[q - b] = farthest;
  }
}

enum Kind { kEncoderKind, kCompassKind, kAnalogKind };

}  // namespace

class ScreeningStream::Impl {
 public:
  Impl(const SensorModel& model, const ScreeningOptions& options, const std::array<bool, kNumChannels>& present)
      : model_(model), o_(options), window_rows_(options.statistics_intervals + 1) {
    options.Validate();
    out_.warning_share = o_.warning_share;
    for (Channel c : kAllChannels) {
      const int ch = static_cast<int>(c);
      ChannelState& s = ch_[ch];
      s.present = present[ch];
      if (!s.present) continue;
      const ChannelModel& m = model_[c];
      const bool encoder = IsEncoder(c);
      s.kind = encoder ? kEncoderKind : c == Channel::kCompass ? kCompassKind : kAnalogKind;
      s.hampel = !encoder;
      s.full_scale = std::ldexp(1.0, m.bits) - 1.0;
      s.period = std::ldexp(1.0, m.counter_bits);
      // The vehicle's limits: the sensor file's, else the options' defaults.
      const VehicleLimits& vehicle = model_.vehicle;
      if (encoder) {
        s.limit = vehicle.max_speed_mps.value_or(o_.max_speed_mps) / std::abs(m.MetresPerCount());
        s.slack = o_.rate_slack_counts;
      } else {
        const double unit = std::abs(m.ToRadians(1.0) - m.ToRadians(0.0));  // radians per count
        // Two samples' noise may part them by rate_noise_sigmas x sqrt(2) x noise_rms.
        const double deg = M_PI / 180.0;
        const double noise = m.units == "rad" || m.units == "rad/s" ? m.noise_rms : m.noise_rms * deg;
        s.slack = o_.rate_slack_counts * unit + o_.rate_noise_sigmas * std::sqrt(2.0) * noise;
        s.noise_from_log = m.noise_rms <= 0 && o_.estimate_missing_noise;  // estimated from the statistics window
        out_.rate_noise[ch] = noise;
        if (c == Channel::kCompass) s.limit = vehicle.max_turn_rate_dps.value_or(o_.max_turn_rate_dps) * deg;
        else if (c == Channel::kGyroZ) s.limit = vehicle.max_turn_accel_dps2.value_or(o_.max_turn_accel_dps2) * deg;
        else s.limit = vehicle.max_tilt_rate_dps.value_or(o_.max_tilt_rate_dps) * deg;
        out_.rate_limit[ch] = s.limit;
        out_.rate_slack[ch] = s.slack;
        // Counts to radians is linear: precomputed, not called per sample.
        s.radians_at_zero = m.ToRadians(0.0);
        s.radians_per_count = m.ToRadians(1.0) - s.radians_at_zero;
        s.min_dev = o_.hampel_min_counts * unit;
      }
    }
    for (Channel c : kAllChannels) {
      ChannelState& s = ch_[static_cast<int>(c)];
      if (s.present) s.correlated = CorrelatedChannels(c);
    }
  }

  // Appends rows read by `source` to the held ones, and screens them.
  std::size_t Read(const ScreeningStream::Source& source, std::size_t max_rows) {
    LN_CHECK(!finished_) << "screening: rows read after the end";
    const std::size_t from = t_.size();
    const std::size_t n = source(&held_, max_rows);
    if (n > 0) Accept(from);
    return n;
  }

  void Push(const TelemetryLog& rows) {
    LN_CHECK(!finished_) << "screening: rows pushed after the end";
    if (rows.size() == 0) return;
    const std::size_t from = t_.size();
    t_.insert(t_.end(), rows.t_s.begin(), rows.t_s.end());
    line_.insert(line_.end(), rows.line.begin(), rows.line.end());
    for (int ch = 0; ch < kNumChannels; ++ch) {
      if (ch_[ch].present) raw_[ch].insert(raw_[ch].end(), rows.counts[ch].begin(), rows.counts[ch].end());
    }
    Accept(from);
  }

  // The rows appended from element `from` on: rows repeating or going back in time are
  // dropped (and moved out), the others kept; then every rule runs.
  void Accept(std::size_t from) {
    const std::size_t to = t_.size(), n = to - from;
    // The usual block, time stamps increasing throughout, is kept whole.
    double previous = out_.rows > 0 ? out_.last_t_s : -std::numeric_limits<double>::infinity();
    std::size_t increasing = from;
    while (increasing < to && t_[increasing] > previous) previous = t_[increasing++];
    if (increasing == to) {
      if (dropped_ > 0) {
        log_row_.resize(to);
        for (std::size_t i = from; i < to; ++i) log_row_[i] = rows_read_ + (i - from);
      }
      if (out_.rows == 0) out_.first_t_s = t_[from];
      out_.last_t_s = t_[to - 1];
      out_.rows += n;
    } else {
      std::size_t kept = from;
      for (std::size_t i = from; i < to; ++i) {
        const double t = t_[i];
        if (out_.rows > 0 && (t == out_.last_t_s || t < out_.last_t_s)) {
          const ScreeningRule rule =
              t == out_.last_t_s ? ScreeningRule::kRepeatedTimestamp : ScreeningRule::kOutOfOrderTimestamp;
          out_.events.push_back({line_[i], t, -1, rule, t});
          ++out_.counts[static_cast<int>(rule)][kRowSlot];
          if (dropped_++ == 0) {  // the rows' indices in the log, kept from now on (so far each was its own)
            log_row_.resize(kept);
            for (std::size_t r = 0; r < kept; ++r) log_row_[r] = base_ + r;
          }
          continue;
        }
        t_[kept] = t;
        line_[kept] = line_[i];
        for (int ch = 0; ch < kNumChannels; ++ch) {
          if (ch_[ch].present) raw_[ch][kept] = raw_[ch][i];
        }
        if (dropped_ > 0) log_row_.push_back(rows_read_ + (i - from));
        if (out_.rows == 0) out_.first_t_s = t;
        out_.last_t_s = t;
        ++out_.rows;
        ++kept;
      }
      t_.resize(kept);
      line_.resize(kept);
      for (int ch = 0; ch < kNumChannels; ++ch) {
        if (ch_[ch].present) raw_[ch].resize(kept);
      }
    }
    for (int ch = 0; ch < kNumChannels; ++ch) {
      if (ch_[ch].present) value_[ch].resize(t_.size(), kNaN);
    }
    rows_read_ += n;
    Pump();
  }

  void Finish() {
    if (finished_) return;
    finished_ = true;
    Pump();
    std::stable_sort(out_.events.begin(), out_.events.end(), [](const ScreeningEvent& a, const ScreeningEvent& b) {
      if (a.line != b.line) return a.line < b.line;
      if (a.channel != b.channel) return a.channel < b.channel;
      return a.rule < b.rule;
    });
  }

  bool finished() const { return finished_; }
  bool statistics_ready() const { return statistics_ready_; }
  bool Has(Channel c) const { return ch_[static_cast<int>(c)].present; }
  std::size_t begin() const { return base_; }
  std::size_t end() const { return out_.rows; }
  std::size_t final_end() const { return final_end_; }
  double t(std::size_t k) const { return t_[k - base_]; }
  long line(std::size_t k) const { return line_[k - base_]; }
  double raw(Channel c, std::size_t k) const { return raw_[static_cast<int>(c)][k - base_]; }
  double value(Channel c, std::size_t k) const { return value_[static_cast<int>(c)][k - base_]; }
  const ScreenedLog& report() const { return out_; }
  ScreeningStream::Rows rows() const {
    ScreeningStream::Rows r;
    r.begin = base_;
    r.end = out_.rows;
    r.t_s = t_.data();
    for (int ch = 0; ch < kNumChannels; ++ch) {
      if (!ch_[ch].present) continue;
      r.raw[ch] = raw_[ch].data();
      r.value[ch] = value_[ch].data();
    }
    return r;
  }

  void Release(std::size_t k) {
    LN_CHECK(k <= final_end_) << "screening: rows released before they are final";
    const std::size_t drop = k - base_, held = out_.rows - base_;
    // Rows are erased in batches of at least half of those held: each row is moved O(1)
    // times on average, however long the look-ahead.
    if (drop < 1024 || 2 * drop < held) return;
    auto erase_front = [drop](auto& v) { v.erase(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(drop)); };
    erase_front(t_);
    erase_front(line_);
    if (!log_row_.empty()) erase_front(log_row_);
    for (int ch = 0; ch < kNumChannels; ++ch) {
      if (!ch_[ch].present) continue;
      erase_front(raw_[ch]);
      erase_front(value_[ch]);
    }
    base_ = k;
  }

  void Reserve(std::size_t rows) {
    t_.reserve(rows);
    line_.reserve(rows);
    for (int ch = 0; ch < kNumChannels; ++ch) {
      if (!ch_[ch].present) continue;
      raw_[ch].reserve(rows);
      value_[ch].reserve(rows);
    }
  }

  ScreenedLog TakeAll() {
    LN_CHECK(finished_ && base_ == 0) << "screening: the whole log is not held";
    ScreenedLog all = std::move(out_);
    all.t_s = std::move(t_);
    if (dropped_ > 0) all.row = std::move(log_row_);
    for (int ch = 0; ch < kNumChannels; ++ch) {
      if (ch_[ch].present) all.value[ch] = std::move(value_[ch]);
    }
    return all;
  }

 private:
  enum class Typical { kUnknown, kKnown, kNone };

  struct ChannelState {
    bool present = false;
    Kind kind = kAnalogKind;
    bool hampel = false;  // analog channels get the spike test
    double full_scale = 0, period = 0, limit = 0, slack = 0, radians_at_zero = 0, radians_per_count = 0;
    bool noise_from_log = false;  // the slack waits for the noise estimated from the log
    // Range, rails, rate limit and unwrapping, against the last accepted sample.
    std::size_t pass_end = 0;  // rows before it have been through them
    bool have_last = false;
    double last_raw = 0, last_value = 0, last_t = 0;
    int rejected_run = 0;
    // The run's rejected samples (rows, values, times), kept until the run is decided: their
    // rows are not final before (hampel_end stops at the first).
    std::array<std::size_t, kRebaselineAfter - 1> run_row{};
    std::array<double, kRebaselineAfter - 1> run_value{}, run_t{}, run_raw{};
    std::array<bool, kRebaselineAfter - 1> run_wrapped{};  // an encoder's counter wrapped there
    // Dropouts: silences longer than gap_factor x the channel's typical interval.
    Typical typical_state = Typical::kUnknown;
    double dropout_limit = 0;   // gap_factor x typical interval
    double last_present_t = kNaN;
    std::vector<ScreeningEvent> first_samples;  // while the interval is unknown
    // Spike test over the accepted samples, which are queued for it: accepted sample p is
    // element p - queue_base.
    std::vector<double> queue_value, queue_t;
    std::vector<std::size_t> queue_row;
    std::size_t queue_base = 0, accepted_in_window = 0, tested = 0;
    std::size_t accepted() const { return queue_base + queue_value.size(); }  // samples queued so far
    Typical sigma_state = Typical::kUnknown;
    double channel_sigma = 0, smallest_threshold = 0, min_dev = 0;
    std::size_t hampel_end = 0;  // rows before it have had their spike test
    // Stuck runs: the scan position and the run open there.
    std::vector<Channel> correlated;
    std::size_t stuck_end = 0;  // rows before it are final
    bool in_run = false;
    std::size_t run_last_valid = 0, run_next = 0;
  };

  // Rare (a fault): kept out of the rules' loops, which stay tight.
  [[gnu::noinline, gnu::cold]] void Record(std::size_t k, int channel, ScreeningRule rule, double raw) {
    out_.events.push_back({line_[k - base_], t_[k - base_], channel, rule, raw});
    ++out_.counts[static_cast<int>(rule)][channel < 0 ? kRowSlot : channel];
  }

  // Runs every rule as far as the rows so far allow.
  void Pump() {
    if (!statistics_ready_) {
      if (out_.rows < window_rows_ && !finished_) return;
      RowStatistics();
    }
    GapStage();
    for (Channel c : kAllChannels) {
      ChannelState& s = ch_[static_cast<int>(c)];
      if (!s.present) continue;
      if (s.typical_state == Typical::kUnknown && s.pass_end == 0) ChannelInterval(c);
      if (s.noise_from_log && s.pass_end == 0) NoiseFromLog(c);
      PassStage(c);
      if (s.typical_state == Typical::kUnknown && finished_) s.typical_state = Typical::kNone;
      if (s.hampel) {
        HampelStage(c);
      } else {
        s.hampel_end = s.pass_end;
      }
      // A rate-limit run still open may yet be restored: its rows are not decided.
      if (s.rejected_run > 0 && !finished_) s.hampel_end = std::min(s.hampel_end, s.run_row[0]);
    }
    final_end_ = out_.rows;
    for (Channel c : kAllChannels) {
      ChannelState& s = ch_[static_cast<int>(c)];
      if (!s.present) continue;
      StuckStage(c);
      final_end_ = std::min(final_end_, s.stuck_end);
    }
  }

  // The rows' typical interval, from the statistics window.
  void RowStatistics() {
    statistics_ready_ = true;
    const std::size_t n = std::min(out_.rows, window_rows_);
    if (n >= 2) {
      out_.typical_interval_s = SubsampledMedian(n - 1, [&](std::size_t k) { return t_[k + 1] - t_[k]; });
    }
    gap_limit_ = o_.gap_factor * out_.typical_interval_s;
  }

  void GapStage() {
    for (std::size_t k = std::max<std::size_t>(gap_next_, 1); k < out_.rows; ++k) {
      if (t_[k - base_] - t_[k - 1 - base_] > gap_limit_) Record(k, -1, ScreeningRule::kGap, t_[k - base_]);
    }
    gap_next_ = out_.rows;
  }

  // The channel's typical interval from its samples in the statistics window (the rows are
  // all held then): known with three samples or more, else left to the first three.
  void ChannelInterval(Channel c) {
    ChannelState& s = ch_[static_cast<int>(c)];
    const std::vector<double>& raw = raw_[static_cast<int>(c)];
    const std::size_t n = std::min(out_.rows, window_rows_);
    // Present in every row (the usual channel): the rows' intervals, so the rows' median.
    if (n >= 3 && std::none_of(raw.begin(), raw.begin() + static_cast<std::ptrdiff_t>(n),
                               [](double x) { return std::isnan(x); })) {
      SetChannelInterval(&s, out_.typical_interval_s);
      return;
    }
    std::vector<double> present_t;
    for (std::size_t k = 0; k < n; ++k) {
      if (!std::isnan(raw[k])) present_t.push_back(t_[k]);
    }
    if (present_t.size() < 3) return;
    SetChannelInterval(
        &s, SubsampledMedian(present_t.size() - 1, [&](std::size_t i) { return present_t[i + 1] - present_t[i]; }));
  }
  // A channel whose noise the sensor file does not state: its noise from its samples in the
  // statistics window (the rows are all held then), the robust sigma of their second
  // differences (for white noise their variance is 6 sigma^2; a smooth motion adds little,
  // and the median ignores the few abrupt changes and faults), and the rate limit's slack
  // from it as from a stated noise_rms. Without it an accelerometer's tilt, which vibrates
  // by a degree or more while driving, had a third of its samples rejected.
  void NoiseFromLog(Channel c) {
    ChannelState& s = ch_[static_cast<int>(c)];
    s.noise_from_log = false;
    const ChannelModel& m = model_[c];
    const std::vector<double>& raw = raw_[static_cast<int>(c)];
    const std::size_t n = std::min(out_.rows, window_rows_);
    std::vector<double> value;
    for (std::size_t k = 0; k < n; ++k) {
      const double r = raw[k];
      if (std::isnan(r) || r < m.valid_min || r > m.valid_max || r == 0 || r == s.full_scale) continue;
      value.push_back(s.radians_at_zero + s.radians_per_count * r);
    }
    if (value.size() < 8) return;  // too few: the slack stays the counts' alone
    const double noise = RateNoiseOfSecondDifferences(value.size() - 2, [&](std::size_t q) {
      const double d2 = value[q + 2] - 2.0 * value[q + 1] + value[q];
      return s.kind == kCompassKind ? std::remainder(d2, 2.0 * M_PI) : d2;  // across +-180 deg
    });
    s.slack += o_.rate_noise_sigmas * std::sqrt(2.0) * noise;
    out_.rate_slack[static_cast<int>(c)] = s.slack;
    out_.rate_noise[static_cast<int>(c)] = noise;
    out_.rate_noise_from_log[static_cast<int>(c)] = true;
  }
  void SetChannelInterval(ChannelState* s, double typical) {
    s->typical_state = Typical::kKnown;
    s->dropout_limit = o_.gap_factor * typical;
  }

  // Range and rails, then conversion, unwrapping and the rate limit against the last accepted
  // sample, over the rows not yet seen; also dropouts, and the accepted samples queued for the
  // spike test.
  void PassStage(Channel c) {
    const ChannelState& s = ch_[static_cast<int>(c)];
    // The loop is compiled once per kind of channel, so that none of those tests is made per
    // sample.
    switch (s.kind) {
      case kEncoderKind: Pass<kEncoderKind>(c); break;
      case kCompassKind: Pass<kCompassKind>(c); break;
      case kAnalogKind: Pass<kAnalogKind>(c); break;
    }
  }

  template <Kind kind>
  void Pass(Channel c) {
    const int ch = static_cast<int>(c);
    ChannelState& s = ch_[ch];
    const ChannelModel& m = model_[c];
    const double* const raw = raw_[ch].data();
    double* const v = value_[ch].data();
    const double* const t = t_.data();
    const std::size_t b = base_;
    const double valid_min = static_cast<double>(m.valid_min), valid_max = static_cast<double>(m.valid_max);
    // The state in locals (the stores to v and the calls to Record cannot touch them).
    bool have_last = s.have_last;
    double last_raw = s.last_raw, last_value = s.last_value, last_t = s.last_t;
    int rejected_run = s.rejected_run;
    Typical typical_state = s.typical_state;
    double last_present_t = s.last_present_t, dropout_limit = s.dropout_limit;
    const double limit = s.limit, slack = s.slack, period = s.period, full_scale = s.full_scale;
    const double radians_at_zero = s.radians_at_zero, radians_per_count = s.radians_per_count;
    // Accepted samples are queued for the spike test by index, into the queue grown by the
    // rows at hand (cut back to the samples queued after the loop).
    std::size_t queued = s.queue_value.size();
    double* queue_value = nullptr;
    double* queue_t = nullptr;
    std::size_t* queue_row = nullptr;
    std::size_t accepted_in_window = s.accepted_in_window;
    long samples = 0;  // present in the rows passed
    if constexpr (kind != kEncoderKind) {
      const std::size_t room = queued + (out_.rows - s.pass_end) + kRebaselineAfter;  // a run restored
      s.queue_value.resize(room);
      s.queue_t.resize(room);
      s.queue_row.resize(room);
      queue_value = s.queue_value.data();
      queue_t = s.queue_t.data();
      queue_row = s.queue_row.data();
    }
    for (std::size_t k = s.pass_end; k < out_.rows; ++k) {
      const std::size_t i = k - b;
      const double r = raw[i];
      if (std::isnan(r)) continue;
      ++samples;
      if (typical_state == Typical::kKnown) {
        if (t[i] - last_present_t > dropout_limit) Record(k, ch, ScreeningRule::kDropout, r);
        last_present_t = t[i];
      } else if (typical_state == Typical::kUnknown) {
        FirstSamples(c, k);
        typical_state = s.typical_state;
        last_present_t = s.last_present_t;
        dropout_limit = s.dropout_limit;
      }
      if (r < valid_min || r > valid_max) {
        Record(k, ch, ScreeningRule::kOutOfRange, r);
        continue;
      }
      // Rails mean saturation, except for the compass, whose 0 and full scale are headings.
      if (kind == kAnalogKind && (r == 0 || r == full_scale)) {
        Record(k, ch, ScreeningRule::kAtRail, r);
        continue;
      }
      double value = 0;
      bool wrapped = false;
      if constexpr (kind == kEncoderKind) {
        double d = have_last ? r - last_raw : 0.0;
        if (d > period / 2) { d -= period; wrapped = true; }
        if (d < -period / 2) { d += period; wrapped = true; }
        value = have_last ? last_value + d : r;
      } else {
        value = radians_at_zero + radians_per_count * r;
        if (kind == kCompassKind && have_last) {  // continue across +-180 deg
          while (value - last_value > M_PI) value -= 2.0 * M_PI;
          while (value - last_value < -M_PI) value += 2.0 * M_PI;
        }
      }
      const bool too_fast = have_last && std::abs(value - last_value) > limit * (t[i] - last_t) + slack;
      if (too_fast && rejected_run + 1 < kRebaselineAfter) {
        s.run_row[rejected_run] = k;
        s.run_value[rejected_run] = value;
        s.run_t[rejected_run] = t[i];
        s.run_raw[rejected_run] = r;
        s.run_wrapped[rejected_run] = wrapped;
        ++rejected_run;
        Record(k, ch, ScreeningRule::kRateLimit, r);
        continue;
      }
      if (rejected_run > 0 && RunLeadsTo(s, rejected_run, last_value, value, t[i], limit, slack)) {
        // The run went from the last accepted sample to this one, which holds its level: a
        // real jolt, only faster than the limit, not a fault.
        for (int j = 0; j < rejected_run; ++j) {
          const std::size_t row = s.run_row[j];
          Unrecord(row, ch, ScreeningRule::kRateLimit);
          if (s.run_wrapped[j]) Record(row, ch, ScreeningRule::kEncoderWrap, s.run_raw[j]);
          v[row - b] = s.run_value[j];
          if constexpr (kind != kEncoderKind) {
            queue_value[queued] = s.run_value[j];
            queue_t[queued] = s.run_t[j];
            queue_row[queued] = row;
            ++queued;
            accepted_in_window += row < window_rows_;
          }
        }
      }
      if (wrapped) Record(k, ch, ScreeningRule::kEncoderWrap, r);
      rejected_run = 0;
      v[i] = value;
      have_last = true;
      last_raw = r;
      last_value = value;
      last_t = t[i];
      if constexpr (kind != kEncoderKind) {
        queue_value[queued] = value;
        queue_t[queued] = t[i];
        queue_row[queued] = k;
        ++queued;
        accepted_in_window += k < window_rows_;
      }
    }
    if constexpr (kind != kEncoderKind) {
      s.queue_value.resize(queued);
      s.queue_t.resize(queued);
      s.queue_row.resize(queued);
      s.accepted_in_window = accepted_in_window;
    }
    s.have_last = have_last;
    s.last_raw = last_raw;
    s.last_value = last_value;
    s.last_t = last_t;
    s.rejected_run = rejected_run;
    s.last_present_t = last_present_t;
    s.pass_end = out_.rows;
    out_.samples[ch] += samples;
  }

  // Whether the rate limit's run of `run` rejected samples was the signal moving from
  // `last_value` to `value` at `t_s` (a jolt, faster than the limit): the run lies between
  // the two (within the slack) and `value` follows its last sample within the limit (the new
  // level holds). A fault jumps out and back, or about: its samples stay rejected.
  static bool RunLeadsTo(const ChannelState& s, int run, double last_value, double value, double t_s, double limit,
                         double slack) {
    const double low = std::min(last_value, value) - slack, high = std::max(last_value, value) + slack;
    for (int j = 0; j < run; ++j) {
      if (s.run_value[j] < low || s.run_value[j] > high) return false;
    }
    return std::abs(value - s.run_value[run - 1]) <= limit * (t_s - s.run_t[run - 1]) + slack;
  }

  // Takes back the event Record() made for row k (rare: a rate-limit run found to be real).
  [[gnu::noinline, gnu::cold]] void Unrecord(std::size_t k, int channel, ScreeningRule rule) {
    const long line = line_[k - base_];
    for (auto e = out_.events.rbegin(); e != out_.events.rend(); ++e) {
      if (e->channel == channel && e->rule == rule && e->line == line) {
        out_.events.erase(std::next(e).base());
        --out_.counts[static_cast<int>(rule)][channel];
        return;
      }
    }
    LN_CHECK(false) << "screening: no event to take back";
  }

  // A sample of a channel with fewer than three in the statistics window: its first three
  // set its typical interval, and their dropouts are reported then.
  // (Their rows may have been released by then: the samples are kept as their events would be.)
  [[gnu::noinline, gnu::cold]] void FirstSamples(Channel c, std::size_t k) {
    const int ch = static_cast<int>(c);
    ChannelState& s = ch_[ch];
    s.first_samples.push_back({line(k), t(k), ch, ScreeningRule::kDropout, raw(c, k)});
    if (s.first_samples.size() < 3) return;
    const ScreeningEvent* e = s.first_samples.data();
    SetChannelInterval(&s, SubsampledMedian(2, [&](std::size_t i) { return e[i + 1].t_s - e[i].t_s; }));
    for (std::size_t i = 1; i < 3; ++i) {
      if (e[i].t_s - e[i - 1].t_s > s.dropout_limit) {
        out_.events.push_back(e[i]);
        ++out_.counts[static_cast<int>(ScreeningRule::kDropout)][ch];
      }
    }
    s.last_present_t = e[2].t_s;
    s.first_samples.clear();
  }

  // Hampel identifier over the accepted samples of an analog channel, on the residuals from
  // the local trend (the median slope of the window), so that a steady turn or climb is not
  // mistaken for spread: a sample is a spike when its residual is further from the residuals'
  // median than hampel_threshold robust sigmas (1.4826 MAD) and hampel_min_counts counts.
  // Sample p is tested once the hampel_half_window accepted samples after it are known (the
  // last ones at the end, in the window ending with the last sample).
  void HampelStage(Channel c) {
    const int ch = static_cast<int>(c);
    ChannelState& s = ch_[ch];
    const std::size_t h = static_cast<std::size_t>(o_.hampel_half_window);
    const std::size_t window = 2 * h + 1;  // odd
    if (s.sigma_state == Typical::kUnknown) NoiseLevel(&s, window);
    if (s.sigma_state == Typical::kKnown) {
      const std::size_t until = finished_ ? s.accepted() : (s.accepted() >= h ? s.accepted() - h : 0);
      if (s.accepted() >= window && s.tested < until) {
        HampelTests(c, s.tested, until);
        s.tested = until;
      }
      // The queue keeps the window of the next sample to test.
      const std::size_t keep_from = s.tested >= window ? s.tested - window : 0;
      if (keep_from - s.queue_base >= 4096 && 2 * (keep_from - s.queue_base) >= s.queue_value.size()) {
        const auto drop = static_cast<std::ptrdiff_t>(keep_from - s.queue_base);
        s.queue_value.erase(s.queue_value.begin(), s.queue_value.begin() + drop);
        s.queue_t.erase(s.queue_t.begin(), s.queue_t.begin() + drop);
        s.queue_row.erase(s.queue_row.begin(), s.queue_row.begin() + drop);
        s.queue_base = keep_from;
      }
    }
    if (s.sigma_state == Typical::kNone) s.tested = s.accepted();
    s.hampel_end = s.tested < s.accepted() ? s.queue_row[s.tested - s.queue_base] : s.pass_end;
  }

  // The channel's noise level, from the second differences of its accepted samples in the
  // statistics window (for white noise their variance is 6 sigma^2): a floor under each
  // window's own estimate, which from a handful of samples is often far too small. A channel
  // with fewer than a test window of samples there takes its first ones; one with fewer in
  // all is not tested.
  void NoiseLevel(ChannelState* s, std::size_t window) {
    std::size_t count = 0;
    if (s->accepted_in_window >= window) {
      count = s->accepted_in_window;
    } else if (s->accepted() >= window) {
      count = window;
    } else {
      if (finished_) s->sigma_state = Typical::kNone;
      return;
    }
    const double* value = s->queue_value.data();  // nothing dropped from the queue yet
    s->channel_sigma =
        NoiseOfSecondDifferences(count - 2, [&](std::size_t q) { return value[q + 2] - 2.0 * value[q + 1] + value[q]; });
    s->smallest_threshold = std::max(o_.hampel_threshold * s->channel_sigma, s->min_dev);
    s->sigma_state = Typical::kKnown;
  }

  // Tests accepted samples [first, last) of channel c (their windows are in the queue).
  void HampelTests(Channel c, std::size_t first, std::size_t last) {
    const int ch = static_cast<int>(c);
    ChannelState& s = ch_[ch];
    // Queue-relative indices: sample p is element p - base.
    const std::size_t base = s.queue_base, count = s.accepted();
    const double* const value = s.queue_value.data();
    const double* const time = s.queue_t.data();
    const std::size_t h = static_cast<std::size_t>(o_.hampel_half_window);
    const std::size_t window = 2 * h + 1;
    const double channel_sigma = s.channel_sigma, smallest_threshold = s.smallest_threshold;
    // The slope joining accepted samples q - 1 and q (queue indices).
    auto slope_at = [&](std::size_t q) { return (value[q] - value[q - 1]) / (time[q] - time[q - 1]); };
    double residual[64], scratch[64];
    std::vector<double> residual_heap, scratch_heap;
    double* res = residual;
    double* scr = scratch;
    if (window > 64) {
      residual_heap.resize(window);
      scratch_heap.resize(window);
      res = residual_heap.data();
      scr = scratch_heap.data();
    }
    auto spike = [&](std::size_t q) {
      const std::size_t row = s.queue_row[q];
      Record(row, ch, ScreeningRule::kSpike, raw_[ch][row - base_]);
      value_[ch][row - base_] = kNaN;
    };
    // The full test of sample p (absolute): trend, residuals, their median and MAD.
    auto test = [&](std::size_t p) {
      const std::size_t lo = std::min(p >= h ? p - h : 0, count - window) - base;
      const std::size_t q = p - base;
      for (std::size_t i = 0; i + 1 < window; ++i) scr[i] = slope_at(lo + 1 + i);
      const double trend = util::SmallMedian(scr, window - 1);
      const double mine = value[q];
      for (std::size_t i = 0; i < window; ++i) res[i] = value[lo + i] - trend * (time[lo + i] - time[q]);
      // Exact shortcut: with an odd window the residuals' median is one of them, so when all
      // lie within the smallest possible threshold of this sample it is no spike.
      double farthest = 0;
      for (std::size_t i = 0; i < window; ++i) farthest = std::max(farthest, std::abs(mine - res[i]));
      if (farthest <= smallest_threshold) return;
      std::copy(res, res + window, scr);
      const double med = util::SmallMedian(scr, window);
      for (std::size_t i = 0; i < window; ++i) scr[i] = std::abs(res[i] - med);
      const double sigma = std::max(1.4826 * util::SmallMedian(scr, window), channel_sigma);
      const double d = std::abs(mine - med);
      if (d > o_.hampel_threshold * sigma && d > s.min_dev) spike(q);
    };
    if (h != 3) {
      for (std::size_t p = first; p < last; ++p) test(p);
      return;
    }
    // The usual half window: interior windows (lo = p - 3) take the shortcut first
    // (ShortcutDistances), in chunks that stay in the cache; the distances are those of the
    // full test, so the decision is the same. The few samples left get the full test.
    const std::size_t interior_begin = std::max<std::size_t>(first, 3);
    const std::size_t interior_end = std::max(interior_begin, std::min(last, count - 3));
    for (std::size_t p = first; p < std::min(last, interior_begin); ++p) test(p);
    constexpr std::size_t kChunk = 2048;
    std::array<double, kChunk + 6> slope;   // slope[i] joins b - 3 + i and b - 2 + i
    std::array<double, kChunk> farthest_of;  // of samples b, b + 1, ...
    for (std::size_t pb = interior_begin; pb < interior_end; pb += kChunk) {
      const std::size_t pe = std::min(pb + kChunk, interior_end);  // samples [pb, pe)
      const std::size_t b = pb - base, e = pe - base;            // in the queue
      ShortcutDistances(value, time, b, e, slope.data(), farthest_of.data());
      for (std::size_t q = b; q < e; ++q) {
        if (farthest_of[q - b] > smallest_threshold) test(q + base);
      }
    }
    for (std::size_t p = std::max(first, interior_end); p < last; ++p) test(p);
  }

  // The channels whose motion tells a stuck `c` from a still one (see CorrelatedMotion).
  std::vector<Channel> CorrelatedChannels(Channel c) const {
    std::vector<Channel> list;
    auto add = [&](Channel o) {
      if (Has(o)) list.push_back(o);
    };
    switch (c) {
      case Channel::kCompass: add(Channel::kGyroZ); break;
      case Channel::kGyroZ: add(Channel::kCompass); break;
      case Channel::kPitchLeft: add(Channel::kPitchRight); break;
      case Channel::kPitchRight: add(Channel::kPitchLeft); break;
      case Channel::kRoll: break;
      default:
        for (Channel o : {Channel::kEncoderFrontLeft, Channel::kEncoderFrontRight, Channel::kEncoderRearLeft,
                          Channel::kEncoderRearRight}) {
          if (o != c) add(o);
        }
    }
    return list;
  }

  // How far a correlated channel of `c` disagrees with `c` holding `stuck_value` over rows
  // [k0, k1] (radians or metres), or -1 when there is none to compare with.
  double CorrelatedMotion(Channel c, std::size_t k0, std::size_t k1, double stuck_value) const {
    auto change = [&](Channel other, bool integrate) -> double {
      if (!Has(other)) return -1;
      const std::vector<double>& w = value_[static_cast<int>(other)];
      double first = kNaN, last = kNaN, integral = 0, prev_t = kNaN, prev_w = kNaN;
      for (std::size_t i = k0 - base_; i <= k1 - base_; ++i) {
        if (std::isnan(w[i])) continue;
        if (std::isnan(first)) first = w[i];
        last = w[i];
        if (!std::isnan(prev_t)) integral += 0.5 * (w[i] + prev_w) * (t_[i] - prev_t);
        prev_t = t_[i];
        prev_w = w[i];
      }
      if (std::isnan(first)) return -1;
      if (integrate) return std::abs(integral);
      if (IsEncoder(other)) return std::abs((last - first) * model_[other].MetresPerCount());
      return std::abs(last - first);
    };
    switch (c) {
      case Channel::kCompass: return change(Channel::kGyroZ, true);
      case Channel::kGyroZ: {  // a constant rate is fine if the compass turns at that rate
        const double turned = change(Channel::kCompass, false);
        return turned < 0 ? -1 : std::abs(turned - std::abs(stuck_value) * (t(k1) - t(k0)));
      }
      case Channel::kPitchLeft: return change(Channel::kPitchRight, false);
      case Channel::kPitchRight: return change(Channel::kPitchLeft, false);
      case Channel::kRoll: return -1;
      default: {  // an encoder: the furthest travel of the others
        double most = -1;
        for (Channel other : {Channel::kEncoderFrontLeft, Channel::kEncoderFrontRight,
                              Channel::kEncoderRearLeft, Channel::kEncoderRearRight}) {
          if (other != c) most = std::max(most, change(other, false));
        }
        return most;
      }
    }
  }

  // Runs of one raw count lasting stuck_min_s while a correlated channel moved. A run is
  // decided when it has ended, on final values of the channels it is compared with: those
  // before it in channel order as their own stuck test left them, those after it as before
  // theirs (which waits for this one).
  void StuckStage(Channel c) {
    const int ch = static_cast<int>(c);
    ChannelState& s = ch_[ch];
    if (s.correlated.empty()) {  // nothing to tell a stuck sensor from a still one
      s.stuck_end = s.hampel_end;
      return;
    }
    std::size_t limit = s.hampel_end;
    for (Channel o : s.correlated) {
      const ChannelState& so = ch_[static_cast<int>(o)];
      limit = std::min(limit, o < c ? so.stuck_end : so.hampel_end);
    }
    const bool all = finished_ && limit == out_.rows;  // every row is known
    const double* const raw = raw_[ch].data();
    double* const v = value_[ch].data();
    const std::size_t b = base_;
    const double motion_threshold = IsEncoder(c) ? 0.3 : 5.0 * M_PI / 180.0;  // metres, radians
    std::size_t k = s.stuck_end;
    bool in_run = s.in_run;
    std::size_t run_last_valid = s.run_last_valid, run_next = s.run_next;
    while (true) {
      if (!in_run) {
        // A sample followed by another count is a run of one: the usual case, skipped here.
        while (k + 1 < limit) {
          const double next = raw[k + 1 - b];
          if (std::isnan(next) || next == raw[k - b]) break;
          ++k;
        }
        while (k < limit && std::isnan(v[k - b])) ++k;
        if (k >= limit) break;
        in_run = true;
        run_last_valid = k;
        run_next = k + 1;
      }
      const double held = raw[k - b];
      while (run_next < limit && (std::isnan(raw[run_next - b]) || raw[run_next - b] == held)) {
        if (!std::isnan(v[run_next - b])) run_last_valid = run_next;
        ++run_next;
      }
      if (run_next == limit && !all) break;  // the run may go on
      const std::size_t end = run_last_valid;
      const double t0 = t(k), t1 = t(end);
      if (end > k && t1 - t0 >= o_.stuck_min_s && CorrelatedMotion(c, k, end, v[k - b]) > motion_threshold) {
        for (std::size_t q = k + 1; q <= end; ++q) {
          if (std::isnan(v[q - b])) continue;
          Record(q, ch, ScreeningRule::kStuck, raw[q - b]);
          v[q - b] = kNaN;
        }
      }
      in_run = false;
      k = end + 1;
    }
    s.in_run = in_run;
    s.run_last_valid = run_last_valid;
    s.run_next = run_next;
    s.stuck_end = k;
  }

  const SensorModel& model_;
  const ScreeningOptions o_;
  const std::size_t window_rows_;  // rows in the statistics window
  // The held rows: row k is element k - base_ of the arrays, its time stamp, line and raw
  // counts as the reader wrote them.
  std::size_t base_ = 0;
  TelemetryLog held_;
  std::vector<double>& t_ = held_.t_s;
  std::vector<long>& line_ = held_.line;
  std::array<std::vector<double>, kNumChannels>& raw_ = held_.counts;
  std::vector<std::size_t> log_row_;  // row k's index among the rows read; empty until a row is dropped
  std::array<std::vector<double>, kNumChannels> value_;
  std::array<ChannelState, kNumChannels> ch_;
  std::size_t rows_read_ = 0, dropped_ = 0;
  bool statistics_ready_ = false, finished_ = false;
  double gap_limit_ = 0;
  std::size_t gap_next_ = 0;
  std::size_t final_end_ = 0;
  ScreenedLog out_;  // counts, events and row statistics
};

ScreeningStream::ScreeningStream(const SensorModel& model, const ScreeningOptions& options,
                                 const std::array<bool, kNumChannels>& present)
    : impl_(std::make_unique<Impl>(model, options, present)) {}
ScreeningStream::~ScreeningStream() = default;
void ScreeningStream::Push(const TelemetryLog& rows) { impl_->Push(rows); }
std::size_t ScreeningStream::Read(const Source& source, std::size_t max_rows) { return impl_->Read(source, max_rows); }
void ScreeningStream::Finish() { impl_->Finish(); }
bool ScreeningStream::finished() const { return impl_->finished(); }
bool ScreeningStream::statistics_ready() const { return impl_->statistics_ready(); }
double ScreeningStream::typical_interval_s() const { return impl_->report().typical_interval_s; }
double ScreeningStream::rate_noise(Channel c) const { return impl_->report().rate_noise[static_cast<int>(c)]; }
bool ScreeningStream::rate_noise_from_log(Channel c) const {
  return impl_->report().rate_noise_from_log[static_cast<int>(c)];
}
bool ScreeningStream::Has(Channel c) const { return impl_->Has(c); }
std::size_t ScreeningStream::begin() const { return impl_->begin(); }
std::size_t ScreeningStream::end() const { return impl_->end(); }
std::size_t ScreeningStream::final_end() const { return impl_->final_end(); }
double ScreeningStream::t(std::size_t k) const { return impl_->t(k); }
double ScreeningStream::value(Channel c, std::size_t k) const { return impl_->value(c, k); }
ScreeningStream::Rows ScreeningStream::rows() const { return impl_->rows(); }
void ScreeningStream::Release(std::size_t k) { impl_->Release(k); }
void ScreeningStream::Reserve(std::size_t rows) { impl_->Reserve(rows); }
const ScreenedLog& ScreeningStream::report() const { return impl_->report(); }
ScreenedLog ScreeningStream::TakeAll() { return impl_->TakeAll(); }

std::string ToString(ScreeningRule rule) {
  switch (rule) {
    case ScreeningRule::kRepeatedTimestamp: return "repeated_timestamp";
    case ScreeningRule::kOutOfOrderTimestamp: return "out_of_order_timestamp";
    case ScreeningRule::kGap: return "gap";
    case ScreeningRule::kDropout: return "dropout";
    case ScreeningRule::kOutOfRange: return "out_of_range";
    case ScreeningRule::kAtRail: return "at_rail";
    case ScreeningRule::kRateLimit: return "rate_limit";
    case ScreeningRule::kSpike: return "spike";
    case ScreeningRule::kStuck: return "stuck";
    case ScreeningRule::kEncoderWrap: return "encoder_wrap";
  }
  return "unknown";
}

void ScreeningOptions::Validate() const {
  LN_CHECK_ARG(gap_factor > 1) << "gap factor: must be > 1";
  LN_CHECK_ARG(max_speed_mps > 0 && max_turn_rate_dps > 0 && max_tilt_rate_dps > 0 &&
               max_turn_accel_dps2 > 0)
      << "rate limits: must be > 0";
  LN_CHECK_ARG(rate_slack_counts >= 0 && hampel_min_counts >= 0) << "slacks: must be >= 0";
  LN_CHECK_ARG(rate_noise_sigmas >= 0 && std::isfinite(rate_noise_sigmas)) << "rate noise sigmas: must be >= 0";
  LN_CHECK_ARG(warning_share > 0 && warning_share <= 1) << "warning share: must be in (0, 1]";
  LN_CHECK_ARG(hampel_half_window >= 2) << "Hampel half window: must be >= 2";
  LN_CHECK_ARG(hampel_threshold > 0) << "Hampel threshold: must be > 0";
  LN_CHECK_ARG(stuck_min_s > 0) << "stuck duration: must be > 0";
  LN_CHECK_ARG(statistics_intervals >= 16) << "statistics window: must be >= 16 intervals";
}

nlohmann::json ScreeningOptions::ToJson() const {
  return {{"gap_factor", gap_factor},
          {"max_speed_mps", max_speed_mps},
          {"max_turn_rate_dps", max_turn_rate_dps},
          {"max_tilt_rate_dps", max_tilt_rate_dps},
          {"max_turn_accel_dps2", max_turn_accel_dps2},
          {"rate_slack_counts", rate_slack_counts},
          {"rate_noise_sigmas", rate_noise_sigmas},
          {"estimate_missing_noise", estimate_missing_noise},
          {"warning_share", warning_share},
          {"hampel_half_window", hampel_half_window},
          {"hampel_threshold", hampel_threshold},
          {"hampel_min_counts", hampel_min_counts},
          {"stuck_min_s", stuck_min_s},
          {"statistics_intervals", statistics_intervals}};
}

long ScreenedLog::Count(ScreeningRule rule) const {
  long total = 0;
  for (long n : counts[static_cast<int>(rule)]) total += n;
  return total;
}

namespace {
// The rules that take samples out of a channel (the others drop rows, report or repair).
bool Rejects(ScreeningRule rule) {
  return rule == ScreeningRule::kOutOfRange || rule == ScreeningRule::kAtRail || rule == ScreeningRule::kRateLimit ||
         rule == ScreeningRule::kSpike || rule == ScreeningRule::kStuck;
}
}  // namespace

std::vector<ScreenedLog::Share> ScreenedLog::RejectionShares() const {
  std::vector<Share> shares;
  for (int r = 0; r < kNumScreeningRules; ++r) {
    if (!Rejects(static_cast<ScreeningRule>(r))) continue;
    for (int c = 0; c < kNumChannels; ++c) {
      if (counts[r][c] == 0 || samples[c] == 0) continue;
      shares.push_back({static_cast<ScreeningRule>(r), c, counts[r][c],
                        static_cast<double>(counts[r][c]) / static_cast<double>(samples[c])});
    }
  }
  return shares;
}

std::vector<ScreenedLog::Share> ScreenedLog::Warnings() const {
  std::vector<Share> warnings;
  for (const Share& s : RejectionShares()) {
    if (s.share > warning_share) warnings.push_back(s);
  }
  return warnings;
}

std::string ScreenedLog::Share::Message() const {
  std::ostringstream m;
  m.imbue(std::locale::classic());
  m.precision(3);
  const char* check = "";
  switch (rule) {
    case ScreeningRule::kRateLimit: check = "the sensor's noise_rms and the vehicle's limits in the sensor file"; break;
    case ScreeningRule::kOutOfRange:
    case ScreeningRule::kAtRail: check = "the channel's bits, valid_range, scale and offset (and --bits)"; break;
    case ScreeningRule::kSpike: check = "the sensor's noise and wiring"; break;
    case ScreeningRule::kStuck: check = "the sensor and the channel it is compared with"; break;
    default: check = "the sensor file"; break;
  }
  m << "screening rule " << ToString(rule) << " rejected " << rejected << " " << ToString(static_cast<Channel>(channel))
    << " samples (" << 100.0 * share << " %); check " << check
    << " (docs/posfilter.md, \"When a rule rejects too much\")";
  return m.str();
}

nlohmann::json ScreenedLog::ReportJson() const {
  nlohmann::json report = nlohmann::json::object();
  for (int r = 0; r < kNumScreeningRules; ++r) {
    nlohmann::json per = nlohmann::json::object();
    for (int c = 0; c <= kNumChannels; ++c) {
      if (counts[r][c] == 0) continue;
      per[c == kRowSlot ? "rows" : ToString(static_cast<Channel>(c))] = counts[r][c];
    }
    report[ToString(static_cast<ScreeningRule>(r))] = {{"total", Count(static_cast<ScreeningRule>(r))},
                                                       {"by_channel", per}};
  }
  nlohmann::json samples_json = nlohmann::json::object(), limits = nlohmann::json::object();
  for (int c = 0; c < kNumChannels; ++c) {
    if (samples[c] > 0) samples_json[ToString(static_cast<Channel>(c))] = samples[c];
    if (rate_limit[c] > 0) {
      const bool gyro = static_cast<Channel>(c) == Channel::kGyroZ;
      limits[ToString(static_cast<Channel>(c))] = {
          {gyro ? "max_change_dps2" : "max_rate_dps", rate_limit[c] * 180 / M_PI},
          {gyro ? "slack_dps" : "slack_deg", rate_slack[c] * 180 / M_PI},
          {gyro ? "noise_dps" : "noise_deg", rate_noise[c] * 180 / M_PI},
          {"noise_from", rate_noise_from_log[c] ? "log" : rate_noise[c] > 0 ? "sensor file" : "none"}};
    }
  }
  report["samples"] = samples_json;
  report["rate_limits"] = limits;
  nlohmann::json shares = nlohmann::json::array(), warnings = nlohmann::json::array();
  for (const Share& s : RejectionShares()) {
    nlohmann::json j = {{"rule", ToString(s.rule)}, {"channel", ToString(static_cast<Channel>(s.channel))},
                        {"rejected", s.rejected}, {"share", s.share}};
    shares.push_back(j);
    if (s.share > warning_share) warnings.push_back(s.Message());
  }
  report["rejection_shares"] = shares;
  report["warning_share"] = warning_share;
  report["warnings"] = warnings;
  return report;
}

ScreenedLog ScreenTelemetry(const TelemetryLog& log, const SensorModel& model,
                            const ScreeningOptions& options) {
  std::array<bool, kNumChannels> present{};
  for (Channel c : kAllChannels) present[static_cast<int>(c)] = log.Has(c);
  ScreeningStream stream(model, options, present);
  stream.Reserve(log.size());
  stream.Push(log);
  stream.Finish();
  return stream.TakeAll();
}

void WriteScreeningLog(const std::filesystem::path& path, const ScreenedLog& screened) {
  std::ostringstream s;
  s.imbue(std::locale::classic());
  s.precision(17);
  s << "# lunarnav screening log: one rejected, dropped or repaired sample per line\n";
  s << "line,t_s,channel,rule,raw\n";
  for (const ScreeningEvent& e : screened.events) {
    s << e.line << "," << e.t_s << ","
      << (e.channel < 0 ? std::string("row") : ToString(static_cast<Channel>(e.channel))) << ","
      << ToString(e.rule) << "," << e.raw << "\n";
  }
  io::WriteFileAtomic(path, s.str());
}

}  // namespace lunarnav::telemetry
