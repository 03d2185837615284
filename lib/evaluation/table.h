// Result tables of `evaluate`, written as CSV, JSON and Markdown with the same content.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace lunarnav::evaluation {

/// One cell: a number, a text, or "n/a" with the reason (never a silent zero).
class Cell {
 public:
  static Cell Number(double value) { Cell c; c.number_ = value; return c; }
  static Cell Text(std::string text) { Cell c; c.text_ = std::move(text); return c; }
  static Cell NotAvailable(std::string reason) { Cell c; c.na_reason_ = std::move(reason); return c; }
  /// A number, or n/a with `reason` when it is not finite.
  static Cell NumberOr(double value, const std::string& reason);

  bool IsNumber() const { return number_.has_value(); }
  bool IsNotAvailable() const { return !number_ && !text_; }
  double number() const { return *number_; }
  const std::string& reason() const { return na_reason_; }
  /// As printed with `precision` decimals: "12.34", the text, or "n/a (reason)".
  std::string Format(int precision) const;
  nlohmann::json ToJson() const;

 private:
  std::optional<double> number_;
  std::optional<std::string> text_;
  std::string na_reason_;
};

struct Column {
  std::string name;       ///< e.g. "bad_1" (CSV header: name_unit, e.g. "bad_1_pct").
  std::string unit;       ///< e.g. "pct", "px", "m"; empty for none.
  std::string heading;    ///< Markdown heading, e.g. "bad-1 (%)".
  int precision = 3;      ///< Decimals in CSV and Markdown.
};

struct Table {
  std::string title;              ///< Markdown heading and JSON "title".
  std::vector<Column> columns;
  std::vector<std::vector<Cell>> rows;
  std::vector<std::string> notes; ///< Printed under the Markdown table; JSON "notes".

  void AddRow(std::vector<Cell> row);
  std::string ToCsv() const;
  std::string ToMarkdown() const;
  nlohmann::json ToJson() const;
};

/// Writes `<dir>/<name>.csv`, `.json` and `.md` atomically.
void WriteTable(const std::filesystem::path& dir, const std::string& name, const Table& table);

}  // namespace lunarnav::evaluation
