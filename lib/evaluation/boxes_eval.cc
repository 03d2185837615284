#include "evaluation/boxes_eval.h"

#include <cmath>

#include "io/json_io.h"
#include "util/check.h"

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

}  // namespace lunarnav::evaluation
