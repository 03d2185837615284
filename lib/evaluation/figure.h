// Figures of `evaluate`: PNG images drawn by gnuplot from the CSV data written beside them.
//
// Every figure is a CSV file (the data, always written) plus a gnuplot script that plots it;
// the PNG is rendered by running gnuplot (Debian package gnuplot-nox) and renamed into
// place atomically. Without gnuplot the data and the script are still written, so the figure
// can be drawn elsewhere with `gnuplot NAME.gp`.
#pragma once

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

namespace lunarnav::evaluation {

struct FigureResult {
  std::filesystem::path png, script;
  bool rendered = false;
  std::string problem;  ///< Why the PNG was not rendered (empty when it was).
};

/// Writes `<dir>/<name>.gp` (a gnuplot script: a pngcairo terminal of `width` x `height`
/// pixels writing `<name>.png`, then `commands`, which name their data files relative to
/// `dir`) and renders `<dir>/<name>.png` with it. Never throws for a missing or failing
/// gnuplot: the result says what happened.
FigureResult WriteFigure(const std::filesystem::path& dir, const std::string& name, const std::string& commands,
                         int width = 900, int height = 600);

/// The entry of a figure in a summary.json: {png, data, rendered, problem}, `data` the CSV
/// it plots. Logs a warning when the PNG was not rendered.
nlohmann::json FigureSummary(const FigureResult& figure, const std::string& data_csv);

/// Quotes `text` for a gnuplot string literal (double quotes, backslashes escaped).
std::string GnuplotString(const std::string& text);

}  // namespace lunarnav::evaluation
