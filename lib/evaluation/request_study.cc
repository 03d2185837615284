#include "evaluation/request_study.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <sstream>

#include <nlohmann/json.hpp>

#include "evaluation/figure.h"
#include "io/atomic_file.h"
#include "io/json_io.h"
#include "util/check.h"
#include "util/errors.h"
#include "util/log.h"
#include "util/timer.h"

namespace lunarnav::evaluation {
namespace fs = std::filesystem;

namespace {

// The paper's Figure 3 (a 150 m, 310-image run at 0.15 m/s): mean min and max of y, d, Y.
struct PaperLine {
  double min, max;
};
const std::map<std::string, PaperLine> kPaper = {{"y", {130, 233}}, {"d", {44, 118}}, {"Y", {4.2, 7.5}}};

BoundStats Stats(const std::vector<double>& v) {
  BoundStats s;
  double sum = 0;
  s.min = std::numeric_limits<double>::infinity();
  s.max = -s.min;
  for (double x : v) {
    sum += x;
    s.min = std::min(s.min, x);
    s.max = std::max(s.max, x);
  }
  s.mean = sum / static_cast<double>(v.size());
  return s;
}

}  // namespace

std::vector<RequestWindow> ReadRequestWindows(const fs::path& run_dir, int* without_window) {
  const fs::path dir = run_dir / "disparity";
  std::error_code ec;
  LN_CHECK_INPUT(fs::is_directory(dir, ec))
      << dir.string() << ": not found; expected a stereo-batch output directory (disparity/<stem>.json)";
  std::vector<fs::path> sidecars;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const fs::path& path = entry.path();
    const std::string name = path.filename().string();
    if (name.empty() || name[0] == '.' || path.extension() != ".json" || !entry.is_regular_file(ec)) continue;
    sidecars.push_back(path);
  }
  LN_CHECK_INPUT(!ec) << dir.string() << ": cannot list (" << ec.message() << ")";
  std::sort(sidecars.begin(), sidecars.end());
  std::vector<RequestWindow> windows;
  int without = 0;
  for (const fs::path& path : sidecars) {
    const nlohmann::json j = io::ReadJson(path);
    LN_CHECK_INPUT(j.is_object() && j.value("format", "") == "lunarnav.disparity/1")
        << path.string() << ": not a stereo-batch sidecar (format lunarnav.disparity/1)";
    const nlohmann::json* w = nullptr;
    if (j.contains("result") && j["result"].is_object() && j["result"].contains("window")) w = &j["result"]["window"];
    // The rig's default search (source rig-ground) is not window selection for a distance.
    if (w != nullptr && w->is_object() && w->value("source", "") == "rig-ground") w = nullptr;
    if (w == nullptr) {
      ++without;
      continue;
    }
    RequestWindow r;
    try {
      r.stem = j.at("stem").get<std::string>();
      r.source = w->value("source", "");
      r.request_line = w->value("request_line", 0L);
      r.y_min_m = w->at("region").at("y_m").at(0).get<double>();
      r.y_max_m = w->at("region").at("y_m").at(1).get<double>();
      r.row_min = w->at("rows").at(0).get<int>();
      r.row_max = w->at("rows").at(1).get<int>();
      r.d_min_px = w->at("disparity_px").at(0).get<int>();
      r.d_max_px = w->at("disparity_px").at(1).get<int>();
    } catch (const nlohmann::json::exception& e) {
      throw InputError(path.string() + ": result.window: " + e.what());
    }
    windows.push_back(std::move(r));
  }
  LN_CHECK_INPUT(!windows.empty())
      << run_dir.string() << ": no pair has a window (" << sidecars.size()
      << " sidecars); run stereo-batch with --rig and --range-y or --requests";
  if (without_window != nullptr) *without_window = without;
  return windows;
}

bool WithinTolerance(double value, double mean, double tolerance) {
  return std::abs(value - mean) <= tolerance * std::abs(mean) + 1e-12;
}

