#include "evaluation/boxes_eval.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "calib/stereo_rig_io.h"
#include "calib/triangulation.h"
#include "evaluation/figure.h"
#include "io/atomic_file.h"
#include "io/float_array_io.h"
#include "io/image_io.h"
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
  // A face is at most a few metres wide: a margin beyond 10 m leaves nothing to score (1e300
  // m wrote an empty table and a figure gnuplot could not draw, exit 0).
  LN_CHECK_ARG(std::isfinite(edge_margin_m) && edge_margin_m >= 0 && edge_margin_m <= 10)
      << "box edge margin: must be in [0, 10] m, got " << edge_margin_m;
  LN_CHECK_ARG(!y_gate_fraction || (*y_gate_fraction > 0 && *y_gate_fraction < 1)) << "box Y gate: must be in (0, 1)";
}

std::optional<double> BoxesEvalOptions::EffectiveYGate(bool with_truth) const {
  if (y_gate_fraction || with_truth) return y_gate_fraction;
  return kDefaultYGateFraction;
}

void FaceErrors::Add(const FaceErrors& other) {
  points += other.points;
  sum_error += other.sum_error;
  sum_sq_error += other.sum_sq_error;
  gated_out += other.gated_out;
}

double FaceErrors::Rms() const { return points > 0 ? std::sqrt(sum_sq_error / points) : NAN; }
double FaceErrors::Mean() const { return points > 0 ? sum_error / points : NAN; }
double FaceErrors::GatedOutShare() const {
  return points + gated_out > 0 ? static_cast<double>(gated_out) / static_cast<double>(points + gated_out) : NAN;
}

std::vector<FaceErrors> EvaluateBoxFaces(const cv::Mat& xyz, const std::vector<BoxFace>& faces,
                                         const BoxesEvalOptions& options, const BoxTruth* truth,
                                         const SampleGrid& grid) {
  options.Validate();
  LN_CHECK_ARG(xyz.type() == CV_32FC3) << "box evaluation: XYZ must be 3-channel float";
  LN_CHECK_ARG(grid.step_x >= 1 && grid.step_y >= 1 && grid.origin_x >= 0 && grid.origin_y >= 0)
      << "box evaluation: impossible sample grid";
  if (truth != nullptr) {
    LN_CHECK_ARG(truth->labels.type() == CV_16UC1 && truth->xyz.type() == CV_32FC3 &&
                 truth->labels.size() == truth->xyz.size())
        << "box evaluation: truth labels (16-bit) and XYZ (3-channel float) of one size expected";
    // The map is either the truth's full grid or its samples.
    const bool full = xyz.size() == truth->labels.size();
    const int samples_x = (truth->labels.cols - grid.origin_x + grid.step_x - 1) / grid.step_x;
    const int samples_y = (truth->labels.rows - grid.origin_y + grid.step_y - 1) / grid.step_y;
    LN_CHECK_INPUT(full || (xyz.cols == samples_x && xyz.rows == samples_y))
        << "the XYZ map's " << xyz.cols << "x" << xyz.rows << " pixels are neither the truth's " << truth->labels.cols
        << "x" << truth->labels.rows << " nor its " << samples_x << "x" << samples_y << " sample points";
  }
  const bool full = truth == nullptr || xyz.size() == truth->labels.size();
  const std::optional<double> gate = options.EffectiveYGate(truth != nullptr);
  const double m = options.edge_margin_m;
  constexpr double kOnFrontFaceM = 1e-3;  // true points this close to front_y_m are on the face
  auto inside = [m](const BoxFace& f, double x, double z) {
    return x >= f.x_min_m + m && x <= f.x_max_m - m && z >= f.z_min_m + m && z <= f.z_max_m - m;
  };
  std::vector<FaceErrors> errors(faces.size());
  for (int r = 0; r < xyz.rows; ++r) {
    const cv::Vec3f* row = xyz.ptr<cv::Vec3f>(r);
    const int truth_row = full ? r : grid.origin_y + r * grid.step_y;
    for (int c = 0; c < xyz.cols; ++c) {
      const cv::Vec3f& p = row[c];
      if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) continue;
      const int truth_col = full ? c : grid.origin_x + c * grid.step_x;
      for (std::size_t k = 0; k < faces.size(); ++k) {
        const BoxFace& f = faces[k];
        if (truth != nullptr) {
          if (truth->labels.at<std::uint16_t>(truth_row, truth_col) != 2 + f.index) continue;
          const cv::Vec3f& t = truth->xyz.at<cv::Vec3f>(truth_row, truth_col);
          if (std::abs(t[1] - f.front_y_m) > kOnFrontFaceM || !inside(f, t[0], t[2])) continue;
        } else if (!inside(f, p[0], p[2])) {
          continue;
        }
        const double e = p[1] - f.front_y_m;
        if (gate && std::abs(e) > *gate * f.front_y_m) {
          ++errors[k].gated_out;
          continue;
        }
        ++errors[k].points;
        errors[k].sum_error += e;
        errors[k].sum_sq_error += e * e;
      }
    }
  }
  return errors;
}

