#include "evaluation/timing_study.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <tuple>

#include "calib/stereo_rig_io.h"
#include "evaluation/figure.h"
#include "io/atomic_file.h"
#include "io/image_io.h"
#include "io/json_io.h"
#include "io/stereo_pairs.h"
#include "stereo/ncc_matcher.h"
#include "util/check.h"
#include "util/errors.h"
#include "util/log.h"
#include "util/parse.h"
#include "util/progress.h"
#include "util/timer.h"

namespace lunarnav::evaluation {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double WorkShare(const calib::ImageWindow& w, int height_px, int full_disparities) {
  const double full = static_cast<double>(height_px) * full_disparities;
  return full > 0 ? static_cast<double>(w.Rows()) * w.Disparities() / full : kNaN;
}

stereo::NccOptions MatcherFor(const stereo::NccOptions& matcher, const calib::ImageWindow& w) {
  stereo::NccOptions m = matcher;
  m.min_row = w.min_row;
  m.max_row = w.max_row;
  m.min_disparity_px = w.min_disparity_px;
  m.max_disparity_px = w.max_disparity_px;
  return m;
}

}  // namespace

void TimingStudyOptions::Validate() const {
  matcher.Validate();
  window_selection.Validate();
  LN_CHECK_ARG(std::isfinite(y_min_m)) << "y-min: must be a finite distance in metres";
  LN_CHECK_ARG(!delta_y_m.empty()) << "delta-y: at least one interval width";
  for (double d : delta_y_m) {
    LN_CHECK_ARG(std::isfinite(d) && d >= 0) << "delta-y: widths must be >= 0 m, got " << d;
  }
  LN_CHECK_ARG(repeat >= 1) << "repeat: must be >= 1, got " << repeat;
  calib::RegionOfInterest region{y_min_m, y_min_m, z_min_m, z_max_m};
  region.Validate();
}

nlohmann::json TimingStudyOptions::ToJson() const {
  return {{"y_min_m", y_min_m},
          {"delta_y_m", delta_y_m},
          {"z_m", {z_min_m, z_max_m}},
          {"disparity_margin_px", window_selection.disparity_margin_px},
          {"repeat", repeat},
          {"matcher", matcher.ToJson()}};
}

std::vector<double> NormaliseToLargest(const std::vector<double>& values) {
  double largest = -std::numeric_limits<double>::infinity();
  for (double v : values) {
    if (std::isfinite(v)) largest = std::max(largest, v);
  }
  std::vector<double> out(values.size(), kNaN);
  if (!(largest > 0)) return out;
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (std::isfinite(values[i])) out[i] = values[i] / largest;
  }
  return out;
}

