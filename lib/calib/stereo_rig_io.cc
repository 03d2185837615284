#include "calib/stereo_rig_io.h"

#include "calib/opencv_storage.h"

#include <set>
#include <string_view>
#include <tuple>

#include <opencv2/core.hpp>
#include <opencv2/core/eigen.hpp>

#include "io/json_io.h"
#include "io/nesting.h"
#include "util/check.h"
#include "util/log.h"

namespace lunarnav::calib {
namespace {

constexpr const char* kFormat = "lunarnav.rig/1";

void OnlyKeys(const nlohmann::json& j, const std::set<std::string>& allowed, const std::string& where) {
  LN_CHECK_INPUT(j.is_object()) << where << ": expected an object";
  for (const auto& [key, value] : j.items()) {
    LN_CHECK_INPUT(allowed.count(key) > 0) << where << ": unknown field '" << key << "'";
  }
}

const nlohmann::json& Field(const nlohmann::json& j, const char* key, const std::string& where) {
  LN_CHECK_INPUT(j.contains(key)) << where << ": missing field '" << key << "'";
  return j.at(key);
}

double Number(const nlohmann::json& v, const std::string& where) {
  LN_CHECK_INPUT(v.is_number()) << where << ": expected a number";
  return v.get<double>();
}

template <int Rows, int Cols>
Eigen::Matrix<double, Rows, Cols> MatrixFrom(const nlohmann::json& v, const std::string& where) {
  LN_CHECK_INPUT(v.is_array() && v.size() == Rows) << where << ": expected " << Rows << " rows of " << Cols;
  Eigen::Matrix<double, Rows, Cols> m;
  for (int r = 0; r < Rows; ++r) {
    LN_CHECK_INPUT(v[r].is_array() && v[r].size() == Cols)
        << where << ": expected " << Rows << " rows of " << Cols;
    for (int c = 0; c < Cols; ++c) m(r, c) = Number(v[r][c], where);
  }
  return m;
}

template <typename Derived>
nlohmann::json MatrixJson(const Eigen::MatrixBase<Derived>& m) {
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < m.rows(); ++r) {
    nlohmann::json row = nlohmann::json::array();
    for (int c = 0; c < m.cols(); ++c) row.push_back(m(r, c));
    rows.push_back(row);
  }
  return rows;
}

CameraIntrinsics CameraFrom(const nlohmann::json& j, const std::string& where) {
  OnlyKeys(j, {"K", "distortion"}, where);
  CameraIntrinsics c;
  c.K = MatrixFrom<3, 3>(Field(j, "K", where), where + ".K");
  if (j.contains("distortion")) {
    const auto& d = j["distortion"];
    LN_CHECK_INPUT(d.is_array()) << where << ".distortion: expected an array";
    for (const auto& v : d) c.distortion.push_back(Number(v, where + ".distortion"));
  }
  return c;
}

std::pair<int, int> SizeFrom(const nlohmann::json& v, const std::string& where) {
  LN_CHECK_INPUT(v.is_array() && v.size() == 2 && v[0].is_number_integer() && v[1].is_number_integer())
      << where << ": expected [width, height] in pixels";
  return {v[0].get<int>(), v[1].get<int>()};
}

}  // namespace

nlohmann::json StereoRigToJson(const StereoRig& rig) {
  auto camera = [](const CameraIntrinsics& c) {
    return nlohmann::json{{"K", MatrixJson(c.K)}, {"distortion", c.distortion}};
  };
  nlohmann::json j;
  j["format"] = kFormat;
  j["image_size_px"] = {rig.width_px, rig.height_px};
  j["left"] = camera(rig.left);
  j["right"] = camera(rig.right);
  j["right_from_left"] = {{"R", MatrixJson(rig.right_from_left_R)},
                          {"t_m", {rig.right_from_left_t_m.x(), rig.right_from_left_t_m.y(), rig.right_from_left_t_m.z()}}};
  j["mast"] = {{"height_m", rig.mast.height_m},
               {"tilt_deg", rig.mast.tilt_deg},
               {"lateral_offset_m", rig.mast.lateral_offset_m},
               {"forward_offset_m", rig.mast.forward_offset_m}};
  if (rig.rectified) {
    const RectifiedGeometry& g = *rig.rectified;
    j["rectified"] = {{"rect_from_left", MatrixJson(g.rect_from_left)},
                      {"rect_from_right", MatrixJson(g.rect_from_right)},
                      {"P_left", MatrixJson(g.P_left)},
                      {"P_right", MatrixJson(g.P_right)},
                      {"size_px", {g.width_px, g.height_px}}};
  }
  return j;
}