Table BoxesTable(const std::vector<BoxRunResult>& runs, const std::map<long, double>& predicted_m,
                 const BoxesEvalOptions& options, bool with_truth) {
  Table table;
  table.title = "Error in measured distance E_Y against distance, per subsampling (Figure 4)";
  table.columns = {{"y", "m", "Y (m)", 2}};
  if (!predicted_m.empty()) table.columns.push_back({"predicted_1px", "m", "predicted, 1 px (m)", 3});
  for (const BoxRunResult& run : runs) {
    table.columns.push_back({"e_y_" + run.name, "m", "E_Y " + run.name + " (m)", 3});
    table.columns.push_back({"bias_" + run.name, "m", "bias " + run.name + " (m)", 3});
    table.columns.push_back({"points_" + run.name, "", "points " + run.name, 0});
    table.columns.push_back({"dropped_" + run.name, "pct", "dropped " + run.name + " (%)", 1});
  }
  std::map<long, bool> distances;
  for (const BoxRunResult& run : runs) {
    for (const auto& [cm, _] : run.by_distance_cm) distances[cm] = true;
  }
  long dropped = 0, selected = 0;
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
      row.push_back(Cell::NumberOr(100 * e.GatedOutShare(), "no points on the face"));
      dropped += e.gated_out;
      selected += e.points + e.gated_out;
    }
    table.AddRow(std::move(row));
  }
  const std::string selection =
      with_truth ? "the pixels that see the box's front face by the simulator's truth (label and true point), "
                   "inside its X and Z extents less the edge margin"
                 : "the points whose measured X and Z lie inside the face's extents less the edge margin";
  std::ostringstream gate;
  const std::optional<double> y_gate = options.EffectiveYGate(with_truth);
  if (y_gate) {
    gate << "Y gate: points whose measured Y is more than " << Cell::Number(100 * *y_gate).Format(0)
         << " % of the true Y from it are dropped and not in E_Y; 'dropped' gives their share of the face's points ("
         << dropped << " of " << selected << " over the table).";
  } else {
    gate << "No Y gate: every point on the face counts in E_Y ('dropped' is 0).";
  }
  table.notes = {"E_Y: RMS of (measured Y - true Y) over the points on each box's front face (" + selection +
                     "), pooled over frames. Bias: the mean of the same differences. Edge margin " +
                     Cell::Number(100 * options.edge_margin_m).Format(0) + " cm.",
                 gate.str()};
  return table;
}

