#include "evaluation/boxes_eval.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "calib/stereo_rig_io.h"
#include "calib/triangulation.h"
#include "evaluation/figure.h"
#include "io/atomic_file.h"
#include "io/float_array_io.h"
#include "io/json_io.h"
#include "util/check.h"
#include "util/errors.h"
#include "util/log.h"
#include "util/timer.h"

namespace lunarnav::evaluation {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

double Number(const json& object, const char* key, const std::string& where) {
  const auto it = object.find(key);
  LN_CHECK_INPUT(it != object.end() && it->is_number() && std::isfinite(it->get<double>()))
      << where << ": \"" << key << "\" must be a finite number";
  return it->get<double>();
}

std::vector<BoxFace> ReadFaces(const json& list, const std::string& where) {
  LN_CHECK_INPUT(list.is_array()) << where << ": must be an array";
  std::vector<BoxFace> faces;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const json& b = list[i];
    const std::string at = where + "[" + std::to_string(i) + "]";
    LN_CHECK_INPUT(b.is_object()) << at << ": must be an object";
    BoxFace f;
    f.index = b.contains("index") && b["index"].is_number_integer() ? b["index"].get<int>() : static_cast<int>(i);
    f.front_y_m = Number(b, "front_y_m", at);
    f.x_min_m = Number(b, "x_min_m", at);
    f.x_max_m = Number(b, "x_max_m", at);
    f.z_min_m = Number(b, "z_min_m", at);
    f.z_max_m = Number(b, "z_max_m", at);
    LN_CHECK_INPUT(f.front_y_m > 0) << at << ": front_y_m must be > 0 (in front of the vehicle)";
    LN_CHECK_INPUT(f.x_min_m < f.x_max_m && f.z_min_m < f.z_max_m) << at << ": empty X or Z extent";
    faces.push_back(f);
  }
  return faces;
}

}  // namespace

const std::vector<BoxFace>& BoxList::For(const std::string& stem) const {
  const auto it = frames.find(stem);
  return it != frames.end() ? it->second : boxes;
}

BoxList ReadBoxList(const fs::path& path) {
  const json doc = io::ReadJson(path);
  const std::string file = path.string();
  LN_CHECK_INPUT(doc.is_object() && doc.value("format", "") == "lunarnav.boxes/1")
      << file << ": \"format\" must be \"lunarnav.boxes/1\"";
  LN_CHECK_INPUT(doc.contains("boxes")) << file << ": missing \"boxes\"";
  BoxList list;
  list.boxes = ReadFaces(doc["boxes"], file + ": boxes");
  if (const auto frames = doc.find("frames"); frames != doc.end()) {
    LN_CHECK_INPUT(frames->is_array()) << file << ": \"frames\" must be an array";
    for (std::size_t i = 0; i < frames->size(); ++i) {
      const json& f = (*frames)[i];
      const std::string at = file + ": frames[" + std::to_string(i) + "]";
      LN_CHECK_INPUT(f.is_object() && f.contains("stem") && f["stem"].is_string() && f.contains("boxes"))
          << at << ": needs \"stem\" and \"boxes\"";
      list.frames[f["stem"].get<std::string>()] = ReadFaces(f["boxes"], at + ".boxes");
    }
  }
  LN_CHECK_INPUT(!list.boxes.empty() || !list.frames.empty()) << file << ": no boxes";
  return list;
}

void BoxesEvalOptions::Validate() const {
  LN_CHECK_ARG(edge_margin_m >= 0) << "box edge margin: must be >= 0 m";
  LN_CHECK_ARG(y_gate_fraction > 0 && y_gate_fraction < 1) << "box Y gate: must be in (0, 1)";
}

void FaceErrors::Add(const FaceErrors& other) {
  points += other.points;
  sum_error += other.sum_error;
  sum_sq_error += other.sum_sq_error;
}

double FaceErrors::Rms() const { return points > 0 ? std::sqrt(sum_sq_error / points) : NAN; }
double FaceErrors::Mean() const { return points > 0 ? sum_error / points : NAN; }

