#include "sim/telemetry_faults.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <sstream>

#include "io/atomic_file.h"
#include "sim/portable_random.h"
#include "util/check.h"

namespace lunarnav::sim {
namespace {

using telemetry::Channel;

constexpr double kDefaultStuckS = 5.0;
constexpr double kDefaultDropoutS = 2.0;
// Clearances of faults placed at random times.
constexpr double kClearanceS = 1.0;
constexpr double kSameChannelClearanceS = 2.0;
constexpr double kEndMarginS = 2.0;
constexpr int kPlacementAttempts = 1000;

const char* kKindNames[] = {"spike", "stuck", "dropout", "repeated_timestamp", "out_of_order_timestamp",
                            "out_of_range"};

double ParseNumber(const std::string& text, const std::string& spec, const char* what) {
  double v = 0;
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  LN_CHECK_ARG(!text.empty() && ec == std::errc() && ptr == text.data() + text.size() && std::isfinite(v))
      << "fault '" << spec << "': " << what << " '" << text << "' is not a number";
  return v;
}

// A placed fault's extent, for the clearances.
struct Extent {
  std::size_t first, last;
  int channel;
};

}  // namespace

std::string ToString(FaultKind kind) { return kKindNames[static_cast<int>(kind)]; }

std::optional<FaultKind> FaultKindFromString(const std::string& name) {
  for (int i = 0; i < 6; ++i) {
    if (name == kKindNames[i]) return static_cast<FaultKind>(i);
  }
  return std::nullopt;
}

namespace {

// A kind as typed on a command line: hyphens for underscores, a plural s.
std::optional<FaultKind> FaultKindFromCommandLine(std::string name) {
  std::replace(name.begin(), name.end(), '-', '_');
  if (const auto kind = FaultKindFromString(name)) return kind;
  if (!name.empty() && name.back() == 's') return FaultKindFromString(name.substr(0, name.size() - 1));
  return std::nullopt;
}

}  // namespace

bool IsRowFault(FaultKind kind) {
  return kind == FaultKind::kRepeatedTimestamp || kind == FaultKind::kOutOfOrderTimestamp;
}

double FaultSpec::Duration() const {
  if (kind == FaultKind::kStuck) return duration_s.value_or(kDefaultStuckS);
  if (kind == FaultKind::kDropout) return duration_s.value_or(kDefaultDropoutS);
  return 0.0;
}

FaultSpec ParseFaultSpec(const std::string& text) {
  FaultSpec spec;
  spec.text = text;
  const std::size_t kind_end = std::min(text.find_first_of(":@*~+"), text.size());
  const std::string kind = text.substr(0, kind_end);
  const std::optional<FaultKind> k = FaultKindFromCommandLine(kind);
  LN_CHECK_ARG(k.has_value()) << "fault '" << text << "': unknown kind '" << kind
                              << "' (known: spikes stuck dropouts timestamps repeated_timestamp "
                                 "out_of_order_timestamp out-of-range)";
  spec.kind = *k;
  std::size_t pos = kind_end;
  bool placed = false;
  while (pos < text.size()) {
    const char tag = text[pos];
    const std::size_t end = std::min(text.find_first_of(":@*~+", pos + 1), text.size());
    const std::string value = text.substr(pos + 1, end - pos - 1);
    switch (tag) {
      case ':': {
        LN_CHECK_ARG(!IsRowFault(spec.kind)) << "fault '" << text << "': a row fault takes no channel";
        if (value != "any") {
          spec.channel = telemetry::ChannelFromString(value);
          LN_CHECK_ARG(spec.channel.has_value())
              << "fault '" << text << "': unknown channel '" << value
              << "' (known: enc_fl enc_fr enc_rl enc_rr compass pitch_left pitch_right roll gyro_z any)";
        }
        break;
      }
      case '@':
        LN_CHECK_ARG(!placed) << "fault '" << text << "': give one of @TIME, *COUNT, ~PER_MINUTE";
        spec.at_s = ParseNumber(value, text, "time");
        LN_CHECK_ARG(*spec.at_s >= 0) << "fault '" << text << "': the time must be >= 0";
        placed = true;
        break;
      case '*': {
        LN_CHECK_ARG(!placed) << "fault '" << text << "': give one of @TIME, *COUNT, ~PER_MINUTE";
        const double n = ParseNumber(value, text, "count");
        LN_CHECK_ARG(n >= 0 && n == std::floor(n) && n <= 100000) << "fault '" << text << "': the count must be a whole number >= 0";
        spec.count = static_cast<int>(n);
        placed = true;
        break;
      }
      case '~':
        LN_CHECK_ARG(!placed) << "fault '" << text << "': give one of @TIME, *COUNT, ~PER_MINUTE";
        spec.per_minute = ParseNumber(value, text, "rate");
        LN_CHECK_ARG(*spec.per_minute >= 0) << "fault '" << text << "': the rate must be >= 0";
        placed = true;
        break;
      case '+':
        LN_CHECK_ARG(spec.kind == FaultKind::kStuck || spec.kind == FaultKind::kDropout)
            << "fault '" << text << "': only stuck and dropout faults have a duration";
        spec.duration_s = ParseNumber(value, text, "duration");
        LN_CHECK_ARG(*spec.duration_s > 0) << "fault '" << text << "': the duration must be > 0";
        break;
      default: break;
    }
    pos = end;
  }
  return spec;
}

std::vector<FaultSpec> ParseFaultSpecs(const std::string& text) {
  const std::size_t kind_end = std::min(text.find_first_of(":@*~+"), text.size());
  if (text.substr(0, kind_end) != "timestamps") return {ParseFaultSpec(text)};
  const std::string rest = text.substr(kind_end);
  LN_CHECK_ARG(rest.find('@') == std::string::npos)
      << "fault '" << text << "': timestamps takes no @TIME (give repeated_timestamp@T or out_of_order_timestamp@T)";
  std::vector<FaultSpec> specs = {ParseFaultSpec("repeated_timestamp" + rest),
                                  ParseFaultSpec("out_of_order_timestamp" + rest)};
  for (FaultSpec& s : specs) s.text = text;
  return specs;
}

std::vector<InjectedFault> InjectFaults(const std::vector<FaultSpec>& specs, const telemetry::SensorModel& model,
                                        std::uint64_t seed, RawTelemetry* raw) {
  std::vector<InjectedFault> out;
  const std::size_t n = raw->size();
  if (specs.empty()) return out;
  LN_CHECK_ARG(n >= 2) << "faults: the log has fewer than two rows";
  PortableRandom rng(seed, "faults");
  const double span_s = static_cast<double>(raw->t_us.back() - raw->t_us.front()) * 1e-6;
  const double rows_per_s = static_cast<double>(n - 1) / span_s;
  auto rows_for = [&](double seconds) { return static_cast<std::size_t>(std::ceil(seconds * rows_per_s - 1e-9)); };

  // 1. Placement: requests at a given time first, then the random ones around them.
  struct Placement {
    const FaultSpec* spec;
    int channel;
    std::size_t row, rows;
  };
  std::vector<Placement> placements;
  std::vector<Extent> taken;
  // Channels a random fault may hit: those the model has (all of them in the paper's
  // presets, so the draws are those of a choice among nine); a channel fault lands on a row
  // where the channel has a sample (channels at lower rates leave cells empty).
  std::vector<int> channels;
  for (Channel c : telemetry::kAllChannels) {
    if (model[c].present) channels.push_back(static_cast<int>(c));
  }
  LN_CHECK_ARG(!channels.empty()) << "faults: the sensor model has no channel";
  auto random_channel = [&] { return channels[rng.UniformInt(channels.size())]; };
  auto sampled = [&](int channel, std::size_t row) {
    return channel < 0 || raw->counts[row][channel] != kEmptyCell;
  };
  auto run_rows = [&](const FaultSpec& s, std::size_t row) {
    const std::size_t len = s.Duration() > 0 ? std::max<std::size_t>(1, rows_for(s.Duration())) : 1;
    return std::min(len, n - row);
  };
  for (const FaultSpec& s : specs) {
    if (!s.at_s) continue;
    const std::int64_t at_us = std::llround(*s.at_s * 1e6);
    const auto it = std::lower_bound(raw->t_us.begin(), raw->t_us.end(), at_us);
    LN_CHECK_ARG(it != raw->t_us.end())
        << "fault '" << s.text << "': " << *s.at_s << " s is after the end of the log (" << span_s << " s)";
    // Stuck, repeated and out-of-order need a previous row.
    const bool needs_previous = s.kind == FaultKind::kStuck || IsRowFault(s.kind);
    std::size_t row = std::max<std::size_t>(needs_previous ? 1 : 0, static_cast<std::size_t>(it - raw->t_us.begin()));
    const int channel = IsRowFault(s.kind) ? -1 : s.channel ? static_cast<int>(*s.channel) : random_channel();
    while (row + 1 < n && !sampled(channel, row)) ++row;  // the channel's next sample
    LN_CHECK_ARG(sampled(channel, row)) << "fault '" << s.text << "': the channel has no sample from " << *s.at_s
                                        << " s on";
    const std::size_t len = run_rows(s, row);
    placements.push_back({&s, channel, row, len});
    taken.push_back({row, row + len - 1, channel});
  }
  const std::size_t margin = rows_for(kEndMarginS);
  for (const FaultSpec& s : specs) {
    if (s.at_s) continue;
    const int count = s.per_minute ? static_cast<int>(std::lround(*s.per_minute * span_s / 60.0)) : s.count;
    for (int i = 0; i < count; ++i) {
      const int channel = IsRowFault(s.kind) ? -1 : s.channel ? static_cast<int>(*s.channel) : random_channel();
      const std::size_t len = std::max<std::size_t>(1, s.Duration() > 0 ? rows_for(s.Duration()) : 1);
      LN_CHECK_ARG(n > 2 * margin + len + 1) << "fault '" << s.text << "': the log is too short to place it";
      bool ok = false;
      for (int attempt = 0; attempt < kPlacementAttempts && !ok; ++attempt) {
        const std::size_t row = margin + static_cast<std::size_t>(rng.UniformInt(n - 2 * margin - len));
        ok = sampled(channel, row);
        for (const Extent& e : taken) {
          const bool related = e.channel == channel || e.channel < 0 || channel < 0;
          const std::size_t gap = rows_for(related ? kSameChannelClearanceS : kClearanceS);
          if (row <= e.last + gap && e.first <= row + len - 1 + gap) {
            ok = false;
            break;
          }
        }
        if (ok) {
          placements.push_back({&s, channel, row, len});
          taken.push_back({row, row + len - 1, channel});
        }
      }
      LN_CHECK_ARG(ok) << "fault '" << s.text << "': cannot place " << count
                       << " faults with the required clearances in a log of " << span_s << " s";
    }
  }

  // 2. Application: channel faults, then row faults (which move whole rows).
  std::stable_sort(placements.begin(), placements.end(), [](const Placement& a, const Placement& b) {
    return IsRowFault(a.spec->kind) != IsRowFault(b.spec->kind) ? !IsRowFault(a.spec->kind) : a.row < b.row;
  });
  for (const Placement& p : placements) {
    InjectedFault f;
    f.kind = p.spec->kind;
    f.channel = p.channel;
    f.row = p.row;
    f.rows = p.rows;
    f.spec = p.spec->text;
    if (IsRowFault(f.kind)) {
      std::int64_t& t = raw->t_us[p.row];
      const std::int64_t previous = raw->t_us[p.row - 1];
      f.original = t;
      if (f.kind == FaultKind::kOutOfOrderTimestamp) {
        std::swap(raw->t_us[p.row - 1], raw->t_us[p.row]);
        std::swap(raw->counts[p.row - 1], raw->counts[p.row]);
      } else {
        t = previous;
      }
      f.value = f.t_us = raw->t_us[p.row];
      out.push_back(f);
      continue;
    }
    const Channel channel = static_cast<Channel>(p.channel);
    const telemetry::ChannelModel& m = model[channel];
    const bool encoder = telemetry::IsEncoder(channel);
    std::int64_t& cell = raw->counts[p.row][p.channel];
    f.t_us = raw->t_us[p.row];
    f.original = cell;
    const std::int64_t levels = std::int64_t{1} << (encoder ? m.counter_bits : m.bits);
    switch (f.kind) {
      case FaultKind::kSpike: {
        LN_CHECK_ARG(cell != kEmptyCell) << "fault '" << f.spec << "': lands on a cell another fault emptied";
        const double base = encoder ? std::max(24.0, levels / 8.0) : std::max(12.0, levels / 32.0);
        std::int64_t size = std::llround((1.0 + rng.Uniform()) * base);
        if (encoder) size = std::min(size, levels / 2 - 1);
        const std::int64_t sign = rng.Sign() > 0 ? 1 : -1;
        if (encoder || channel == Channel::kCompass) {
          cell = ((cell + sign * size) % levels + levels) % levels;
        } else {
          std::int64_t v = cell + sign * size;
          if (v < 1 || v > levels - 2) v = cell - sign * size;
          cell = std::clamp<std::int64_t>(v, 1, levels - 2);
        }
        break;
      }
      case FaultKind::kOutOfRange: {
        const std::int64_t beyond = 1 + static_cast<std::int64_t>(rng.UniformInt(static_cast<std::uint64_t>(levels)));
        cell = rng.Sign() > 0 ? m.valid_max + beyond : m.valid_min - beyond;
        break;
      }
      case FaultKind::kStuck: {  // the last sample before repeated in the run's sampled cells
        std::size_t before = p.row - 1;
        while (before > 0 && raw->counts[before][p.channel] == kEmptyCell) --before;
        const std::int64_t held = raw->counts[before][p.channel];
        for (std::size_t r = p.row; r < p.row + p.rows; ++r) {
          if (raw->counts[r][p.channel] != kEmptyCell) raw->counts[r][p.channel] = held;
        }
        break;
      }
      case FaultKind::kDropout:
        for (std::size_t r = p.row; r < p.row + p.rows; ++r) raw->counts[r][p.channel] = kEmptyCell;
        break;
      default: break;
    }
    f.value = f.kind == FaultKind::kDropout ? 0 : cell;
    out.push_back(f);
  }
  std::sort(out.begin(), out.end(), [](const InjectedFault& a, const InjectedFault& b) {
    return a.row != b.row ? a.row < b.row : a.channel < b.channel;
  });
  return out;
}

void WriteFaultsCsv(const std::filesystem::path& path, const std::vector<InjectedFault>& faults) {
  std::ostringstream s;
  s.imbue(std::locale::classic());
  s << "# lunarnav injected faults: the first affected row of telemetry.csv (0-based data row, and its line in\n"
    << "# the file), its time stamp (s), channel (or row), kind, rows affected, count written and the count it\n"
    << "# replaced (row faults: time stamps, s)\n"
    << "row,line,t_s,channel,kind,rows,value,original\n";
  for (const InjectedFault& f : faults) {
    s << f.row << "," << TelemetryCsvLine(f.row) << "," << FormatMicroseconds(f.t_us) << ","
      << (f.channel < 0 ? std::string("row") : telemetry::ToString(static_cast<Channel>(f.channel))) << ","
      << ToString(f.kind) << "," << f.rows << ",";
    if (IsRowFault(f.kind)) {
      s << FormatMicroseconds(f.value) << "," << FormatMicroseconds(f.original);
    } else {
      if (f.kind != FaultKind::kDropout) s << f.value;
      s << ",";
      if (f.original != kEmptyCell) s << f.original;
    }
    s << "\n";
  }
  io::WriteFileAtomic(path, s.str());
}

}  // namespace lunarnav::sim
