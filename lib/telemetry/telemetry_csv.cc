#include "telemetry/telemetry_csv.h"

#include <charconv>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <string_view>

#include "util/check.h"

namespace lunarnav::telemetry {
namespace {

std::string_view Trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

// Splits one line at commas into `cells` (views into the line); returns the count.
int SplitCells(std::string_view line, std::vector<std::string_view>* cells) {
  cells->clear();
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    cells->push_back(Trim(line.substr(start, comma == std::string_view::npos ? line.npos : comma - start)));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return static_cast<int>(cells->size());
}

}  // namespace

TelemetryLog ParseTelemetryCsv(const std::string& text, const std::string& source,
                               const SensorModel& model) {
  TelemetryLog log;
  log.source = source;
  const std::string_view all(text);
  std::size_t pos = 0;
  long line_number = 0;
  auto next_line = [&](std::string_view* line) {
    if (pos >= all.size()) return false;
    std::size_t end = all.find('\n', pos);
    if (end == std::string_view::npos) end = all.size();
    *line = all.substr(pos, end - pos);
    pos = end + 1;
    ++line_number;
    return true;
  };

  // Header: the first line that is neither blank nor a comment.
  std::string_view line;
  std::vector<std::string_view> cells;
  bool have_header = false;
  while (next_line(&line)) {
    const std::string_view trimmed = Trim(line);
    if (trimmed.empty() || trimmed.front() == '#') continue;
    have_header = true;
    break;
  }
  LN_CHECK_INPUT(have_header) << source << ": no header line (the file is empty)";
  const long header_line = line_number;
  const int num_columns = SplitCells(line, &cells);
  std::vector<std::string> header(cells.begin(), cells.end());

  // Which column feeds what: -2 = time, channel index, or -1 = unused.
  std::vector<int> role(num_columns, -1);
  int time_column = -1;
  for (int c = 0; c < num_columns; ++c) {
    if (header[c] == model.time_column) {
      LN_CHECK_INPUT(time_column < 0) << source << ":" << header_line << ": column '"
                                      << header[c] << "' appears twice";
      time_column = c;
      role[c] = -2;
    }
  }
  LN_CHECK_INPUT(time_column >= 0) << source << ":" << header_line
                                   << ": missing required column '" << model.time_column << "'";
  for (Channel ch : kAllChannels) {
    const ChannelModel& m = model[ch];
    if (!m.present) continue;
    int found = -1;
    for (int c = 0; c < num_columns; ++c) {
      if (header[c] == m.column) found = c;
    }
    if (found < 0) {
      log.missing_columns.push_back(ch);
    } else {
      role[found] = static_cast<int>(ch);
    }
  }
  for (int c = 0; c < num_columns; ++c) {
    if (role[c] == -1) log.unused_columns.push_back(header[c]);
  }
  std::vector<std::vector<double>*> sink(num_columns, nullptr);
  for (int c = 0; c < num_columns; ++c) {
    if (role[c] >= 0) sink[c] = &log.counts[role[c]];
  }

  // Rows. A reservation from the file size avoids regrowing the arrays.
  const std::size_t estimate = (all.size() - pos) / (8 * static_cast<std::size_t>(num_columns) + 1) + 16;
  log.t_s.reserve(estimate);
  log.line.reserve(estimate);
  for (auto* s : sink) {
    if (s != nullptr) s->reserve(estimate);
  }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  while (next_line(&line)) {
    const std::string_view trimmed = Trim(line);
    if (trimmed.empty() || trimmed.front() == '#') continue;
    const int n = SplitCells(line, &cells);
    LN_CHECK_INPUT(n == num_columns) << source << ":" << line_number << ": " << n << " cells, the header has "
                                     << num_columns;
    for (int c = 0; c < num_columns; ++c) {
      const std::string_view cell = cells[c];
      if (c == time_column) {
        double t = 0;
        const auto [ptr, ec] = std::from_chars(cell.data(), cell.data() + cell.size(), t);
        LN_CHECK_INPUT(!cell.empty() && ec == std::errc() && ptr == cell.data() + cell.size() &&
                       std::isfinite(t))
            << source << ":" << line_number << ": column '" << header[c] << "': '" << cell
            << "' is not a time stamp";
        log.t_s.push_back(t);
      } else if (sink[c] != nullptr) {
        if (cell.empty()) {
          sink[c]->push_back(nan);
          continue;
        }
        long long count = 0;
        const char* first = cell.data() + (cell.front() == '+' ? 1 : 0);
        const auto [ptr, ec] = std::from_chars(first, cell.data() + cell.size(), count);
        LN_CHECK_INPUT(ec == std::errc() && ptr == cell.data() + cell.size())
            << source << ":" << line_number << ": column '" << header[c] << "': '" << cell
            << "' is not an integer count";
        sink[c]->push_back(static_cast<double>(count));
      }
    }
    log.line.push_back(line_number);
  }
  return log;
}

TelemetryLog ReadTelemetryCsv(const std::filesystem::path& path, const SensorModel& model) {
  std::ifstream in(path, std::ios::binary);
  LN_CHECK_INPUT(in.good()) << path.string() << ": cannot open";
  std::string text;
  in.seekg(0, std::ios::end);
  text.resize(static_cast<std::size_t>(in.tellg()));
  in.seekg(0);
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  LN_CHECK_INPUT(in.good() || in.eof()) << path.string() << ": read error";
  return ParseTelemetryCsv(text, path.string(), model);
}

}  // namespace lunarnav::telemetry