std::vector<FaceErrors> EvaluateBoxFaces(const cv::Mat& xyz, const std::vector<BoxFace>& faces,
                                         const BoxesEvalOptions& options) {
  options.Validate();
  LN_CHECK_ARG(xyz.type() == CV_32FC3) << "box evaluation: XYZ must be 3-channel float";
  std::vector<FaceErrors> errors(faces.size());
  for (int r = 0; r < xyz.rows; ++r) {
    const cv::Vec3f* row = xyz.ptr<cv::Vec3f>(r);
    for (int c = 0; c < xyz.cols; ++c) {
      const cv::Vec3f& p = row[c];
      if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) continue;
      for (std::size_t k = 0; k < faces.size(); ++k) {
        const BoxFace& f = faces[k];
        const double m = options.edge_margin_m;
        if (p[0] < f.x_min_m + m || p[0] > f.x_max_m - m || p[2] < f.z_min_m + m || p[2] > f.z_max_m - m) continue;
        const double e = p[1] - f.front_y_m;
        if (std::abs(e) > options.y_gate_fraction * f.front_y_m) continue;
        ++errors[k].points;
        errors[k].sum_error += e;
        errors[k].sum_sq_error += e * e;
      }
    }
  }
  return errors;
}

Table BoxesTable(const std::vector<BoxRunResult>& runs, const std::map<long, double>& predicted_m) {
  Table table;
  table.title = "Error in measured distance E_Y against distance, per subsampling (Figure 4)";
  table.columns = {{"y", "m", "Y (m)", 2}};
  if (!predicted_m.empty()) table.columns.push_back({"predicted_1px", "m", "predicted, 1 px (m)", 3});
  for (const BoxRunResult& run : runs) {
    table.columns.push_back({"e_y_" + run.name, "m", "E_Y " + run.name + " (m)", 3});
    table.columns.push_back({"bias_" + run.name, "m", "bias " + run.name + " (m)", 3});
    table.columns.push_back({"points_" + run.name, "", "points " + run.name, 0});
  }
  std::map<long, bool> distances;
  for (const BoxRunResult& run : runs) {
    for (const auto& [cm, _] : run.by_distance_cm) distances[cm] = true;
  }
  for (const auto& [cm, _] : distances) {
    std::vector<Cell> row = {Cell::Number(cm / 100.0)};
    if (!predicted_m.empty()) {
      const auto it = predicted_m.find(cm);
      row.push_back(it != predicted_m.end() ? Cell::Number(it->second) : Cell::NotAvailable("no rig"));
    }
    for (const BoxRunResult& run : runs) {
      const auto it = run.by_distance_cm.find(cm);
      const FaceErrors e = it != run.by_distance_cm.end() ? it->second : FaceErrors{};
      row.push_back(Cell::NumberOr(e.Rms(), "no points on the face"));
      row.push_back(Cell::NumberOr(e.Mean(), "no points on the face"));
      row.push_back(Cell::Number(static_cast<double>(e.points)));
    }
    table.AddRow(std::move(row));
  }
  table.notes = {"E_Y: RMS of (measured Y - true Y) over the points on each box's front face (inside its X and Z "
                 "extents less the edge margin, Y within the gate of the true Y), pooled over frames. Bias: the "
                 "mean of the same differences."};
  return table;
}

namespace {

// One stereo-batch run's XYZ maps scored against the box list.
BoxRunResult ScoreBoxRun(const fs::path& run, const BoxList& boxes, const BoxesEvalOptions& options, json* run_json,
                         int* failed) {
  const json summary = io::ReadJson(run / "summary.json");
  LN_CHECK_INPUT(summary.value("tool", "") == "stereo-batch")
      << (run / "summary.json").string() << ": not a stereo-batch summary";
  BoxRunResult result;
  const json& step = summary["options"]["step_px"];
  LN_CHECK_INPUT(step.is_array() && step.size() == 2) << (run / "summary.json").string() << ": no options.step_px";
  result.step_x = step[0].get<int>();
  result.step_y = step[1].get<int>();
  result.name = "dx" + std::to_string(result.step_x) + "_dy" + std::to_string(result.step_y);
  const fs::path xyz_dir = run / "xyz";
  LN_CHECK_INPUT(fs::is_directory(xyz_dir)) << xyz_dir.string() << ": no XYZ maps (run stereo-batch with --rig)";
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(xyz_dir)) {
    if (entry.path().extension() == ".exr") files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  LN_CHECK_INPUT(!files.empty()) << xyz_dir.string() << ": no .exr files";
  long maps = 0;
  for (const fs::path& file : files) {
    const std::string stem = file.stem().string();
    try {
      const io::ExrImage xyz = io::ReadExr(file);
      LN_CHECK_INPUT(xyz.pixels.type() == CV_32FC3) << file.string() << ": expected 3 channels (X, Y, Z)";
      const auto& faces = boxes.For(stem);
      const auto errors = EvaluateBoxFaces(xyz.pixels, faces, options);
      for (std::size_t k = 0; k < faces.size(); ++k) {
        result.by_distance_cm[std::lround(faces[k].front_y_m * 100)].Add(errors[k]);
      }
      ++maps;
    } catch (const InputError& e) {
      ++*failed;
      LN_LOG(Error) << "pair " << stem << ": " << e.what();
    }
  }
  *run_json = {{"dir", run.string()}, {"name", result.name}, {"maps", maps}, {"step_px", {result.step_x, result.step_y}}};
  return result;
}

// Figure 4: E_Y against Y per subsampling, with the predicted 1-pixel curve.
FigureResult BoxesFigure(const fs::path& dir, const std::vector<BoxRunResult>& runs, bool predicted) {
  std::ostringstream gp;
  gp << "set title \"Error in measured distance against distance, per subsampling (Figure 4)\"\n"
     << "set xlabel \"Y (m)\"\nset ylabel \"E_Y (m)\"\nset grid\nset key top left\n"
     << "set offsets graph 0.03, 0.03, 0.05, 0\nset yrange [0:*]\nplot ";
  int column = 2;
  bool first = true;
  if (predicted) {
    gp << "\"boxes.csv\" using 1:2 with lines lw 2 dt 2 lc rgb \"black\" title \"predicted, 1 px\"";
    first = false;
    ++column;
  }
  for (const auto& run : runs) {
    gp << (first ? "" : ", \\\n     ") << "\"boxes.csv\" using 1:" << column << " with linespoints pt 7 title \"("
       << run.step_x << ", " << run.step_y << ")\"";
    first = false;
    column += 3;  // E_Y, bias, points
  }
  gp << "\n";
  return WriteFigure(dir, "boxes", gp.str());
}

}  // namespace

