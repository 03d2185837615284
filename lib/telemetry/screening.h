// Screening of raw telemetry: "the raw data from each of the four types of sensor is biased
// and noisy and sometimes corrupt" (Krotkov & Hebert sec. 4.1). Every rule is counted and
// every rejected or repaired sample is recorded; nothing is dropped silently.
#pragma once

#include <array>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "telemetry/sensor_model.h"
#include "telemetry/telemetry_csv.h"

namespace lunarnav::telemetry {

/// The screening rules (docs/posfilter.md describes each).
enum class ScreeningRule {
  kRepeatedTimestamp,   ///< Row whose time stamp equals the previous one: dropped.
  kOutOfOrderTimestamp, ///< Row earlier than the last kept one: dropped.
  kGap,                 ///< Rows further apart than gap_factor x the median interval: reported.
  kDropout,             ///< A channel silent for longer than gap_factor x its own interval: reported.
  kOutOfRange,          ///< Count outside the channel's valid range: rejected.
  kAtRail,              ///< Analog count at 0 or 2^bits - 1 (saturated or disconnected): rejected.
  kRateLimit,           ///< Change since the last accepted sample faster than physics allows: rejected.
  kSpike,               ///< Hampel test on residuals from the local trend: rejected.
  kStuck,               ///< Unchanged for stuck_min_s while a correlated channel moves: rejected.
  kEncoderWrap          ///< Encoder counter wrapped around: unwrapped (repaired, not rejected).
};
inline constexpr int kNumScreeningRules = 10;
std::string ToString(ScreeningRule rule);

/// Thresholds of the rules. Physical limits are generous multiples of the paper's rover
/// (top speed 0.7 m/s).
struct ScreeningOptions {
  double gap_factor = 5.0;            ///< Gap / dropout: interval > gap_factor x typical. > 1.
  double max_speed_mps = 2.0;         ///< Rate limit of each wheel's travel. > 0.
  double max_turn_rate_dps = 90.0;    ///< Rate limit of the compass heading. > 0.
  double max_tilt_rate_dps = 60.0;    ///< Rate limit of pitch and roll. > 0.
  /// Rate limit of the gyro's reading (angular acceleration): a skid-steered rover starts
  /// and stops turning abruptly, several hundred deg/s^2. > 0.
  double max_turn_accel_dps2 = 500.0;
  /// The sensor file's vehicle limits (SensorModel::vehicle), when stated, replace the four
  /// above.
  /// Slack added to every rate limit, in counts of the channel (quantisation).
  double rate_slack_counts = 4.0;
  /// And in the channel's noise (ChannelModel::noise_rms): two samples' noise parts them by
  /// up to this many sigmas x sqrt(2). >= 0.
  double rate_noise_sigmas = 5.0;
  /// A channel whose noise the sensor file does not state has it estimated from its samples
  /// in the statistics window (robust sigma of the second differences), for the slack above;
  /// summary.json says which (`rate_limits.CHANNEL.noise_from`: "sensor file" or "log").
  bool estimate_missing_noise = true;
  /// A rule that rejects more than this share of a channel's samples is reported as a
  /// warning (a threshold or a sensor description that does not fit the log). (0, 1].
  double warning_share = 0.01;
  int hampel_half_window = 3;         ///< Hampel test over +-k accepted samples. >= 2.
  /// In robust sigmas: the larger of the window's 1.4826 MAD and the channel's noise level
  /// (from its second differences). > 0.
  double hampel_threshold = 5.0;
  double hampel_min_counts = 6.0;     ///< Smallest deviation called a spike, in counts.
  double stuck_min_s = 3.0;           ///< Shortest stuck run. > 0.
  /// The typical intervals (of the rows and of each channel) and each channel's noise level
  /// are medians over the first statistics_intervals intervals of the log (all of it when
  /// shorter), so that a log of any length is screened as it is read. >= 16.
  std::size_t statistics_intervals = 65536;
  void Validate() const;
  nlohmann::json ToJson() const;
};

/// One rejected, dropped or repaired sample (or row, when channel is not set).
struct ScreeningEvent {
  long line = 0;                ///< Line in the CSV file.
  double t_s = 0;
  int channel = -1;             ///< static_cast<int>(Channel), or -1 for a whole row.
  ScreeningRule rule = ScreeningRule::kSpike;
  double raw = 0;               ///< The raw count (or the time stamp for row rules).
};

/// The screened log.
struct ScreenedLog {
  std::size_t rows = 0;         ///< Kept rows.
  double first_t_s = 0, last_t_s = 0;  ///< Time stamps of the first and last kept rows.
  double typical_interval_s = 0;  ///< Median interval of the rows (statistics window).
  /// The arrays below are filled by ScreenTelemetry; a ScreeningStream hands its rows over
  /// one block at a time instead.
  std::vector<double> t_s;      ///< Kept rows, strictly increasing.
  /// Their indices in the TelemetryLog; empty when every row was kept (row k is then k).
  std::vector<std::size_t> row;
  /// Per channel and kept row: encoders: unwrapped cumulative counts; analog channels:
  /// radians (rad/s for the gyro), the compass unwrapped (continuous across +-180 deg).
  /// NaN where the sample is missing or was rejected. Empty for absent channels.
  std::array<std::vector<double>, kNumChannels> value;
  std::array<std::array<long, kNumChannels + 1>, kNumScreeningRules> counts{};  ///< [rule][channel or kNumChannels for rows]
  std::array<long, kNumChannels> samples{};  ///< Samples present per channel (rows kept).
  /// Each analog channel's rate limit (rad/s; the gyro's rad/s^2) and slack (rad; rad/s), as
  /// derived from the vehicle's limits and the sensor's noise (0: not an analog channel).
  std::array<double, kNumChannels> rate_limit{}, rate_slack{};
  /// The noise in that slack (rad; rad/s), from the sensor file or estimated from the log.
  std::array<double, kNumChannels> rate_noise{};
  std::array<bool, kNumChannels> rate_noise_from_log{};
  double warning_share = 0.01;  ///< ScreeningOptions::warning_share.
  std::vector<ScreeningEvent> events;