RequestStudy SummarizeRequests(std::vector<RequestWindow> windows, double tolerance) {
  LN_CHECK_ARG(!windows.empty()) << "requests: no windows to summarise";
  LN_CHECK_ARG(std::isfinite(tolerance) && tolerance >= 0 && tolerance <= 1)
      << "tolerance: must be in [0, 1] (0.1 = 10 %), got " << tolerance;
  RequestStudy study;
  study.tolerance = tolerance;
  study.windows = std::move(windows);
  const std::size_t n = study.windows.size();
  struct Bounds {
    std::string name, unit;
    std::vector<double> lower, upper;
  };
  std::vector<Bounds> bounds = {{"y", "px", {}, {}}, {"d", "px", {}, {}}, {"Y", "m", {}, {}}};
  for (const RequestWindow& w : study.windows) {
    bounds[0].lower.push_back(w.row_min);
    bounds[0].upper.push_back(w.row_max);
    bounds[1].lower.push_back(w.d_min_px);
    bounds[1].upper.push_back(w.d_max_px);
    bounds[2].lower.push_back(w.y_min_m);
    bounds[2].upper.push_back(w.y_max_m);
  }
  study.within.assign(n, true);
  for (const Bounds& b : bounds) {
    QuantityStats q{b.name, b.unit, Stats(b.lower), Stats(b.upper), 0};
    for (std::size_t i = 0; i < n; ++i) {
      const bool ok = WithinTolerance(b.lower[i], q.lower.mean, tolerance) &&
                      WithinTolerance(b.upper[i], q.upper.mean, tolerance);
      q.within += ok;
      if (!ok) study.within[i] = false;
    }
    study.quantities.push_back(q);
  }
  study.within_count = static_cast<int>(std::count(study.within.begin(), study.within.end(), true));
  for (std::size_t i = n; i-- > 0 && study.within[i];) study.steady_from = static_cast<int>(i);
  return study;
}

Table RequestsTable(const RequestStudy& study) {
  Table t;
  t.title = "Requested rows, disparities and distances over the run (Figure 3)";
  t.columns = {{"quantity", "", "", 0},
               {"unit", "", "unit", 0},
               {"mean_min", "", "min (mean)", 2},
               {"mean_max", "", "max (mean)", 2},
               {"mean_delta", "", "Δ (mean)", 2},
               {"min_lowest", "", "min: lowest", 2},
               {"min_highest", "", "min: highest", 2},
               {"max_lowest", "", "max: lowest", 2},
               {"max_highest", "", "max: highest", 2},
               {"within", "pct", "pairs within ±" + Cell::Number(100 * study.tolerance).Format(0) + " % (%)", 1},
               {"paper_min", "", "paper min", 1},
               {"paper_max", "", "paper max", 1},
               {"paper_delta", "", "paper Δ", 1}};
  const double n = static_cast<double>(study.windows.size());
  for (const QuantityStats& q : study.quantities) {
    const std::string label = q.name == "y" ? "y (rows)" : q.name == "d" ? "d (disparity)" : "Y (distance)";
    const PaperLine& p = kPaper.at(q.name);
    t.AddRow({Cell::Text(label), Cell::Text(q.unit), Cell::Number(q.lower.mean), Cell::Number(q.upper.mean),
              Cell::Number(q.upper.mean - q.lower.mean), Cell::Number(q.lower.min), Cell::Number(q.lower.max),
              Cell::Number(q.upper.min), Cell::Number(q.upper.max), Cell::Number(100.0 * q.within / n),
              Cell::Number(p.min), Cell::Number(p.max), Cell::Number(p.max - p.min)});
  }
  std::ostringstream n1, n2;
  n1 << study.windows.size() << " pairs; " << study.within_count << " ("
     << Cell::Number(100.0 * study.within_count / n).Format(1) << " %) have all six bounds within ±"
     << Cell::Number(100 * study.tolerance).Format(0) << " % of their means; ";
  if (study.steady_from < 0) {
    n1 << "the last pair is not within, so the run has no steady tail.";
  } else {
    n1 << "every pair from #" << study.steady_from << " (" << study.windows[study.steady_from].stem
       << ") on is within (the paper: after an initial adjustment phase, within 10 %).";
  }
  n2 << "Rows and disparities as searched (window selection rounds outward and adds the disparity margin); the "
        "paper's values are from a 150 m, 310-image run at 0.15 m/s with its own camera and heights.";
  t.notes = {n1.str(), n2.str()};
  return t;
}

Table RequestPairsTable(const RequestStudy& study) {
  Table t;
  t.title = "Window of every pair";
  t.columns = {{"index", "", "#", 0},       {"stem", "", "stem", 0},       {"source", "", "source", 0},
               {"y_min", "px", "y_min", 0}, {"y_max", "px", "y_max", 0},   {"d_min", "px", "d_min", 0},
               {"d_max", "px", "d_max", 0}, {"Y_min", "m", "Y_min (m)", 3}, {"Y_max", "m", "Y_max (m)", 3},
               {"within", "", "within", 0}};
  for (std::size_t i = 0; i < study.windows.size(); ++i) {
    const RequestWindow& w = study.windows[i];
    t.AddRow({Cell::Number(static_cast<double>(i)), Cell::Text(w.stem), Cell::Text(w.source),
              Cell::Number(w.row_min), Cell::Number(w.row_max), Cell::Number(w.d_min_px), Cell::Number(w.d_max_px),
              Cell::Number(w.y_min_m), Cell::Number(w.y_max_m), Cell::Number(study.within[i] ? 1 : 0)});
  }
  return t;
}

