#include "stereo/window_requests.h"

#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include "util/check.h"
#include "util/text_lines.h"
#include "util/errors.h"
#include "util/parse.h"

namespace lunarnav::stereo {
namespace {

using util::Trim;

std::vector<std::string> SplitCells(const std::string& line) {
  std::vector<std::string> cells;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    cells.push_back(Trim(line.substr(start, comma == std::string::npos ? std::string::npos : comma - start)));
    if (comma == std::string::npos) return cells;
    start = comma + 1;
  }
}

double ParseMetres(const std::string& cell, const std::string& where, const char* column) {
  std::size_t used = 0;
  double value = NAN;
  try {
    value = std::stod(cell, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  LN_CHECK_INPUT(!cell.empty() && used == cell.size() && std::isfinite(value))
      << where << ": column '" << column << "': '" << cell << "' is not a finite number";
  return value;
}

}  // namespace

std::vector<WindowRequest> ReadWindowRequests(const std::filesystem::path& path) {
  LN_CHECK_INPUT(std::ifstream(path).good()) << path.string() << ": cannot open the requests file";
  util::TextLines lines(path);
  std::vector<WindowRequest> requests;
  std::map<std::string, long> first_line;
  bool have_header = false;
  std::string trimmed;
  while (lines.Next(&trimmed)) {
    const long line_number = lines.number();
    const std::string where = lines.Where();
    const std::vector<std::string> cells = SplitCells(trimmed);
    if (!have_header) {
      LN_CHECK_INPUT(cells == std::vector<std::string>({"stem", "y_min_m", "y_max_m"}))
          << where << ": expected the header 'stem,y_min_m,y_max_m', got '" << trimmed << "'";
      have_header = true;
      continue;
    }
    LN_CHECK_INPUT(cells.size() == 3) << where << ": " << cells.size() << " cells, expected 3 (stem,y_min_m,y_max_m)";
    WindowRequest r;
    r.stem = cells[0];
    r.line = line_number;
    LN_CHECK_INPUT(!r.stem.empty()) << where << ": empty stem";
    r.y_min_m = ParseMetres(cells[1], where, "y_min_m");
    r.y_max_m = ParseMetres(cells[2], where, "y_max_m");
    LN_CHECK_INPUT(r.y_min_m <= r.y_max_m)
        << where << ": Y_min " << r.y_min_m << " m is greater than Y_max " << r.y_max_m << " m";
    // As far as plan-windows may ask (mapping::kMaxRequestDistanceM): 1e300 m reached the
    // window selection as an empty band, blamed on no file.
    LN_CHECK_INPUT(std::abs(r.y_min_m) <= kMaxRequestY && std::abs(r.y_max_m) <= kMaxRequestY)
        << where << ": Y " << r.y_min_m << " to " << r.y_max_m << " m: a request reaches at most " << kMaxRequestY
        << " m";
    const auto [it, inserted] = first_line.emplace(r.stem, line_number);
    LN_CHECK_INPUT(inserted) << where << ": stem '" << r.stem << "' already requested on line " << it->second;
    requests.push_back(r);
  }
  LN_CHECK_INPUT(have_header) << path.string() << ": no header line (the file is empty)";
  return requests;
}

}  // namespace lunarnav::stereo