  /// The share of a channel's samples one rule rejected.
  struct Share {
    ScreeningRule rule;
    int channel;
    long rejected;
    double share;
    std::string Message() const;  ///< The warning line.
  };
  /// Every rejecting rule's share per channel (rules that rejected nothing left out).
  std::vector<Share> RejectionShares() const;
  /// Those above warning_share.
  std::vector<Share> Warnings() const;

  bool Has(Channel c) const { return !value[static_cast<int>(c)].empty(); }
  long Count(ScreeningRule rule) const;  ///< Over all channels and rows.
  nlohmann::json ReportJson() const;     ///< Counts per rule and channel.
};

/// Screening of a log that arrives a block of rows at a time (a log of any length in
/// bounded memory). Rows are numbered as kept (dropped rows skipped) from 0; a kept row is
/// final, screened for good, once every rule that looks ahead of it has seen enough of the
/// log: the spike test the next hampel_half_window accepted samples of each channel, the
/// stuck test the end of a run of repeated counts. Rows are held from the first not
/// Release()d one on, so memory is the look-ahead's (and the statistics window's at the start).
class ScreeningStream {
 public:
  /// `present`: the channels whose columns the log has.
  ScreeningStream(const SensorModel& model, const ScreeningOptions& options,
                  const std::array<bool, kNumChannels>& present);
  ~ScreeningStream();
  ScreeningStream(const ScreeningStream&) = delete;
  ScreeningStream& operator=(const ScreeningStream&) = delete;

  /// Screens the next rows of the log (in file order: their t_s, line and the present
  /// channels' counts).
  void Push(const TelemetryLog& rows);
  /// Appends rows to a TelemetryLog's per-row arrays (those of the present channels), up to
  /// a number of them; returns how many (0: the log has ended). TelemetryReader::Read is one.
  using Source = std::function<std::size_t(TelemetryLog*, std::size_t)>;
  /// Screens the next rows read by `source` (up to max_rows of them) straight into the held
  /// rows, without a copy; returns how many were read.
  std::size_t Read(const Source& source, std::size_t max_rows);
  /// The log has ended: every row becomes final and the events are sorted.
  void Finish();
  bool finished() const;
  /// Whether the statistics window has been read (typical_interval_s() is known).
  bool statistics_ready() const;
  double typical_interval_s() const;
  /// An analog channel's noise (rad; rad/s) as the rate limit uses it, from the sensor file
  /// or, where it states none, estimated from the statistics window (known once it is read).
  double rate_noise(Channel c) const;
  bool rate_noise_from_log(Channel c) const;

  bool Has(Channel c) const;
  std::size_t begin() const;      ///< First row held.
  std::size_t end() const;        ///< Rows kept so far.
  std::size_t final_end() const;  ///< Rows before it are final.
  /// Row k's time stamp and a channel's screened value (as in ScreenedLog::value; NaN when
  /// missing or rejected; final only for k < final_end()), for k in [begin(), end()); rows()
  /// has the raw counts too, as arrays.
  double t(std::size_t k) const;
  double value(Channel c, std::size_t k) const;
  /// The held rows as arrays: row k is element k - begin of each; valid until the next
  /// Push, Finish or Release. A channel not present has null arrays.
  struct Rows {
    std::size_t begin = 0, end = 0;
    const double* t_s = nullptr;
    std::array<const double*, kNumChannels> raw{}, value{};
  };
  Rows rows() const;
  /// Rows before k (<= final_end()) are no longer read: their memory may be reused.
  void Release(std::size_t k);
  /// Room for `rows` rows held at once (for a caller that will hold the whole log): the
  /// arrays are not regrown, and copied, as they fill.
  void Reserve(std::size_t rows);

  /// Counts and events so far (the events in order after Finish()); rows, first_t_s,
  /// last_t_s and typical_interval_s; no arrays.
  const ScreenedLog& report() const;
  /// After Finish() with nothing released: the whole screened log, arrays included.
  ScreenedLog TakeAll();

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

/// Applies the rules to a log read with `model`.
ScreenedLog ScreenTelemetry(const TelemetryLog& log, const SensorModel& model,
                            const ScreeningOptions& options);

/// Writes the events as CSV (line, t_s, channel, rule, raw), atomically.
void WriteScreeningLog(const std::filesystem::path& path, const ScreenedLog& screened);

}  // namespace lunarnav::telemetry