namespace {

// One stereo-batch run's XYZ maps scored against the box list.
// With a truth directory, each map's faces are selected by the frame's labels and true XYZ.
BoxRunResult ScoreBoxRun(const fs::path& run, const BoxList& boxes, const BoxesEvalOptions& options,
                         const fs::path& truth_dir, json* run_json, int* failed) {
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
      std::vector<FaceErrors> errors;
      if (truth_dir.empty()) {
        errors = EvaluateBoxFaces(xyz.pixels, faces, options);
      } else {
        BoxTruth truth;
        truth.labels = io::ReadGreyImage(truth_dir / "labels" / (stem + ".png"));
        truth.xyz = io::ReadExr(truth_dir / "xyz" / (stem + ".exr")).pixels;
        LN_CHECK_INPUT(truth.labels.type() == CV_16UC1 && truth.xyz.type() == CV_32FC3 &&
                       truth.labels.size() == truth.xyz.size())
            << truth_dir.string() << ": labels/" << stem << ".png (16-bit) and xyz/" << stem
            << ".exr (X, Y, Z) of one size expected";
        const SampleGrid grid = ReadSampleGrid(run / "disparity" / (stem + ".pfm"));
        errors = EvaluateBoxFaces(xyz.pixels, faces, options, &truth, grid);
      }
      for (std::size_t k = 0; k < faces.size(); ++k) {
        result.by_distance_cm[std::lround(faces[k].front_y_m * 100)].Add(errors[k]);
      }
      ++maps;
    } catch (const InputError& e) {
      ++*failed;
      LN_LOG(Error) << "pair " << stem << ": " << e.what();
    }
  }
  *run_json = {
      {"dir", run.string()}, {"name", result.name}, {"maps", maps}, {"step_px", {result.step_x, result.step_y}}};
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
    column += 4;  // E_Y, bias, points, dropped
  }
  gp << "\n";
  return WriteFigure(dir, "boxes", gp.str());
}

}  // namespace

int RunBoxesCommand(const BoxesCommand& command, const json& summary_head) {
  util::Timer timer;
  command.options.Validate();
  LN_CHECK_ARG(std::isfinite(command.sigma_d_px) && command.sigma_d_px > 0 && command.sigma_d_px <= 100)
      << "--sigma-d: must be in (0, 100] px, got " << command.sigma_d_px;
  const BoxList boxes = ReadBoxList(command.boxes);
  io::CreateOutputDirectory(command.output_dir);
  std::vector<BoxRunResult> runs;
  json runs_json = json::array();
  int failed = 0;
  for (const fs::path& run : command.runs) {
    json run_json;
    runs.push_back(ScoreBoxRun(run, boxes, command.options, command.truth, &run_json, &failed));
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
  const bool with_truth = !command.truth.empty();
  const Table table = BoxesTable(runs, predicted, command.options, with_truth);
  WriteTable(command.output_dir, "boxes", table);
  const FigureResult figure = BoxesFigure(command.output_dir, runs, !predicted.empty());
  const std::optional<double> gate = command.options.EffectiveYGate(with_truth);
  long dropped = 0, on_faces = 0;
  for (const BoxRunResult& run : runs) {
    for (const auto& [cm, e] : run.by_distance_cm) {
      dropped += e.gated_out;
      on_faces += e.points + e.gated_out;
    }
  }
  json summary = summary_head;
  summary["inputs"] = {{"runs", runs_json},
                       {"boxes", command.boxes.string()},
                       {"rig", command.rig.string()},
                       {"truth", command.truth.string()}};
  summary["rig_notes"] = rig_notes;  // what reading the rig changed (printed precision)
  summary["options"] = {{"edge_margin_m", command.options.edge_margin_m},
                        {"selection", with_truth ? "truth" : "extent"},
                        {"y_gate_fraction", gate ? json(*gate) : json(nullptr)},
                        {"sigma_d_px", command.sigma_d_px}};
  summary["counts"] = {{"runs", runs.size()},
                       {"distances", table.rows.size()},
                       {"failed_maps", failed},
                       {"face_points", on_faces},
                       {"gated_out", dropped}};
  summary["table"] = table.ToJson();
  summary["figures"] = json::array({FigureSummary(figure, "boxes.csv")});
  summary["timings_s"] = {{"total", timer.ElapsedSeconds()}};
  io::WriteJsonAtomic(command.output_dir / "summary.json", summary);
  LN_LOG(Info) << "evaluate boxes: " << runs.size() << " runs, " << table.rows.size() << " distances; "
               << (command.output_dir / "boxes.md").string();
  return failed > 0 ? kExitBatchPartial : kExitOk;
}

}  // namespace lunarnav::evaluation