int RunBoxesCommand(const BoxesCommand& command, const json& summary_head) {
  util::Timer timer;
  command.options.Validate();
  LN_CHECK_ARG(command.sigma_d_px > 0) << "--sigma-d: must be > 0";
  const BoxList boxes = ReadBoxList(command.boxes);
  io::CreateOutputDirectory(command.output_dir);
  std::vector<BoxRunResult> runs;
  json runs_json = json::array();
  int failed = 0;
  for (const fs::path& run : command.runs) {
    json run_json;
    runs.push_back(ScoreBoxRun(run, boxes, command.options, &run_json, &failed));
    runs_json.push_back(run_json);
  }
  // The predicted E_Y of a one-pixel disparity error at the centre of each face.
  std::map<long, double> predicted;
  std::vector<std::string> rig_notes;
  if (!command.rig.empty()) {
    const calib::StereoRig rig = calib::ReadStereoRig(command.rig);
    rig_notes = rig.notes;
    LN_CHECK_ARG(rig.rectified.has_value()) << command.rig.string() << ": not a rectified rig";
    std::vector<BoxFace> faces = boxes.boxes;
    for (const auto& [stem, list] : boxes.frames) faces.insert(faces.end(), list.begin(), list.end());
    for (const auto& f : faces) {
      const Eigen::Vector3d centre(0.5 * (f.x_min_m + f.x_max_m), f.front_y_m, 0.5 * (f.z_min_m + f.z_max_m));
      predicted[std::lround(f.front_y_m * 100)] =
          calib::PredictPointSigma(rig, centre, calib::ReferenceImage::kRight, command.sigma_d_px).y();
    }
  }
  const Table table = BoxesTable(runs, predicted);
  WriteTable(command.output_dir, "boxes", table);
  const FigureResult figure = BoxesFigure(command.output_dir, runs, !predicted.empty());
  json summary = summary_head;
  summary["inputs"] = {{"runs", runs_json}, {"boxes", command.boxes.string()}, {"rig", command.rig.string()}};
  summary["rig_notes"] = rig_notes;  // what reading the rig changed (printed precision)
  summary["options"] = {{"edge_margin_m", command.options.edge_margin_m},
                        {"y_gate_fraction", command.options.y_gate_fraction},
                        {"sigma_d_px", command.sigma_d_px}};
  summary["counts"] = {{"runs", runs.size()}, {"distances", table.rows.size()}, {"failed_maps", failed}};
  summary["table"] = table.ToJson();
  summary["figures"] = json::array({FigureSummary(figure, "boxes.csv")});
  summary["timings_s"] = {{"total", timer.ElapsedSeconds()}};
  io::WriteJsonAtomic(command.output_dir / "summary.json", summary);
  LN_LOG(Info) << "evaluate boxes: " << runs.size() << " runs, " << table.rows.size() << " distances; "
               << (command.output_dir / "boxes.md").string();
  return failed > 0 ? kExitBatchPartial : kExitOk;
}

}  // namespace lunarnav::evaluation