double Median(std::vector<double> values) {
  if (values.empty()) return kNaN;
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 == 1 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

double Quantile(std::vector<double> values, double p) {
  if (values.empty()) return kNaN;
  std::sort(values.begin(), values.end());
  const double h = (static_cast<double>(values.size()) - 1) * std::clamp(p, 0.0, 1.0);
  const std::size_t below = static_cast<std::size_t>(std::floor(h));
  if (below + 1 >= values.size()) return values.back();
  return values[below] + (h - static_cast<double>(below)) * (values[below + 1] - values[below]);
}

TimingStudy PlanTimingStudy(const calib::StereoRig& rig, const TimingStudyOptions& options) {
  options.Validate();
  LN_CHECK_ARG(rig.rectified.has_value())
      << "rig: no rectified geometry; window selection needs the rectified rig (the rig.json that rectify writes)";
  TimingStudy study;
  study.options = options;
  study.width_px = rig.rectified->width_px;
  study.height_px = rig.rectified->height_px;
  const int full_disparities = options.matcher.max_disparity_px - options.matcher.min_disparity_px + 1;
  for (double dy : options.delta_y_m) {
    const calib::RegionOfInterest region{options.y_min_m, options.y_min_m + dy, options.z_min_m, options.z_max_m};
    TimingPoint p;
    p.delta_y_m = dy;
    p.window = calib::SelectWindow(rig, region, options.matcher.reference, options.window_selection);
    LN_CHECK_ARG(p.window.visible) << "delta-y " << dy << ": no point with Y in [" << region.y_min_m << ", "
                                   << region.y_max_m << "] m and Z in [" << region.z_min_m << ", "
                                   << region.z_max_m << "] m is seen by the "
                                   << calib::ToString(options.matcher.reference) << " camera";
    p.work_share = WorkShare(p.window, study.height_px, full_disparities);
    study.points.push_back(std::move(p));
  }
  calib::ImageWindow& w = study.full.window;
  w.visible = true;
  w.min_row = 0;
  w.max_row = study.height_px - 1;
  w.min_disparity_px = options.matcher.min_disparity_px;
  w.max_disparity_px = options.matcher.max_disparity_px;
  w.row_extent[0] = w.min_row;
  w.row_extent[1] = w.max_row;
  w.disparity_extent_px[0] = w.min_disparity_px;
  w.disparity_extent_px[1] = w.max_disparity_px;
  w.image_width_px = study.width_px;
  w.image_height_px = study.height_px;
  study.full.work_share = 1.0;
  return study;
}

void NormaliseTimingStudy(TimingStudy* study) {
  std::vector<double> seconds, work;
  for (const TimingPoint& p : study->points) {
    seconds.push_back(p.seconds);
    work.push_back(p.work_share);
  }
  const std::vector<double> time_n = NormaliseToLargest(seconds), work_n = NormaliseToLargest(work);
  double largest_seconds = kNaN, largest_work = kNaN;
  for (std::size_t i = 0; i < study->points.size(); ++i) {
    TimingPoint& p = study->points[i];
    p.time_normalised = time_n[i];
    p.work_normalised = work_n[i];
    p.time_share = study->full.seconds > 0 ? p.seconds / study->full.seconds : kNaN;
    if (time_n[i] == 1.0) largest_seconds = p.seconds;
    if (work_n[i] == 1.0) largest_work = p.work_share;
  }
  TimingPoint& f = study->full;
  f.time_normalised = largest_seconds > 0 ? f.seconds / largest_seconds : kNaN;
  f.work_normalised = largest_work > 0 ? f.work_share / largest_work : kNaN;
  f.time_share = f.seconds > 0 ? 1.0 : kNaN;
}

TimingStudy RunTimingStudy(const calib::StereoRig& rig, const std::vector<std::pair<cv::Mat, cv::Mat>>& pairs,
                           const TimingStudyOptions& options, const std::function<void()>& progress) {
  TimingStudy study = PlanTimingStudy(rig, options);
  LN_CHECK_INPUT(!pairs.empty()) << "timing: no image pairs";
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const cv::Mat& left = pairs[i].first;
    LN_CHECK_INPUT(left.cols == study.width_px && left.rows == study.height_px)
        << "pair " << i << ": size " << left.cols << "x" << left.rows << " differs from the rig's rectified size "
        << study.width_px << "x" << study.height_px;
  }
  study.pairs = static_cast<int>(pairs.size());
  std::vector<TimingPoint*> all;
  for (TimingPoint& p : study.points) all.push_back(&p);
  all.push_back(&study.full);

  stereo::NccResult result;  // maps reused, as stereo-batch does
  // Warm-up (untimed): allocates the maps and brings code and images into the caches.
  stereo::MatchStereoPair(MatcherFor(options.matcher, study.full.window), pairs[0].first, pairs[0].second, &result);
  for (int round = 0; round < options.repeat; ++round) {
    for (TimingPoint* p : all) {
      const stereo::NccOptions matcher = MatcherFor(options.matcher, p->window);
      double total = 0;
      long long evaluated = 0;
      for (const auto& [left, right] : pairs) {
        util::Timer timer;
        stereo::MatchStereoPair(matcher, left, right, &result);
        total += timer.ElapsedSeconds();
        evaluated += result.summary.evaluated_pixels;
      }
      p->repeat_seconds.push_back(total / static_cast<double>(pairs.size()));
      p->evaluated_pixels = evaluated;
      if (progress) progress();
    }
  }
  for (TimingPoint* p : all) {
    p->seconds = Median(p->repeat_seconds);
    p->seconds_q1 = Quantile(p->repeat_seconds, 0.25);
    p->seconds_q3 = Quantile(p->repeat_seconds, 0.75);
  }
  NormaliseTimingStudy(&study);
  return study;
}

