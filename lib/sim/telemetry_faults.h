// Faults injected into a simulated telemetry log on request, with a record of each one so
// that tests can check that screening (telemetry/screening.h) catches them: "the raw data
// from each of the four types of sensor is biased and noisy and sometimes corrupt"
// (Krotkov & Hebert sec. 4.1).
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "sim/rover_sensors.h"
#include "telemetry/sensor_model.h"

namespace lunarnav::sim {

/// Kinds of fault. Their names are those of the screening rules that should report them.
enum class FaultKind {
  kSpike,                ///< One sample far off (analog: 1-2x max(12, 2^bits/32) counts; encoder: a jump).
  kStuck,                ///< A channel repeats its last count for a while.
  kDropout,              ///< A channel's cells are empty for a while.
  kRepeatedTimestamp,    ///< A row carries the previous row's time stamp.
  kOutOfOrderTimestamp,  ///< Two rows swapped: the second is earlier than the first.
  kOutOfRange            ///< A count outside the channel's valid range.
};
std::string ToString(FaultKind kind);
std::optional<FaultKind> FaultKindFromString(const std::string& name);
/// Row faults concern a whole row (its time stamp); the others one channel.
bool IsRowFault(FaultKind kind);

/// One request, parsed from KIND[:CHANNEL][@TIME | *COUNT | ~PER_MINUTE][+SECONDS]:
///   spike:compass@30      a compass spike at the first sample at or after 30 s
///   stuck:enc_fl@40+6     the front-left encoder stuck from 40 s for 6 s
///   dropout*3             three dropouts of random channels at random times
///   out_of_range:gyro_z~2 about two per minute of log (rounded over its length)
///   repeated_timestamp@12
/// CHANNEL is a channel name or `any` (the default: a random channel per fault); row faults
/// take none. +SECONDS is the length of a stuck run (default 5 s) or dropout (default 2 s).
struct FaultSpec {
  FaultKind kind = FaultKind::kSpike;
  std::optional<telemetry::Channel> channel;  ///< Unset: a random channel per fault.
  std::optional<double> at_s;                 ///< Place one fault here.
  int count = 1;                              ///< Else this many at random times...
  std::optional<double> per_minute;           ///< ...or this many per minute of log.
  std::optional<double> duration_s;           ///< Stuck, dropout.
  std::string text;                           ///< As given.
  /// Seconds a stuck run or dropout lasts (the default when duration_s is unset), else 0.
  double Duration() const;
};

/// Parses one request. KIND is a kind's name (ToString) or a spelling of it with hyphens
/// and/or a plural s ("spikes", "dropouts", "out-of-range").
/// @throws std::invalid_argument naming the text and the problem.
FaultSpec ParseFaultSpec(const std::string& text);

/// As ParseFaultSpec, also accepting the group `timestamps` (a repeated and an out-of-order
/// time stamp, each with the rest of the request: `timestamps*2` is two of each; it takes no
/// @TIME, since the two would land on one row).
std::vector<FaultSpec> ParseFaultSpecs(const std::string& text);

/// One injected fault.
struct InjectedFault {
  FaultKind kind = FaultKind::kSpike;
  int channel = -1;           ///< static_cast<int>(Channel); -1 for row faults.
  std::size_t row = 0;        ///< First affected row. Out of order: the row with the earlier time.
  std::size_t rows = 1;       ///< Rows affected (stuck, dropout: the run's length).
  std::int64_t t_us = 0;      ///< Time stamp written in that row.
  std::int64_t value = 0;     ///< Count written (spike, out of range, stuck), 0 for a dropout;
                              ///< row faults: the time stamp written, microseconds.
  std::int64_t original = 0;  ///< The count (or time stamp) it replaced.
  std::string spec;           ///< The request it came from.
};

/// Places and applies the requests in order. Faults at random times keep clear of the
/// others (1 s between any two, 2 s on one channel, 2 s from either end of the log); one
/// at a given time goes exactly there (or, for a channel at a lower rate than the rows, to
/// its next sample). A random channel is one the model has; a channel fault lands on a row
/// where the channel has a sample, and a stuck run repeats the sample before it in the
/// run's sampled cells. A stuck or dropout run is cut at the log's end.
/// @param seed  the "faults" stream: the same requests and seed give the same faults.
/// @throws std::invalid_argument for a time outside the log, or too many faults to place.
std::vector<InjectedFault> InjectFaults(const std::vector<FaultSpec>& specs, const telemetry::SensorModel& model,
                                        std::uint64_t seed, RawTelemetry* raw);

/// Writes faults.csv atomically: `row,line,t_s,channel,kind,rows,value,original` per fault,
/// in row order (row: 0-based data row of telemetry.csv; line: its line in the file;
/// channel: a name or `row`; for row faults value and original are time stamps in seconds).
void WriteFaultsCsv(const std::filesystem::path& path, const std::vector<InjectedFault>& faults);

}  // namespace lunarnav::sim
