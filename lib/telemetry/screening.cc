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
// A rate-limit rejection run this long means the signal really moved: accept it from there.
constexpr int kRebaselineAfter = 3;

// Median of value(0), ..., value(count - 1), for estimates of a typical interval or noise
// level: long sequences are subsampled evenly to at most 65536 values (plenty for a robust
// level, and linear time), and only those values are computed.
template <typename Value>
double SubsampledMedian(std::size_t count, Value value) {
  constexpr std::size_t kMaxSamples = 65536;
  const std::size_t stride = count > kMaxSamples ? (count + kMaxSamples - 1) / kMaxSamples : 1;
  std::vector<double> v;
  v.reserve(count / stride + 1);
  for (std::size_t i = 0; i < count; i += stride) v.push_back(value(i));
  if (v.empty()) return kNaN;
  const std::size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + mid, v.end());
  return v[mid];
}

// How many values are NaN.
std::size_t CountNaN(const std::vector<double>& values) {
  std::size_t count = 0;
  for (const double x : values) count += static_cast<std::size_t>(std::isnan(x));
  return count;
}

class Screener {
 public:
  Screener(const TelemetryLog& log, const SensorModel& model, const ScreeningOptions& options)
      : log_(log), model_(model), o_(options) {}

  ScreenedLog Run() {
    ScreenRows();
    for (Channel c : kAllChannels) {
      if (log_.Has(c)) ScreenChannel(c);
    }
    for (Channel c : kAllChannels) {
      if (out_.Has(c)) DetectStuck(c);
    }
    std::sort(out_.events.begin(), out_.events.end(), [](const ScreeningEvent& a, const ScreeningEvent& b) {
      return a.line != b.line ? a.line < b.line : a.channel < b.channel;
    });
    return std::move(out_);
  }

 private:
  void Record(std::size_t k, int channel, ScreeningRule rule, double raw) {
    out_.events.push_back({log_.line[out_.Row(k)], out_.t_s[k], channel, rule, raw});
    ++out_.counts[static_cast<int>(rule)][channel < 0 ? kRowSlot : channel];
  }

  void ScreenRows() {
    out_.t_s.reserve(log_.size());
    double last_t = -std::numeric_limits<double>::infinity();
    bool dropped = false;  // the row list is kept from the first dropped row on
    for (std::size_t i = 0; i < log_.size(); ++i) {
      const double t = log_.t_s[i];
      if (!out_.t_s.empty() && (t == last_t || t < last_t)) {
        const ScreeningRule rule =
            t == last_t ? ScreeningRule::kRepeatedTimestamp : ScreeningRule::kOutOfOrderTimestamp;
        out_.events.push_back({log_.line[i], t, -1, rule, t});
        ++out_.counts[static_cast<int>(rule)][kRowSlot];
        if (!dropped) {
          dropped = true;
          out_.row.reserve(log_.size());
          for (std::size_t k = 0; k < i; ++k) out_.row.push_back(k);
        }
        continue;
      }
      if (dropped) out_.row.push_back(i);
      out_.t_s.push_back(t);
      last_t = t;
    }
    const std::vector<double>& t = out_.t_s;
    if (t.size() < 2) return;
    const double typical = SubsampledMedian(t.size() - 1, [&](std::size_t k) { return t[k + 1] - t[k]; });
    for (std::size_t k = 1; k < t.size(); ++k) {
      if (t[k] - t[k - 1] > o_.gap_factor * typical) {
        Record(k, -1, ScreeningRule::kGap, t[k]);
        gap_rows_.push_back(k);
      }
    }
  }

