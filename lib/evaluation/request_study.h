// Figure 3 of Krotkov & Hebert (1995), sec. 3.3: the average of the minimum and maximum of the
// requested image rows, disparities and distances Y over a run, and how steadily the requests
// stay near those averages ("within 10 % of the average values").
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "evaluation/table.h"

namespace lunarnav::evaluation {

/// The window one pair of a stereo-batch run measured (its sidecar's result.window).
struct RequestWindow {
  std::string stem;
  std::string source;      ///< "requests" or "range-y".
  long request_line = 0;   ///< Line of the requests file (0 for range-y).
  double y_min_m = 0, y_max_m = 0;        ///< The distance interval I_Y, metres.
  int row_min = 0, row_max = 0;           ///< Reference-image rows searched, inclusive.
  int d_min_px = 0, d_max_px = 0;         ///< Disparities searched, inclusive.
};

/// The windows of a stereo-batch output directory, in stem order, from its sidecars
/// (RUN_DIR/disparity/<stem>.json; so shards and resumed runs count too). Pairs processed
/// without window selection are counted in `without_window`.
/// @throws InputError when RUN_DIR/disparity cannot be listed, a sidecar is unreadable or not a
///         stereo-batch sidecar (naming the file), or no pair has a window (run stereo-batch with
///         --rig and --range-y or --requests).
std::vector<RequestWindow> ReadRequestWindows(const std::filesystem::path& run_dir, int* without_window = nullptr);

/// Mean, minimum and maximum of one bound over the run.
struct BoundStats {
  double mean = 0, min = 0, max = 0;
};

/// One line of Figure 3: a quantity's lower and upper bounds over the run.
struct QuantityStats {
  std::string name;    ///< "y", "d" or "Y".
  std::string unit;    ///< "px" or "m".
  BoundStats lower, upper;
  int within = 0;      ///< Pairs whose both bounds lie within the tolerance of their means.
};

struct RequestStudy {
  double tolerance = 0.10;
  std::vector<RequestWindow> windows;
  std::vector<QuantityStats> quantities;  ///< y (rows), d (disparities), Y (distances).
  std::vector<bool> within;  ///< Per pair: all six bounds within the tolerance of their means.
  int within_count = 0;
  /// First pair (index into windows) from which every pair is within; -1 when the last is not.
  int steady_from = -1;
};

/// True when |value - mean| <= tolerance |mean|.
bool WithinTolerance(double value, double mean, double tolerance);

/// Statistics of the windows. @throws std::invalid_argument for no windows or a tolerance
/// outside [0, 1].
RequestStudy SummarizeRequests(std::vector<RequestWindow> windows, double tolerance = 0.10);

/// Figure 3: one row per quantity (y, d, Y): mean of the minimum and maximum bound and their
/// difference, the range of each bound over the run, the pairs within the tolerance, and the
/// paper's values beside them.
Table RequestsTable(const RequestStudy& study);
/// Every pair's window (the data of the figure): index, stem, source, y, d, Y bounds, within.
Table RequestPairsTable(const RequestStudy& study);
/// gnuplot commands: three panels (rows, disparities, distances), each pair's bounds against
/// its index with the means and the tolerance band, reading `pairs_csv` (RequestPairsTable's CSV).
std::string RequestsFigureCommands(const RequestStudy& study, const std::string& pairs_csv);

/// The inputs and options of `evaluate requests` (docs/evaluate.md).
struct RequestsCommand {
  std::filesystem::path run, output_dir;  ///< run: a stereo-batch output directory.
  double tolerance = 0.10;                ///< As SummarizeRequests.
};

/// `evaluate requests`: writes the requests and request_pairs tables, the figure and
/// summary.json (`summary_head` plus inputs, options, counts, table, figures).
/// @return kExitOk. @throws std::invalid_argument for a tolerance outside [0, 1];
///         InputError as ReadRequestWindows.
int RunRequestsCommand(const RequestsCommand& command, const nlohmann::json& summary_head);

}  // namespace lunarnav::evaluation
