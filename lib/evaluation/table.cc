#include "evaluation/table.h"

#include <cmath>
#include <sstream>

#include "io/atomic_file.h"
#include "util/check.h"

namespace lunarnav::evaluation {
namespace {

std::string CsvField(const std::string& text) {
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string quoted = "\"";
  for (char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

std::string MarkdownField(const std::string& text) {
  std::string out;
  for (char c : text) out += c == '|' ? std::string("\\|") : std::string(1, c);
  return out;
}

}  // namespace

Cell Cell::NumberOr(double value, const std::string& reason) {
  return std::isfinite(value) ? Number(value) : NotAvailable(reason);
}

std::string Cell::Format(int precision) const {
  if (number_) {
    std::ostringstream s;
    s.setf(std::ios::fixed);
    s.precision(precision);
    s << *number_;
    return s.str();
  }
  if (text_) return *text_;
  return "n/a (" + na_reason_ + ")";
}

nlohmann::json Cell::ToJson() const {
  if (number_) return *number_;
  if (text_) return *text_;
  return {{"n/a", na_reason_}};
}

void Table::AddRow(std::vector<Cell> row) {
  LN_CHECK(row.size() == columns.size()) << title << ": row of " << row.size() << " cells for "
                                         << columns.size() << " columns";
  rows.push_back(std::move(row));
}

std::string Table::ToCsv() const {
  std::ostringstream s;
  for (std::size_t c = 0; c < columns.size(); ++c) {
    s << (c ? "," : "") << CsvField(columns[c].unit.empty() ? columns[c].name
                                                            : columns[c].name + "_" + columns[c].unit);
  }
  s << "\n";
  for (const auto& row : rows) {
    for (std::size_t c = 0; c < row.size(); ++c) {
      s << (c ? "," : "") << CsvField(row[c].Format(columns[c].precision));
    }
    s << "\n";
  }
  return s.str();
}

std::string Table::ToMarkdown() const {
  std::ostringstream s;
  if (!title.empty()) s << "### " << title << "\n\n";
  s << "|";
  for (const Column& c : columns) s << " " << MarkdownField(c.heading.empty() ? c.name : c.heading) << " |";
  s << "\n|";
  for (std::size_t c = 0; c < columns.size(); ++c) s << (c == 0 ? "---|" : "---:|");
  s << "\n";
  for (const auto& row : rows) {
    s << "|";
    for (std::size_t c = 0; c < row.size(); ++c) s << " " << MarkdownField(row[c].Format(columns[c].precision)) << " |";
    s << "\n";
  }
  if (!notes.empty()) {
    s << "\n";
    for (const std::string& note : notes) s << note << "\n";
  }
  return s.str();
}

nlohmann::json Table::ToJson() const {
  nlohmann::json cols = nlohmann::json::array(), body = nlohmann::json::array();
  for (const Column& c : columns) cols.push_back({{"name", c.name}, {"unit", c.unit}});
  for (const auto& row : rows) {
    nlohmann::json r;
    for (std::size_t c = 0; c < row.size(); ++c) r[columns[c].name] = row[c].ToJson();
    body.push_back(std::move(r));
  }
  return {{"title", title}, {"columns", cols}, {"rows", body}, {"notes", notes}};
}

void WriteTable(const std::filesystem::path& dir, const std::string& name, const Table& table) {
  io::WriteFileAtomic(dir / (name + ".csv"), table.ToCsv());
  io::WriteFileAtomic(dir / (name + ".json"), table.ToJson().dump(2) + "\n");
  io::WriteFileAtomic(dir / (name + ".md"), table.ToMarkdown());
}

}  // namespace lunarnav::evaluation