  void ScreenChannel(Channel c) {
    const int ch = static_cast<int>(c);
    const ChannelModel& m = model_[c];
    const std::size_t n = out_.t_s.size();
    // The raw counts of the kept rows: the log's own array when no row was dropped.
    if (!out_.row.empty()) {
      raw_copy_[ch].resize(n);
      for (std::size_t k = 0; k < n; ++k) raw_copy_[ch][k] = log_.counts[ch][out_.row[k]];
      raw_[ch] = &raw_copy_[ch];
    } else {
      raw_[ch] = &log_.counts[ch];
    }
    const std::vector<double>& raw = *raw_[ch];
    std::vector<double>& v = out_.value[ch];
    v.assign(n, kNaN);

    // Dropouts: silences much longer than the channel's own sampling interval.
    // The present samples: all of them (dense: no index list), or listed.
    const std::size_t missing =
        CountNaN(raw);
    const bool dense = missing == 0;
    std::vector<std::size_t>& present = present_;
    present.clear();
    if (!dense) {
      present.reserve(n - missing);
      for (std::size_t k = 0; k < n; ++k) {
        if (!std::isnan(raw[k])) present.push_back(k);
      }
    }
    const std::size_t present_count = n - missing;
    auto present_at = [&](std::size_t p) { return dense ? p : present[p]; };
    if (present_count >= 3 && dense) {
      // Every row present: the channel's intervals are the rows', its typical interval the
      // rows' (the same median of the same values), its dropouts the rows' gaps.
      for (std::size_t k : gap_rows_) Record(k, ch, ScreeningRule::kDropout, raw[k]);
    } else if (present_count >= 3) {
      const std::vector<double>& t = out_.t_s;
      auto gap = [&](std::size_t p) { return t[present_at(p)] - t[present_at(p - 1)]; };  // p >= 1
      const double typical = SubsampledMedian(present_count - 1, [&](std::size_t i) { return gap(i + 1); });
      for (std::size_t p = 1; p < present_count; ++p) {
        if (gap(p) > o_.gap_factor * typical) {
          Record(present_at(p), ch, ScreeningRule::kDropout, raw[present_at(p)]);
        }
      }
    }

    // Range and rails, then conversion, unwrapping and the rate limit against the last
    // accepted sample.
    const bool encoder = IsEncoder(c);
    const double full_scale = std::ldexp(1.0, m.bits) - 1.0;
    const double period = std::ldexp(1.0, m.counter_bits);
    double limit = 0, slack = 0;  // per second, and absolute, in the value's units
    if (encoder) {
      limit = o_.max_speed_mps / std::abs(m.MetresPerCount());
      slack = o_.rate_slack_counts;
    } else {
      const double unit = std::abs(m.ToRadians(1.0) - m.ToRadians(0.0));  // radians per count
      slack = o_.rate_slack_counts * unit;
      const double deg = M_PI / 180.0;
      if (c == Channel::kCompass) limit = o_.max_turn_rate_dps * deg;
      else if (c == Channel::kGyroZ) limit = o_.max_turn_accel_dps2 * deg;
      else limit = o_.max_tilt_rate_dps * deg;
    }
    // Counts to radians is linear: precomputed, not called per sample.
    const double radians_at_zero = encoder ? 0.0 : m.ToRadians(0.0);
    const double radians_per_count = encoder ? 0.0 : m.ToRadians(1.0) - radians_at_zero;
    // The loop is compiled once per kind of channel and for dense channels, so that none of
    // those tests is made per sample.
    enum Kind { kEncoderKind, kCompassKind, kAnalogKind };
    auto screen = [&](auto kind_tag, auto dense_tag) {
      constexpr Kind kind = decltype(kind_tag)::value;
      constexpr bool all_present = decltype(dense_tag)::value;
      bool have_last = false;
      double last_raw = 0, last_value = 0, last_t = 0;
      int rejected_run = 0;
      for (std::size_t p = 0; p < present_count; ++p) {
        const std::size_t k = all_present ? p : present[p];
        const double r = raw[k];
        if (r < m.valid_min || r > m.valid_max) {
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
        if (have_last && std::abs(value - last_value) > limit * (out_.t_s[k] - last_t) + slack &&
            rejected_run + 1 < kRebaselineAfter) {
          ++rejected_run;
          Record(k, ch, ScreeningRule::kRateLimit, r);
          continue;
        }
        if (wrapped) Record(k, ch, ScreeningRule::kEncoderWrap, r);
        rejected_run = 0;
        v[k] = value;
        have_last = true;
        last_raw = r;
        last_value = value;
        last_t = out_.t_s[k];
      }
    };
    auto with_kind = [&](auto dense_tag) {
      if (encoder) {
        screen(std::integral_constant<Kind, kEncoderKind>{}, dense_tag);
      } else if (c == Channel::kCompass) {
        screen(std::integral_constant<Kind, kCompassKind>{}, dense_tag);
      } else {
        screen(std::integral_constant<Kind, kAnalogKind>{}, dense_tag);
      }
    };
    if (dense) {
      with_kind(std::true_type{});
    } else {
      with_kind(std::false_type{});
    }
    if (!encoder) Hampel(c);
  }

  // Hampel identifier over the accepted samples of an analog channel, on the residuals from
  // the local trend (the median slope of the window), so that a steady turn or climb is not
  // mistaken for spread: a sample is a spike when its residual is further from the residuals'
  // median than hampel_threshold robust sigmas (1.4826 MAD) and hampel_min_counts counts.
  void Hampel(Channel c) {
    const int ch = static_cast<int>(c);
    const ChannelModel& m = model_[c];
    std::vector<double>& v = out_.value[ch];
    // The accepted samples: their values and times, compacted when some are missing or were
    // rejected.
    const std::size_t count =
        v.size() - CountNaN(v);
    const bool dense = count == v.size();
    if (!dense) {
      accepted_row_.clear();
      accepted_value_.clear();
      accepted_t_.clear();
      for (std::size_t k = 0; k < v.size(); ++k) {
        if (std::isnan(v[k])) continue;
        accepted_row_.push_back(k);
        accepted_value_.push_back(v[k]);
        accepted_t_.push_back(out_.t_s[k]);
      }
    }
    const double* const value = dense ? v.data() : accepted_value_.data();
    const double* const time = dense ? out_.t_s.data() : accepted_t_.data();
    const std::size_t h = static_cast<std::size_t>(o_.hampel_half_window);
    const std::size_t window = 2 * h + 1;  // odd
    if (count < window) return;
    const double unit = std::abs(m.ToRadians(1.0) - m.ToRadians(0.0));
    const double min_dev = o_.hampel_min_counts * unit;
    // The channel's noise level, from its second differences (for white noise their variance
    // is 6 sigma^2): a floor under each window's own estimate, which from a handful of
    // samples is often far too small.
    const double channel_sigma = 1.4826 *
                                 SubsampledMedian(count - 2, [&](std::size_t q) {
                                   return std::abs(value[q + 2] - 2.0 * value[q + 1] + value[q]);
                                 }) /
                                 std::sqrt(6.0);
    // The slope joining accepted samples q - 1 and q.
    auto slope_at = [&](std::size_t q) { return (value[q] - value[q - 1]) / (time[q] - time[q - 1]); };
    const double smallest_threshold = std::max(o_.hampel_threshold * channel_sigma, min_dev);
    std::vector<double> residual(window), scratch(window);
    std::vector<std::size_t> spikes;
    // The full test of sample p: trend, residuals, their median and MAD.
    auto test = [&](std::size_t p) {
      const std::size_t lo = std::min(p >= h ? p - h : 0, count - window);
      for (std::size_t i = 0; i + 1 < window; ++i) scratch[i] = slope_at(lo + 1 + i);
      const double trend = util::SmallMedian(scratch.data(), window - 1);
      const double mine = value[p];
      for (std::size_t i = 0; i < window; ++i) residual[i] = value[lo + i] - trend * (time[lo + i] - time[p]);
      // Exact shortcut: with an odd window the residuals' median is one of them, so when all
      // lie within the smallest possible threshold of this sample it is no spike.
      double farthest = 0;
      for (std::size_t i = 0; i < window; ++i) farthest = std::max(farthest, std::abs(mine - residual[i]));
      if (farthest <= smallest_threshold) return;
      scratch = residual;
      const double med = util::SmallMedian(scratch.data(), window);
      for (std::size_t i = 0; i < window; ++i) scratch[i] = std::abs(residual[i] - med);
      const double sigma = std::max(1.4826 * util::SmallMedian(scratch.data(), window), channel_sigma);
      const double d = std::abs(mine - med);
      if (d > o_.hampel_threshold * sigma && d > min_dev) spikes.push_back(dense ? p : accepted_row_[p]);
    };
    if (h != 3) {
      for (std::size_t p = 0; p < count; ++p) test(p);
    } else {
      // The usual half window: interior windows (lo = p - 3) take the shortcut first, in
      // chunks that stay in the cache, by a branch-free loop the compiler vectorises; the
      // distances are those of the full test, so the decision is the same. The few samples
      // left get the full test.
      constexpr std::size_t kChunk = 2048;
      std::array<double, kChunk + 6> slope;   // slope[i] joins b - 3 + i and b - 2 + i
      std::array<double, kChunk> farthest_of;  // of samples b, b + 1, ...
      for (std::size_t p = 0; p < std::min<std::size_t>(3, count); ++p) test(p);
      for (std::size_t b = 3; b + 3 < count; b += kChunk) {
        const std::size_t e = std::min(b + kChunk, count - 3);  // samples [b, e)
        for (std::size_t q = b - 2; q < e + 4; ++q) slope[q - (b - 2)] = slope_at(q);
        for (std::size_t p = b; p < e; ++p) {
          double sl[6];
          for (std::size_t i = 0; i < 6; ++i) sl[i] = slope[p - b + i];
          const double trend = util::MedianOf6(sl);
          const double mine = value[p];
          double farthest = 0;
          for (std::size_t i = 0; i < 7; ++i) {
            const std::size_t q = p - 3 + i;
            farthest = std::max(farthest, std::abs(mine - (value[q] - trend * (time[q] - time[p]))));
          }
          farthest_of[p - b] = farthest;
        }
        for (std::size_t p = b; p < e; ++p) {
          if (farthest_of[p - b] > smallest_threshold) test(p);
        }
      }
      for (std::size_t p = std::max<std::size_t>(3, count - 3); p < count; ++p) test(p);
    }
    for (std::size_t k : spikes) {
      Record(k, ch, ScreeningRule::kSpike, (*raw_[ch])[k]);
      v[k] = kNaN;
    }
  }

  // Whether CorrelatedMotion has a channel to compare `c` with.
  bool HasCorrelatedChannel(Channel c) const {
    switch (c) {
      case Channel::kCompass: return out_.Has(Channel::kGyroZ);
      case Channel::kGyroZ: return out_.Has(Channel::kCompass);
      case Channel::kPitchLeft: return out_.Has(Channel::kPitchRight);
      case Channel::kPitchRight: return out_.Has(Channel::kPitchLeft);
      case Channel::kRoll: return false;
      default:
        for (Channel other : {Channel::kEncoderFrontLeft, Channel::kEncoderFrontRight,
                              Channel::kEncoderRearLeft, Channel::kEncoderRearRight}) {
          if (other != c && out_.Has(other)) return true;
        }
        return false;
    }
  }

  // How far a correlated channel of `c` disagrees with `c` holding `stuck_value` over
  // [t0, t1] (radians or metres), or -1 when there is none to compare with.
  double CorrelatedMotion(Channel c, double t0, double t1, double stuck_value) const {
    auto change = [&](Channel other, bool integrate) -> double {
      const int o = static_cast<int>(other);
      if (!out_.Has(other)) return -1;
      const std::vector<double>& w = out_.value[o];
      double first = kNaN, last = kNaN, integral = 0, prev_t = kNaN, prev_w = kNaN;
      // Time stamps increase strictly: the samples in [t0, t1] are one stretch.
      const auto begin = std::lower_bound(out_.t_s.begin(), out_.t_s.end(), t0) - out_.t_s.begin();
      for (std::size_t k = static_cast<std::size_t>(begin); k < w.size() && out_.t_s[k] <= t1; ++k) {
        if (std::isnan(w[k])) continue;
        if (std::isnan(first)) first = w[k];
        last = w[k];
        if (!std::isnan(prev_t)) integral += 0.5 * (w[k] + prev_w) * (out_.t_s[k] - prev_t);
        prev_t = out_.t_s[k];
        prev_w = w[k];
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
        return turned < 0 ? -1 : std::abs(turned - std::abs(stuck_value) * (t1 - t0));
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

  // Runs of one raw count lasting stuck_min_s while a correlated channel moved.
  void DetectStuck(Channel c) {
    const int ch = static_cast<int>(c);
    if (!HasCorrelatedChannel(c)) return;  // nothing to tell a stuck sensor from a still one
    const std::vector<double>& raw = *raw_[ch];
    std::vector<double>& v = out_.value[ch];
    const double motion_threshold = IsEncoder(c) ? 0.3 : 5.0 * M_PI / 180.0;  // metres, radians
    std::size_t k = 0;
    while (k < v.size()) {
      if (std::isnan(v[k])) {
        ++k;
        continue;
      }
      std::size_t end = k, next = k + 1;
      while (next < v.size() && (std::isnan(raw[next]) || raw[next] == raw[k])) {
        if (!std::isnan(v[next])) end = next;
        ++next;
      }
      const double t0 = out_.t_s[k], t1 = out_.t_s[end];
      if (end > k && t1 - t0 >= o_.stuck_min_s && CorrelatedMotion(c, t0, t1, v[k]) > motion_threshold) {
        for (std::size_t q = k + 1; q <= end; ++q) {
          if (std::isnan(v[q])) continue;
          Record(q, ch, ScreeningRule::kStuck, raw[q]);
          v[q] = kNaN;
        }
      }
      k = end + 1;
    }
  }

  const TelemetryLog& log_;
  const SensorModel& model_;
  const ScreeningOptions& o_;
  std::array<const std::vector<double>*, kNumChannels> raw_{};  // raw counts of kept rows
  std::array<std::vector<double>, kNumChannels> raw_copy_;      // when rows were dropped
  // Work space, reused from channel to channel.
  std::vector<std::size_t> present_, accepted_row_;
  std::vector<std::size_t> gap_rows_;  // kept rows that follow a gap
  std::vector<double> accepted_value_, accepted_t_;
  ScreenedLog out_;
};

}  // namespace

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
  LN_CHECK_ARG(hampel_half_window >= 2) << "Hampel half window: must be >= 2";
  LN_CHECK_ARG(hampel_threshold > 0) << "Hampel threshold: must be > 0";
  LN_CHECK_ARG(stuck_min_s > 0) << "stuck duration: must be > 0";
}

nlohmann::json ScreeningOptions::ToJson() const {
  return {{"gap_factor", gap_factor},
          {"max_speed_mps", max_speed_mps},
          {"max_turn_rate_dps", max_turn_rate_dps},
          {"max_tilt_rate_dps", max_tilt_rate_dps},
          {"max_turn_accel_dps2", max_turn_accel_dps2},
          {"rate_slack_counts", rate_slack_counts},
          {"hampel_half_window", hampel_half_window},
          {"hampel_threshold", hampel_threshold},
          {"hampel_min_counts", hampel_min_counts},
          {"stuck_min_s", stuck_min_s}};
}

long ScreenedLog::Count(ScreeningRule rule) const {
  long total = 0;
  for (long n : counts[static_cast<int>(rule)]) total += n;
  return total;
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
  return report;
}

ScreenedLog ScreenTelemetry(const TelemetryLog& log, const SensorModel& model,
                            const ScreeningOptions& options) {
  options.Validate();
  return Screener(log, model, options).Run();
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