Table TimingTable(const TimingStudy& study) {
  Table t;
  t.title = "Stereo time against the width of the distance interval, Y_min = " +
            Cell::Number(study.options.y_min_m).Format(1) + " m (Figure 2)";
  t.columns = {{"delta_y", "m", "ΔY (m)", 2},
               {"y_max", "m", "Y_max (m)", 2},
               {"row_min", "px", "y_min", 0},
               {"row_max", "px", "y_max", 0},
               {"rows", "", "rows", 0},
               {"d_min", "px", "d_min", 0},
               {"d_max", "px", "d_max", 0},
               {"disparities", "", "disparities", 0},
               {"work_share", "pct", "rows×disparities (% of image)", 1},
               {"time", "ms", "time per pair (ms)", 2},
               {"time_normalised", "", "time / largest", 3},
               {"work_normalised", "", "work / largest", 3},
               {"time_share", "pct", "time (% of image)", 1},
               {"time_q1", "ms", "time, 1st quartile (ms)", 2},
               {"time_q3", "ms", "time, 3rd quartile (ms)", 2}};
  auto add = [&](const TimingPoint& p) {
    const std::string whole = "whole image, no window selection";
    const Cell dy = p.delta_y_m ? Cell::Number(*p.delta_y_m) : Cell::NotAvailable(whole);
    const Cell ymax = p.delta_y_m ? Cell::Number(study.options.y_min_m + *p.delta_y_m) : Cell::NotAvailable(whole);
    const calib::ImageWindow& w = p.window;
    t.AddRow({dy, ymax, Cell::Number(w.min_row), Cell::Number(w.max_row), Cell::Number(w.Rows()),
              Cell::Number(w.min_disparity_px), Cell::Number(w.max_disparity_px), Cell::Number(w.Disparities()),
              Cell::NumberOr(100 * p.work_share, "no work"), Cell::NumberOr(1e3 * p.seconds, "not timed"),
              Cell::NumberOr(p.time_normalised, "not timed"), Cell::NumberOr(p.work_normalised, "no work"),
              Cell::NumberOr(100 * p.time_share, "not timed"),
              Cell::NumberOr(p.repeat_seconds.empty() ? kNaN : 1e3 * p.seconds_q1, "not timed"),
              Cell::NumberOr(p.repeat_seconds.empty() ? kNaN : 1e3 * p.seconds_q3, "not timed")});
  };
  for (const TimingPoint& p : study.points) add(p);
  add(study.full);
  std::ostringstream n1, n2;
  n1 << "Times are medians of " << study.options.repeat << " runs of the mean matching time over " << study.pairs
     << " pair(s) of " << study.width_px << "x" << study.height_px
     << " px, with their quartiles; they depend on the machine and its load: two widths' times differ beyond that "
        "noise only when their interquartile ranges do not overlap.";
  n2 << "Windows by window selection (sec. 3.3) for Z in [" << study.options.z_min_m << ", " << study.options.z_max_m
     << "] m; the last row searches every row and the disparities " << study.options.matcher.min_disparity_px << ":"
     << study.options.matcher.max_disparity_px
     << "; 'work' is rows × disparities, the cost window selection predicts.";
  t.notes = {n1.str(), n2.str()};
  return t;
}

std::string TimingCurveCsv(const TimingStudy& study) {
  std::ostringstream s;
  s << "delta_y_m,y_max_m,time_normalised,work_normalised,time_ms,rows,disparities,time_q1_normalised,"
       "time_q3_normalised\n";
  s.precision(6);
  auto num = [](double v) {
    std::ostringstream o;
    o.precision(6);
    if (std::isfinite(v)) o << v; else o << "nan";
    return o.str();
  };
  for (const TimingPoint& p : study.points) {
    s << num(*p.delta_y_m) << "," << num(study.options.y_min_m + *p.delta_y_m) << "," << num(p.time_normalised) << ","
      << num(p.work_normalised) << "," << num(1e3 * p.seconds) << "," << p.window.Rows() << ","
      << p.window.Disparities() << "," << num(p.time_normalised * p.seconds_q1 / p.seconds) << ","
      << num(p.time_normalised * p.seconds_q3 / p.seconds) << "\n";
  }
  return s.str();
}

std::string TimingFigureCommands(const TimingStudy& study, const std::string& curve_csv) {
  std::ostringstream gp;
  gp << "set title \"Stereo time against the width of the distance interval (Y_{min} = " << study.options.y_min_m
     << " m), normalised to the largest\"\n"
     << "set xlabel \"{/Symbol D}Y = Y_{max} - Y_{min} (m)\"\nset ylabel \"normalised\"\nset grid\n"
     << "set key left top box opaque\nset yrange [0:*]\nset offsets graph 0.02, 0.02, 0, 0\n"
     << "plot " << GnuplotString(curve_csv)
     << " using 1:3 skip 1 with linespoints pt 7 ps 1.2 lw 2 title \"measured time (median)\", \\\n     "
     << GnuplotString(curve_csv)
     << " using 1:3:8:9 skip 1 with yerrorbars pt 7 ps 0.1 lc 1 title \"interquartile range of the runs\", \\\n     "
     << GnuplotString(curve_csv)
     << " using 1:4 skip 1 with linespoints pt 4 ps 1.0 dt 2 title \"predicted: rows x disparities\"\n";
  return gp.str();
}