std::string RequestsFigureCommands(const RequestStudy& study, const std::string& pairs_csv) {
  std::ostringstream gp;
  const std::string data = GnuplotString(pairs_csv);
  const double tol = study.tolerance;
  gp << "set multiplot layout 3,1 title \"Requested windows over the run: each pair's bounds, their means "
        "(dashed) and +-"
     << Cell::Number(100 * tol).Format(0) << " % of the means (shaded)\"\n"
     << "set grid\nset key outside right top\nset offsets graph 0.02, 0.02, 0.1, 0.1\n"
     << "set style fill transparent solid 0.15 noborder\n";
  // Columns of the pairs CSV: 1 index, 4-5 y, 6-7 d, 8-9 Y.
  const int columns[3] = {4, 6, 8};
  const char* titles[3] = {"image rows y (px)", "disparity d (px)", "distance Y (m)"};
  for (std::size_t k = 0; k < study.quantities.size() && k < 3; ++k) {
    const QuantityStats& q = study.quantities[k];
    const int c = columns[k];
    gp << "set ylabel " << GnuplotString(titles[k]) << "\n"
       << (k == 2 ? "set xlabel \"pair (stem order)\"\n" : "unset xlabel\n")
       << "plot " << data << " using 1:(" << q.lower.mean * (1 - tol) << "):(" << q.lower.mean * (1 + tol)
       << ") skip 1 with filledcurves lc rgb \"#1f77b4\" notitle, \\\n     "
       << data << " using 1:(" << q.upper.mean * (1 - tol) << "):(" << q.upper.mean * (1 + tol)
       << ") skip 1 with filledcurves lc rgb \"#d62728\" notitle, \\\n     "
       << data << " using 1:" << c << " skip 1 with linespoints pt 7 ps 0.6 lc rgb \"#1f77b4\" title \"min\", \\\n     "
       << data << " using 1:" << c + 1
       << " skip 1 with linespoints pt 7 ps 0.6 lc rgb \"#d62728\" title \"max\", \\\n     "
       << q.lower.mean << " with lines dt 2 lc rgb \"#1f77b4\" title \"mean min\", \\\n     "
       << q.upper.mean << " with lines dt 2 lc rgb \"#d62728\" title \"mean max\"\n";
  }
  gp << "unset multiplot\n";
  return gp.str();
}

int RunRequestsCommand(const RequestsCommand& command, const nlohmann::json& summary_head) {
  util::Timer timer;
  LN_CHECK_ARG(std::isfinite(command.tolerance) && command.tolerance >= 0 && command.tolerance <= 1)
      << "--tolerance: must be in [0, 1] (0.1 = 10 %), got " << command.tolerance;
  int without_window = 0;
  const RequestStudy study = SummarizeRequests(ReadRequestWindows(command.run, &without_window), command.tolerance);
  io::CreateOutputDirectory(command.output_dir);
  const Table table = RequestsTable(study);
  WriteTable(command.output_dir, "requests", table);
  WriteTable(command.output_dir, "request_pairs", RequestPairsTable(study));
  const FigureResult figure =
      WriteFigure(command.output_dir, "requests", RequestsFigureCommands(study, "request_pairs.csv"), 900, 900);
  if (without_window > 0) {
    LN_LOG(Warning) << command.run.string() << ": " << without_window
                    << " pair(s) matched without window selection are left out";
  }
  nlohmann::json summary = summary_head;
  summary["inputs"] = {{"run", command.run.string()}};
  summary["options"] = {{"tolerance", command.tolerance}};
  summary["counts"] = {{"pairs", study.windows.size()},
                       {"without_window", without_window},
                       {"within", study.within_count},
                       {"steady_from", study.steady_from}};
  summary["table"] = table.ToJson();
  summary["figures"] = nlohmann::json::array({FigureSummary(figure, "request_pairs.csv")});
  summary["timings_s"] = {{"total", timer.ElapsedSeconds()}};
  io::WriteJsonAtomic(command.output_dir / "summary.json", summary);
  LN_LOG(Info) << "evaluate requests: " << study.windows.size() << " pairs, " << study.within_count << " within "
               << 100 * command.tolerance << " %; " << (command.output_dir / "requests.md").string();
  return kExitOk;
}

}  // namespace lunarnav::evaluation
