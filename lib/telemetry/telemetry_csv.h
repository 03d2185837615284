// Reading raw telemetry logs (CSV with a header) into per-channel arrays of counts.
#pragma once

#include <array>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "telemetry/sensor_model.h"

namespace lunarnav::telemetry {

/// A log as read: time stamps and raw counts, nothing screened or converted yet.
struct TelemetryLog {
  std::filesystem::path source;
  std::vector<double> t_s;            ///< Time stamp of each row, seconds, as written.
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