int RunTimingCommand(const TimingCommand& command, const nlohmann::json& summary_head) {
  util::Timer timer;
  TimingStudyOptions options = command.options;
  std::tie(options.matcher.half_window_x_px, options.matcher.half_window_y_px) =
      util::ParseIntPair(command.window, 'x', "--window");
  std::tie(options.matcher.step_x_px, options.matcher.step_y_px) = util::ParseIntPair(command.step, 'x', "--step");
  std::tie(options.matcher.min_disparity_px, options.matcher.max_disparity_px) =
      util::ParseIntPair(command.disparity, ':', "--disparity");
  std::tie(options.z_min_m, options.z_max_m) = util::ParseDoublePair(command.z_range, ':', "--z-range");
  options.matcher.reference = stereo::ReferenceImageFromString(command.reference);
  LN_CHECK_ARG(command.max_pairs >= 0) << "--max-pairs: must be >= 0 (0 = all)";
  const calib::StereoRig rig = calib::ReadStereoRig(command.rig);
  const TimingStudy plan = PlanTimingStudy(rig, options);  // bad options: exit 2 before reading pairs

  std::vector<io::PairFiles> listing = io::ListStereoPairs(command.pairs);
  LN_CHECK_INPUT(!listing.empty()) << command.pairs.string() << ": no image pairs in left/ and right/";
  if (command.max_pairs > 0 && listing.size() > static_cast<std::size_t>(command.max_pairs)) {
    listing.resize(command.max_pairs);
  }
  std::vector<std::pair<cv::Mat, cv::Mat>> images;
  nlohmann::json stems = nlohmann::json::array();
  for (const io::PairFiles& pair : listing) {
    LN_CHECK_INPUT(pair.problem.empty()) << "pair " << pair.stem << ": " << pair.problem;
    images.emplace_back(io::ReadGreyImage(pair.left), io::ReadGreyImage(pair.right));
    const cv::Mat& left = images.back().first;
    LN_CHECK_INPUT(left.size() == images.back().second.size() && left.type() == images.back().second.type())
        << pair.right.string() << ": size or bit depth differs from the left image's";
    LN_CHECK_INPUT(left.cols == plan.width_px && left.rows == plan.height_px)
        << pair.left.string() << ": size " << left.cols << "x" << left.rows << " differs from the rig's rectified size "
        << plan.width_px << "x" << plan.height_px << " (" << command.rig.string() << ")";
    stems.push_back(pair.stem);
  }
  io::CreateOutputDirectory(command.output_dir);
  util::ProgressBar progress(options.repeat * (options.delta_y_m.size() + 1), "evaluate timing", command.progress);
  const TimingStudy study = RunTimingStudy(rig, images, options, [&] { progress.Increment(); });

  const Table table = TimingTable(study);
  WriteTable(command.output_dir, "timing", table);
  io::WriteFileAtomic(command.output_dir / "timing_curve.csv", TimingCurveCsv(study));
  const FigureResult figure =
      WriteFigure(command.output_dir, "timing", TimingFigureCommands(study, "timing_curve.csv"));
  nlohmann::json summary = summary_head;
  summary["inputs"] = {{"pairs", command.pairs.string()}, {"rig", command.rig.string()}, {"stems", stems}};
  summary["rig_notes"] = rig.notes;  // what reading the rig changed (printed precision)
  summary["options"] = options.ToJson();
  summary["options"]["max_pairs"] = command.max_pairs;
  summary["counts"] = {{"pairs", study.pairs}, {"windows", study.points.size() + 1}, {"repeat", options.repeat}};
  summary["kernel"] = stereo::ActiveKernelName();
  nlohmann::json windows = nlohmann::json::array();
  auto add_window = [&](const TimingPoint& p) {
    windows.push_back({{"delta_y_m", p.delta_y_m ? nlohmann::json(*p.delta_y_m) : nlohmann::json(nullptr)},
                       {"window", p.window.ToJson()},
                       {"repeat_s", p.repeat_seconds},
                       {"evaluated_pixels", p.evaluated_pixels}});
  };
  for (const TimingPoint& p : study.points) add_window(p);
  add_window(study.full);
  summary["windows"] = windows;
  summary["table"] = table.ToJson();
  summary["figures"] = nlohmann::json::array({FigureSummary(figure, "timing_curve.csv")});
  summary["timings_s"] = {{"total", timer.ElapsedSeconds()}};
  io::WriteJsonAtomic(command.output_dir / "summary.json", summary);
  LN_LOG(Info) << "evaluate timing: " << study.points.size() << " windows x " << study.pairs << " pairs x "
               << options.repeat << " runs; " << (command.output_dir / "timing.md").string();
  return kExitOk;
}

}  // namespace lunarnav::evaluation
