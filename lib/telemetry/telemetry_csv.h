// Reading raw telemetry logs (CSV with a header) into per-channel arrays of counts.
#pragma once

#include <array>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "telemetry/sensor_model.h"

namespace lunarnav::telemetry {

/// A log as read: time stamps and raw counts, nothing screened or converted yet.
struct TelemetryLog {
  std::filesystem::path source;
  /// Time stamp of each row, seconds (the time column in the units the sensor model declares).
  std::vector<double> t_s;
  std::vector<long> line;             ///< 1-based line number of each row in the file.
  /// Raw counts per channel, one per row; NaN for an empty cell (a channel sampled at a lower
  /// rate). Empty vector when the channel is not in the sensor model or not in the file.
  std::array<std::vector<double>, kNumChannels> counts;
  /// Channels the sensor model configures whose column the file lacks.
  std::vector<Channel> missing_columns;
  /// Header columns nobody reads.
  std::vector<std::string> unused_columns;

  bool Has(Channel c) const { return !counts[static_cast<int>(c)].empty(); }
  std::size_t size() const { return t_s.size(); }
  /// Empties the per-row arrays (t_s, line, counts), keeping their capacity.
  void ClearRows();
};

/// A telemetry CSV read a piece at a time: the header when opened, then rows in blocks, so
/// that a log of any length is processed in bounded memory. The file format and the errors
/// are those of ReadTelemetryCsv.
class TelemetryReader {
 public:
  /// Opens `path` (a regular file is mapped, anything else, such as a pipe, read whole) and
  /// reads its header.
  /// @throws InputError "<file>:<line>: <reason>" for an unreadable file, no header or a
  ///         missing time column.
  TelemetryReader(const std::filesystem::path& path, const SensorModel& model);
  /// The same for text in memory, which must outlive the reader; `source` names it in errors.
  TelemetryReader(std::string_view text, const std::string& source, const SensorModel& model);
  ~TelemetryReader();
  TelemetryReader(const TelemetryReader&) = delete;
  TelemetryReader& operator=(const TelemetryReader&) = delete;

  /// Appends up to `max_rows` rows to `out`'s per-row arrays (t_s, line, and counts of the
  /// channels Has() names; the other arrays are left alone). Returns how many: 0 at the end.
  /// @throws InputError "<file>:<line>: <reason>" for a row with the wrong number of cells
  ///         or text where a number belongs.
  std::size_t Read(TelemetryLog* out, std::size_t max_rows);

  const std::filesystem::path& source() const;
  /// Whether the file has the channel's column (and the sensor model configures it).
  bool Has(Channel c) const;
  const std::vector<Channel>& missing_columns() const;  ///< As in TelemetryLog.
  const std::vector<std::string>& unused_columns() const;
  /// Lines not yet read: an upper bound on the rows to come.
  std::size_t LinesLeft() const;
  /// Fraction of the text read so far, in [0, 1].
  double FractionRead() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Reads a telemetry CSV: an optional block of '#' comment lines, a header naming the
/// columns, then one row per sample. The time column (model.time_column) is required; each
/// configured channel is read from its column. Cells are separated by commas (spaces around
/// them are ignored); counts are integers, time stamps decimal numbers; an empty cell is a
/// missing sample.
/// @throws InputError "<file>:<line>: <reason>" for a missing time column, a row with the
///         wrong number of cells, or text where a number belongs.
TelemetryLog ReadTelemetryCsv(const std::filesystem::path& path, const SensorModel& model);

/// The same from text already in memory; `source` names it in errors.
TelemetryLog ParseTelemetryCsv(std::string_view text, const std::string& source, const SensorModel& model);

}  // namespace lunarnav::telemetry