StereoRig StereoRigFromJson(const nlohmann::json& j, const std::string& source) {
  OnlyKeys(j, {"format", "description", "image_size_px", "left", "right", "right_from_left", "mast", "rectified"},
           source);
  LN_CHECK_INPUT(Field(j, "format", source) == kFormat)
      << source << ".format: expected \"" << kFormat << "\"";
  StereoRig rig;
  std::tie(rig.width_px, rig.height_px) = SizeFrom(Field(j, "image_size_px", source), source + ".image_size_px");
  rig.left = CameraFrom(Field(j, "left", source), source + ".left");
  rig.right = CameraFrom(Field(j, "right", source), source + ".right");
  const std::string rl = source + ".right_from_left";
  const auto& pose = Field(j, "right_from_left", source);
  OnlyKeys(pose, {"R", "t_m"}, rl);
  rig.right_from_left_R = MatrixFrom<3, 3>(Field(pose, "R", rl), rl + ".R");
  const auto& t = Field(pose, "t_m", rl);
  LN_CHECK_INPUT(t.is_array() && t.size() == 3) << rl << ".t_m: expected 3 numbers";
  rig.right_from_left_t_m = MatrixFrom<3, 1>(nlohmann::json{{t[0]}, {t[1]}, {t[2]}}, rl + ".t_m");
  if (j.contains("mast")) {
    const std::string m = source + ".mast";
    const auto& mj = j["mast"];
    OnlyKeys(mj, {"height_m", "tilt_deg", "lateral_offset_m", "forward_offset_m"}, m);
    rig.mast.height_m = Number(Field(mj, "height_m", m), m + ".height_m");
    rig.mast.tilt_deg = Number(Field(mj, "tilt_deg", m), m + ".tilt_deg");
    if (mj.contains("lateral_offset_m")) rig.mast.lateral_offset_m = Number(mj["lateral_offset_m"], m + ".lateral_offset_m");
    if (mj.contains("forward_offset_m")) rig.mast.forward_offset_m = Number(mj["forward_offset_m"], m + ".forward_offset_m");
  }
  if (j.contains("rectified")) {
    const std::string r = source + ".rectified";
    const auto& rj = j["rectified"];
    OnlyKeys(rj, {"rect_from_left", "rect_from_right", "P_left", "P_right", "size_px"}, r);
    RectifiedGeometry g;
    g.rect_from_left = MatrixFrom<3, 3>(Field(rj, "rect_from_left", r), r + ".rect_from_left");
    g.rect_from_right = MatrixFrom<3, 3>(Field(rj, "rect_from_right", r), r + ".rect_from_right");
    g.P_left = MatrixFrom<3, 4>(Field(rj, "P_left", r), r + ".P_left");
    g.P_right = MatrixFrom<3, 4>(Field(rj, "P_right", r), r + ".P_right");
    std::tie(g.width_px, g.height_px) = SizeFrom(Field(rj, "size_px", r), r + ".size_px");
    rig.rectified = g;
  }
  RepairPrintedPrecision(&rig, source);
  rig.Validate(source);
  return rig;
}

StereoRig ReadStereoRig(const std::filesystem::path& path) {
  StereoRig rig = StereoRigFromJson(io::ReadJson(path), path.string());
  for (const std::string& note : rig.notes) LN_LOG(Warning) << note;
  return rig;
}

void WriteStereoRig(const std::filesystem::path& path, const StereoRig& rig) {
  io::WriteJsonAtomic(path, StereoRigToJson(rig));
}

StereoRig ReadOpenCvCalibration(const std::filesystem::path& intrinsics,
                                const std::filesystem::path& extrinsics, int width_px,
                                int height_px, double metres_per_unit, const MastPose& mast) {
  LN_CHECK_ARG(metres_per_unit > 0) << "metres per unit: must be > 0";
  // Never given to OpenCV's FileStorage: read by parsers that bound their own depth, the
  // matrices built from what they read (opencv_storage.h). The file is read whole, bounded.
  auto open = [](const std::filesystem::path& p) {
    return OpenCvStorage::Parse(io::ReadConfigText(p, io::kMaxConfigBytes, /*check_nesting=*/false), p.string());
  };
  const OpenCvStorage in = open(intrinsics), ex = open(extrinsics);
  const std::string in_name = intrinsics.string(), ex_name = extrinsics.string();
  StereoRig rig;
  rig.width_px = width_px;
  rig.height_px = height_px;
  rig.mast = mast;
  auto camera = [&](const char* m_name, const char* d_name) {
    const cv::Mat m = in.Matrix(m_name, true), d = in.Matrix(d_name, false);
    LN_CHECK_INPUT(m.rows == 3 && m.cols == 3) << in_name << ": " << m_name << " must be 3x3";
    CameraIntrinsics c;
    cv::cv2eigen(m, c.K);
    for (int i = 0; i < static_cast<int>(d.total()); ++i) c.distortion.push_back(d.at<double>(i));
    c.Validate(width_px, height_px, in_name + ": " + m_name);  // named where it was read
    return c;
  };
  rig.left = camera("M1", "D1");
  rig.right = camera("M2", "D2");
  const cv::Mat r = ex.Matrix("R", true), t = ex.Matrix("T", true);
  LN_CHECK_INPUT(r.rows == 3 && r.cols == 3) << ex_name << ": R must be 3x3";
  LN_CHECK_INPUT(t.total() == 3) << ex_name << ": T must have 3 elements";
  cv::cv2eigen(r, rig.right_from_left_R);
  for (int i = 0; i < 3; ++i) rig.right_from_left_t_m[i] = t.at<double>(i) * metres_per_unit;
  const cv::Mat r1 = ex.Matrix("R1", false), r2 = ex.Matrix("R2", false);
  const cv::Mat p1 = ex.Matrix("P1", false), p2 = ex.Matrix("P2", false);
  if (!r1.empty() && !r2.empty() && !p1.empty() && !p2.empty()) {
    for (const auto& [m, name, cols] : {std::tuple{&r1, "R1", 3}, {&r2, "R2", 3}, {&p1, "P1", 4}, {&p2, "P2", 4}}) {
      LN_CHECK_INPUT(m->rows == 3 && m->cols == cols) << ex_name << ": " << name << " must be 3x" << cols;
    }
    RectifiedGeometry g;
    cv::cv2eigen(r1, g.rect_from_left);
    cv::cv2eigen(r2, g.rect_from_right);
    cv::cv2eigen(p1, g.P_left);
    cv::cv2eigen(p2, g.P_right);
    g.P_right(0, 3) *= metres_per_unit;  // -f * baseline, in T's units
    g.width_px = width_px;
    g.height_px = height_px;
    rig.rectified = g;
  }
  RepairPrintedPrecision(&rig, ex_name);
  rig.Validate(ex_name);
  return rig;
}

}  // namespace lunarnav::calib
