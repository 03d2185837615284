#include "evaluation/correlation_study.h"

#include <cmath>
#include <sstream>

#include "evaluation/figure.h"
#include "io/atomic_file.h"
#include "io/image_io.h"
#include "io/json_io.h"
#include "util/check.h"
#include "util/errors.h"
#include "util/log.h"
#include "util/timer.h"

namespace lunarnav::evaluation {

void CorrelationStudyOptions::Validate() const {
  matcher.Validate();
  LN_CHECK_ARG(!steps_x.empty() && !steps_y.empty()) << "correlation: at least one step in x and in y";
  for (int s : steps_x) LN_CHECK_ARG(s >= 1) << "correlation: column steps must be >= 1";
  for (int s : steps_y) LN_CHECK_ARG(s >= 1) << "correlation: row steps must be >= 1";
  LN_CHECK_ARG(zoom_px >= 1) << "correlation: zoom must be >= 1 px";
}

CorrelationStudy RunCorrelationStudy(const cv::Mat& left, const cv::Mat& right, const CorrelationStudyOptions& options) {
  options.Validate();
  CorrelationStudy study;
  study.options = options;
  for (int dx : options.steps_x) {
    for (int dy : options.steps_y) {
      stereo::NccOptions m = options.matcher;
      m.step_x_px = dx;
      m.step_y_px = dy;
      CorrelationStudy::Entry e;
      e.step_x = dx;
      e.step_y = dy;
      e.partial = stereo::ComputeCorrelationCurve(left, right, m, options.x, options.y);
      e.conventional = stereo::ComputeConventionalCurve(left, right, m, options.x, options.y);
      study.entries.push_back(std::move(e));
    }
  }
  return study;
}

namespace {
std::string CurveName(const CorrelationStudy::Entry& e) {
  return "C_dx" + std::to_string(e.step_x) + "_dy" + std::to_string(e.step_y);
}
}  // namespace

std::string CorrelationCurvesCsv(const CorrelationStudy& study) {
  std::ostringstream s;
  s << "d_px";
  for (const auto& e : study.entries) s << "," << CurveName(e);
  s << "\n";
  const stereo::NccOptions& m = study.options.matcher;
  s.precision(6);
  for (int d = m.min_disparity_px; d <= m.max_disparity_px; ++d) {
    s << d;
    for (const auto& e : study.entries) {
      const double c = e.partial.values[static_cast<std::size_t>(d - e.partial.min_disparity_px)];
      s << ",";
      if (std::isfinite(c)) {
        s << c;
      } else {
        s << "nan";
      }
    }
    s << "\n";
  }
  return s.str();
}

Table CorrelationPeaksTable(const CorrelationStudy& study) {
  Table table;
  table.title = "Correlation peak at pixel (" + std::to_string(study.options.x) + ", " +
                std::to_string(study.options.y) + ") for each subsampling (Figure 5)";
  table.columns = {{"dx", "px", "dx", 0},
                   {"dy", "px", "dy", 0},
                   {"best_disparity", "px", "best d (px)", 0},
                   {"subpixel_disparity", "px", "sub-pixel d (px)", 3},
                   {"best_correlation", "", "C at best d", 4},
                   {"conventional_disparity", "px", "conventional: best d (px)", 0},
                   {"conventional_subpixel", "px", "conventional: sub-pixel d (px)", 3},
                   {"conventional_correlation", "", "conventional: C", 4}};
  const char* none = "no defined correlation";
  for (const auto& e : study.entries) {
    const auto best = [&](const stereo::CorrelationCurve& c) {
      return c.best_disparity_px >= 0 ? Cell::Number(c.best_disparity_px) : Cell::NotAvailable(none);
    };
    table.AddRow({Cell::Number(e.step_x), Cell::Number(e.step_y), best(e.partial),
                  Cell::NumberOr(e.partial.subpixel_disparity_px, "peak at a range end"),
                  Cell::NumberOr(e.partial.best_correlation, none), best(e.conventional),
                  Cell::NumberOr(e.conventional.subpixel_disparity_px, "peak at a range end"),
                  Cell::NumberOr(e.conventional.best_correlation, none)});
  }
  const stereo::NccOptions& m = study.options.matcher;
  table.notes = {"Partial subsampling (sec. 3.4): the window's pixels on the (dx, dy) grid, every integer "
                 "disparity searched. Conventional: both images decimated by (dx, dy), disparities searched "
                 "in steps of dx. Window " +
                 std::to_string(2 * m.half_window_x_px + 1) + " x " + std::to_string(2 * m.half_window_y_px + 1) +
                 " px, disparities " + std::to_string(m.min_disparity_px) + " to " +
                 std::to_string(m.max_disparity_px) + ", " + stereo::ToString(m.reference) + " reference."};
  return table;
}

std::string CorrelationFigureCommands(const CorrelationStudy& study, const std::string& curves_csv) {
  // The magnified window is centred on the peak of the finest subsampling.
  int centre = study.entries.front().partial.best_disparity_px;
  if (centre < 0) centre = (study.options.matcher.min_disparity_px + study.options.matcher.max_disparity_px) / 2;
  const std::string data = GnuplotString(curves_csv);
  std::ostringstream gp;
  gp << "set multiplot layout 1,2 title \"Correlation curves at pixel (" << study.options.x << ", "
     << study.options.y << ") for partial subsampling (dx, dy)\"\n"
     << "set grid\nset xlabel \"disparity (px)\"\nset ylabel \"C\"\nset key top right box opaque\n";
  auto plot = [&](const std::string& title) {
    gp << "set title \"" << title << "\"\nplot ";
    for (std::size_t i = 0; i < study.entries.size(); ++i) {
      const auto& e = study.entries[i];
      gp << (i ? ", \\\n     " : "") << data << " using 1:" << i + 2 << " with linespoints pt 7 ps 0.4 title \"("
         << e.step_x << ", " << e.step_y << ")\"";
    }
    gp << "\n";
  };
  plot("complete curve");
  gp << "set xrange [" << centre - study.options.zoom_px << ":" << centre + study.options.zoom_px << "]\n"
     << "set key off\n";
  plot("around the maximum");
  gp << "unset multiplot\n";
  return gp.str();
}

int RunCorrelationCommand(const CorrelationCommand& command, const nlohmann::json& summary_head) {
  util::Timer timer;
  CorrelationStudyOptions options = command.options;
  LN_CHECK_ARG(command.pixel.size() == 2) << "--pixel: expected X,Y";
  options.x = command.pixel[0];
  options.y = command.pixel[1];
  options.matcher.reference = stereo::ReferenceImageFromString(command.reference);
  options.Validate();
  const cv::Mat left = io::ReadGreyImage(command.left);
  const cv::Mat right = io::ReadGreyImage(command.right);
  LN_CHECK_INPUT(left.size() == right.size() && left.type() == right.type())
      << command.left.string() << ", " << command.right.string() << ": the images differ in size or bit depth";
  LN_CHECK_INPUT(options.x >= 0 && options.x < left.cols && options.y >= 0 && options.y < left.rows)
      << "--pixel " << options.x << "," << options.y << ": outside the " << left.cols << " x " << left.rows << " image";
  const CorrelationStudy study = RunCorrelationStudy(left, right, options);
  io::CreateOutputDirectory(command.output_dir);
  io::WriteFileAtomic(command.output_dir / "correlation_curves.csv", CorrelationCurvesCsv(study));
  const Table table = CorrelationPeaksTable(study);
  WriteTable(command.output_dir, "correlation", table);
  const FigureResult figure = WriteFigure(command.output_dir, "correlation",
                                          CorrelationFigureCommands(study, "correlation_curves.csv"), 1200, 550);
  nlohmann::json summary = summary_head;
  summary["inputs"] = {{"left", command.left.string()}, {"right", command.right.string()}};
  summary["options"] = {{"pixel", {options.x, options.y}},
                        {"steps_x", options.steps_x},
                        {"steps_y", options.steps_y},
                        {"zoom_px", options.zoom_px},
                        {"matcher", options.matcher.ToJson()}};
  summary["counts"] = {{"curves", study.entries.size()},
                       {"disparities", options.matcher.max_disparity_px - options.matcher.min_disparity_px + 1}};
  summary["table"] = table.ToJson();
  summary["figures"] = nlohmann::json::array({FigureSummary(figure, "correlation_curves.csv")});
  summary["timings_s"] = {{"total", timer.ElapsedSeconds()}};
  io::WriteJsonAtomic(command.output_dir / "summary.json", summary);
  LN_LOG(Info) << "evaluate correlation: " << study.entries.size() << " curves; "
               << (command.output_dir / "correlation.md").string();
  return kExitOk;
}

}  // namespace lunarnav::evaluation
