#include "calib/rig_import.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "calib/key_value_text.h"
#include "calib/stereo_rig_io.h"
#include "io/atomic_file.h"
#include "io/image_io.h"
#include "io/json_io.h"
#include "io/nesting.h"
#include "util/check.h"
#include "util/parse.h"
#include "util/log.h"
#include "util/summary.h"
#include "util/timer.h"

namespace lunarnav::calib {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// ---- YAML (ROS, Kalibr) ----

YAML::Node LoadYaml(const fs::path& path) {
  const std::string text = io::ReadConfigText(path);  // size and nesting bounded first
  try {
    YAML::Node root = YAML::Load(text);
    LN_CHECK_INPUT(root.IsMap()) << path.string() << ": expected a YAML mapping at the top";
    return root;
  } catch (const YAML::Exception& e) {
    throw InputError(path.string() + ": not YAML (line " + std::to_string(e.mark.line + 1) + ": " + e.msg + ")");
  }
}

// The first of `keys` present in `node` (ROS 1 and ROS 2 spell the same field differently).
YAML::Node YamlField(const YAML::Node& node, std::initializer_list<const char*> keys, const std::string& where) {
  for (const char* key : keys) {
    if (node[key]) return node[key];
  }
  throw InputError(where + ": missing field '" + *keys.begin() + "'");
}

double YamlNumber(const YAML::Node& node, const std::string& where) {
  try {
    const double v = node.as<double>();
    LN_CHECK_INPUT(std::isfinite(v)) << where << ": not finite";
    return v;
  } catch (const YAML::Exception&) {
    throw InputError(where + ": expected a number");
  }
}

int YamlInt(const YAML::Node& node, const std::string& where) {
  try {
    return node.as<int>();
  } catch (const YAML::Exception&) {
    throw InputError(where + ": expected an integer");
  }
}

std::string YamlString(const YAML::Node& node, const std::string& where) {
  try {
    return node.as<std::string>();
  } catch (const YAML::Exception&) {
    throw InputError(where + ": expected a string");
  }
}

// A flat list of numbers; `count` < 0 accepts any length.
std::vector<double> YamlNumbers(const YAML::Node& node, int count, const std::string& where) {
  LN_CHECK_INPUT(node.IsSequence()) << where << ": expected a list of numbers";
  LN_CHECK_INPUT(count < 0 || static_cast<int>(node.size()) == count)
      << where << ": expected " << count << " numbers, got " << node.size();
  std::vector<double> values;
  for (std::size_t i = 0; i < node.size(); ++i) values.push_back(YamlNumber(node[i], where));
  return values;
}

// A matrix given as a flat list, or (camera_calibration's files) as {rows, cols, data}.
template <int Rows, int Cols>
Eigen::Matrix<double, Rows, Cols> YamlMatrix(const YAML::Node& node, const std::string& where) {
  std::vector<double> values;
  if (node.IsMap()) {
    const int rows = YamlInt(YamlField(node, {"rows"}, where), where + ".rows");
    const int cols = YamlInt(YamlField(node, {"cols"}, where), where + ".cols");
    LN_CHECK_INPUT(rows == Rows && cols == Cols) << where << ": expected " << Rows << "x" << Cols << ", got " << rows
                                                 << "x" << cols;
    values = YamlNumbers(YamlField(node, {"data"}, where), Rows * Cols, where + ".data");
  } else {
    values = YamlNumbers(node, Rows * Cols, where);
  }
  Eigen::Matrix<double, Rows, Cols> m;
  for (int r = 0; r < Rows; ++r) {
    for (int c = 0; c < Cols; ++c) m(r, c) = values[static_cast<std::size_t>(r * Cols + c)];
  }
  return m;
}

// The distortion coefficients of a list, or of {rows, cols, data}.
std::vector<double> YamlDistortion(const YAML::Node& node, const std::string& where) {
  if (node.IsMap()) return YamlNumbers(YamlField(node, {"data"}, where), -1, where + ".data");
  return YamlNumbers(node, -1, where);
}

struct RosCamera {
  int width = 0, height = 0;
  CameraIntrinsics intrinsics;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Matrix<double, 3, 4> P = Eigen::Matrix<double, 3, 4>::Zero();
};

RosCamera ReadRosCamera(const fs::path& path) {
  const YAML::Node root = LoadYaml(path);
  const std::string f = path.string();
  RosCamera c;
  c.width = YamlInt(YamlField(root, {"image_width", "width"}, f), f + ".image_width");
  c.height = YamlInt(YamlField(root, {"image_height", "height"}, f), f + ".image_height");
  const std::string model = YamlString(YamlField(root, {"distortion_model"}, f), f + ".distortion_model");
  // plumb_bob and rational_polynomial are OpenCV's k1 k2 p1 p2 k3 [k4 k5 k6].
  LN_CHECK_INPUT(model == "plumb_bob" || model == "rational_polynomial")
      << f << ".distortion_model: '" << model << "' is not supported (plumb_bob or rational_polynomial)";
  c.intrinsics.K = YamlMatrix<3, 3>(YamlField(root, {"camera_matrix", "K", "k"}, f), f + ".camera_matrix");
  c.intrinsics.distortion =
      YamlDistortion(YamlField(root, {"distortion_coefficients", "D", "d"}, f), f + ".distortion_coefficients");
  // An all-zero list (an uncalibrated camera_info) means no distortion.
  bool all_zero = true;
  for (double d : c.intrinsics.distortion) all_zero = all_zero && d == 0;
  if (all_zero) c.intrinsics.distortion.clear();
  c.R = YamlMatrix<3, 3>(YamlField(root, {"rectification_matrix", "R", "r"}, f), f + ".rectification_matrix");
  c.P = YamlMatrix<3, 4>(YamlField(root, {"projection_matrix", "P", "p"}, f), f + ".projection_matrix");
  return c;
}

// ---- key = value text (Middlebury, KITTI) ----

// A rig whose raw images are already rectified: no distortion, the same K (up to the principal
// column), R = I, t = (-B, 0, 0), and its own rectified geometry.
StereoRig RectifiedRig(const Eigen::Matrix3d& k_left, const Eigen::Matrix3d& k_right, double baseline_m, int width,
                       int height, const MastPose& mast) {
  StereoRig rig;
  rig.width_px = width;
  rig.height_px = height;
  rig.left.K = k_left;
  rig.right.K = k_right;
  rig.right_from_left_R = Eigen::Matrix3d::Identity();
  rig.right_from_left_t_m = Eigen::Vector3d(-baseline_m, 0, 0);
  rig.mast = mast;
  RectifiedGeometry g;
  g.P_left.leftCols<3>() = k_left;
  g.P_right.leftCols<3>() = k_right;
  g.P_right(0, 3) = -k_right(0, 0) * baseline_m;
  g.width_px = width;
  g.height_px = height;
  rig.rectified = g;
  return rig;
}

std::string Fixed(double value, int precision) {
  char text[48];
  std::snprintf(text, sizeof(text), "%.*f", precision, value);
  return text;
}

}  // namespace

std::string ToString(RigFormat format) {
  for (const auto& [name, f] : RigFormatNames()) {
    if (f == format) return name;
  }
  return "?";
}

std::map<std::string, KittiPair> KittiPairNames() {
  return {{"colour", KittiPair::kColour}, {"grey", KittiPair::kGrey}};
}

std::map<std::string, RigFormat> RigFormatNames() {
  return {{"opencv", RigFormat::kOpenCv},
          {"ros", RigFormat::kRos},
          {"kalibr", RigFormat::kKalibr},
          {"middlebury", RigFormat::kMiddlebury},
          {"kitti", RigFormat::kKitti}};
}

int RigFormatFileCount(RigFormat format) {
  return format == RigFormat::kOpenCv || format == RigFormat::kRos ? 2 : 1;
}

void RigImportOptions::Validate() const {
  const int count = RigFormatFileCount(format);
  LN_CHECK_ARG(static_cast<int>(files.size()) == count)
      << "--from " << ToString(format) << ": expected " << count << " file" << (count == 1 ? "" : "s") << ", got "
      << files.size();
  if (format == RigFormat::kOpenCv) {
    LN_CHECK_ARG(image_size_px.has_value()) << "--from opencv needs --image-size WIDTHxHEIGHT";
    LN_CHECK_ARG(image_size_px->first > 0 && image_size_px->second > 0) << "--image-size: must be positive";
    LN_CHECK_ARG(std::isfinite(metres_per_unit) && metres_per_unit > 0)
        << "--square: the metres per unit of T must be positive, got " << metres_per_unit;
  }
  LN_CHECK_ARG(std::isfinite(mast.tilt_deg) && mast.tilt_deg > -90 && mast.tilt_deg < 90)
      << "--tilt: must be in (-90, 90) deg, got " << mast.tilt_deg;
}

json RigImportOptions::ToJson() const {
  json j = {{"format", ToString(format)},
            {"mast", {{"height_m", mast.height_m},
                      {"tilt_deg", mast.tilt_deg},
                      {"lateral_offset_m", mast.lateral_offset_m},
                      {"forward_offset_m", mast.forward_offset_m}}}};
  if (format == RigFormat::kOpenCv) {
    j["image_size_px"] = {image_size_px->first, image_size_px->second};
    j["metres_per_unit"] = metres_per_unit;
  }
  if (format == RigFormat::kKitti) {
    j["kitti_pair"] = kitti_pair == KittiPair::kGrey ? "grey" : "colour";
    if (image_size_px) j["image_size_px"] = {image_size_px->first, image_size_px->second};
  }
  return j;
}

StereoRig ReadRosCameraInfoPair(const fs::path& left, const fs::path& right, const MastPose& mast) {
  RosCamera l = ReadRosCamera(left), r = ReadRosCamera(right);
  const std::string lf = left.string(), rf = right.string();
  // The rotations may be printed: make them exact before deriving the raw pose from them.
  std::vector<std::string> notes;
  RepairPrintedRotation(&l.R, lf + ".rectification_matrix", &notes);
  RepairPrintedRotation(&r.R, rf + ".rectification_matrix", &notes);
  LN_CHECK_INPUT(l.width == r.width && l.height == r.height)
      << rf << ".image_width, image_height: " << r.width << "x" << r.height << " differs from " << lf << "'s "
      << l.width << "x" << l.height;
  LN_CHECK_INPUT(l.P(0, 3) == 0 && l.P(1, 3) == 0)
      << lf << ".projection_matrix: the left camera's P must have Tx = Ty = 0 (is this the right camera's file?)";
  LN_CHECK_INPUT(r.P(1, 3) == 0 && r.P(0, 3) < 0)
      << rf << ".projection_matrix: expected a horizontal stereo pair with the right camera to the right "
      << "(P[0][3] = -f B < 0, P[1][3] = 0), got P[0][3] = " << r.P(0, 3) << ", P[1][3] = " << r.P(1, 3);
  LN_CHECK_INPUT(r.P(0, 0) > 0) << rf << ".projection_matrix: the focal length must be positive";
  StereoRig rig;
  rig.width_px = l.width;
  rig.height_px = l.height;
  rig.left = l.intrinsics;
  rig.right = r.intrinsics;
  rig.mast = mast;
  RectifiedGeometry g;
  g.rect_from_left = l.R;
  g.rect_from_right = r.R;
  g.P_left = l.P;
  g.P_right = r.P;
  g.width_px = l.width;
  g.height_px = l.height;
  rig.rectified = g;
  rig.notes = notes;
  RepairPrintedPrecision(&rig, rf);  // the right projection's shared values
  const RectifiedGeometry& e = *rig.rectified;
  // x_rect_right = x_rect_left + (P_right[0][3] / f', 0, 0); x_rect = R x for each camera.
  const Eigen::Vector3d t_rect(e.P_right(0, 3) / e.P_right(0, 0), 0, 0);
  rig.right_from_left_R = e.rect_from_right.transpose() * e.rect_from_left;
  rig.right_from_left_t_m = e.rect_from_right.transpose() * t_rect;
  rig.Validate(lf + " and " + rf);
  return rig;
}

StereoRig ReadKalibrCamchain(const fs::path& camchain, const MastPose& mast) {
  const YAML::Node root = LoadYaml(camchain);
  const std::string f = camchain.string();
  StereoRig rig;
  rig.mast = mast;
  std::pair<int, int> sizes[2];
  for (int i = 0; i < 2; ++i) {
    const std::string name = i == 0 ? "cam0" : "cam1";
    const std::string where = f + "." + name;
    const YAML::Node cam = YamlField(root, {i == 0 ? "cam0" : "cam1"}, f);
    LN_CHECK_INPUT(cam.IsMap()) << where << ": expected a mapping";
    const std::string model = YamlString(YamlField(cam, {"camera_model"}, where), where + ".camera_model");
    LN_CHECK_INPUT(model == "pinhole") << where << ".camera_model: '" << model << "' is not supported (pinhole)";
    const std::string distortion =
        YamlString(YamlField(cam, {"distortion_model"}, where), where + ".distortion_model");
    LN_CHECK_INPUT(distortion == "radtan" || distortion == "none")
        << where << ".distortion_model: '" << distortion << "' is not supported (radtan, OpenCV's k1 k2 p1 p2)";
    const std::vector<double> in = YamlNumbers(YamlField(cam, {"intrinsics"}, where), 4, where + ".intrinsics");
    CameraIntrinsics& c = i == 0 ? rig.left : rig.right;
    c.K << in[0], 0, in[2], 0, in[1], in[3], 0, 0, 1;
    if (distortion == "radtan") {
      c.distortion = YamlNumbers(YamlField(cam, {"distortion_coeffs"}, where), 4, where + ".distortion_coeffs");
    }
    const std::vector<double> res = YamlNumbers(YamlField(cam, {"resolution"}, where), 2, where + ".resolution");
    sizes[i] = {static_cast<int>(res[0]), static_cast<int>(res[1])};
    LN_CHECK_INPUT(res[0] == sizes[i].first && res[1] == sizes[i].second && res[0] > 0 && res[1] > 0)
        << where << ".resolution: expected [width, height] in pixels";
  }
  LN_CHECK_INPUT(sizes[0] == sizes[1]) << f << ".cam1.resolution: differs from cam0's (the rig needs one size)";
  rig.width_px = sizes[0].first;
  rig.height_px = sizes[0].second;
  const std::string tw = f + ".cam1.T_cn_cnm1";
  const YAML::Node t = YamlField(root["cam1"], {"T_cn_cnm1"}, f + ".cam1");
  LN_CHECK_INPUT(t.IsSequence() && t.size() == 4) << tw << ": expected 4 rows of 4";
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r) {
    const std::vector<double> row = YamlNumbers(t[r], 4, tw);
    for (int c = 0; c < 4; ++c) m(r, c) = row[static_cast<std::size_t>(c)];
  }
  LN_CHECK_INPUT(std::abs(m(3, 0)) + std::abs(m(3, 1)) + std::abs(m(3, 2)) < 1e-9 && std::abs(m(3, 3) - 1) < 1e-9)
      << tw << ": the last row must be [0, 0, 0, 1]";
  rig.right_from_left_R = m.topLeftCorner<3, 3>();
  rig.right_from_left_t_m = m.topRightCorner<3, 1>();
  RepairPrintedRotation(&rig.right_from_left_R, tw, &rig.notes);
  rig.Validate(f);
  return rig;
}

StereoRig ReadMiddleburyCalib(const fs::path& calib_txt, const MastPose& mast) {
  const auto entries = ReadKeyValues(calib_txt, '=');
  auto matrix = [&](const char* key) {
    const std::vector<double> v = TextNumbers(TextField(entries, key, calib_txt), key, calib_txt, 9);
    Eigen::Matrix3d k;
    k << v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8];
    return k;
  };
  auto number = [&](const char* key) { return TextNumbers(TextField(entries, key, calib_txt), key, calib_txt, 1)[0]; };
  const Eigen::Matrix3d cam0 = matrix("cam0"), cam1 = matrix("cam1");
  const double doffs = number("doffs"), baseline_mm = number("baseline");
  const double width = number("width"), height = number("height");
  const std::string f = calib_txt.string();
  LN_CHECK_INPUT(width > 0 && height > 0 && width == std::floor(width) && height == std::floor(height))
      << f << ": width, height: expected positive whole pixels";
  LN_CHECK_INPUT(baseline_mm > 0) << f << ": baseline: must be positive (millimetres), got " << baseline_mm;
  LN_CHECK_INPUT(cam0(0, 0) > 0 && cam0(0, 0) == cam1(0, 0) && cam0(1, 1) == cam1(1, 1) && cam0(1, 2) == cam1(1, 2))
      << f << ": cam0, cam1: a rectified pair shares the focal length and the principal row";
  LN_CHECK_INPUT(std::abs(cam1(0, 2) - cam0(0, 2) - doffs) <= 1e-3 * std::max(1.0, std::abs(doffs)))
      << f << ": doffs: " << doffs << " differs from the principal points' offset cx1 - cx0 = "
      << cam1(0, 2) - cam0(0, 2);
  StereoRig rig = RectifiedRig(cam0, cam1, baseline_mm * 1e-3, static_cast<int>(width), static_cast<int>(height), mast);
  rig.Validate(f);
  return rig;
}

StereoRig ReadKittiCalib(const fs::path& calib_txt, const MastPose& mast, KittiPair pair,
                         const std::optional<std::pair<int, int>>& image_size_px) {
  const auto entries = ReadKeyValues(calib_txt, ':');
  const std::string f = calib_txt.string();
  const bool grey = pair == KittiPair::kGrey;
  // The raw format names its rectified projections P_rect_0N; the odometry format PN.
  const bool odometry = entries.count("P_rect_00") == 0 && entries.count("P_rect_02") == 0 &&
                        (entries.count("P0") > 0 || entries.count("P2") > 0);
  const std::string left_key = odometry ? (grey ? "P0" : "P2") : (grey ? "P_rect_00" : "P_rect_02");
  const std::string right_key = odometry ? (grey ? "P1" : "P3") : (grey ? "P_rect_01" : "P_rect_03");
  auto projection = [&](const std::string& key) {
    const std::vector<double> v = TextNumbers(TextField(entries, key, calib_txt), key, calib_txt, 12);
    Eigen::Matrix<double, 3, 4> p;
    for (int i = 0; i < 12; ++i) p(i / 4, i % 4) = v[static_cast<std::size_t>(i)];
    return p;
  };
  const Eigen::Matrix<double, 3, 4> pl = projection(left_key), pr = projection(right_key);
  std::pair<double, double> size;
  if (!odometry) {
    const std::string size_key = grey ? "S_rect_00" : "S_rect_02";
    const std::vector<double> s = TextNumbers(TextField(entries, size_key, calib_txt), size_key, calib_txt, 2);
    size = {s[0], s[1]};
  } else if (image_size_px.has_value()) {
    size = {image_size_px->first, image_size_px->second};
  } else {
    // calib.txt holds no size: the sequence's own first image of the pair's left camera.
    const fs::path folder = calib_txt.parent_path() / (grey ? "image_0" : "image_2");
    std::error_code ec;
    fs::path first;
    if (fs::is_directory(folder, ec)) {
      for (const auto& e : fs::directory_iterator(folder, ec)) {
        if (io::HasImageExtension(e.path()) && (first.empty() || e.path() < first)) first = e.path();
      }
    }
    LN_CHECK_ARG(!first.empty()) << f << ": an odometry calib.txt holds no image size: give --image-size WIDTHxHEIGHT "
                                 << "(no image in " << folder.string() << " to take it from)";
    const cv::Mat image = io::ReadImage(first);
    size = {image.cols, image.rows};
  }
  LN_CHECK_INPUT(size.first > 0 && size.second > 0 && size.first == std::floor(size.first) &&
                 size.second == std::floor(size.second) && size.first <= 1e5 && size.second <= 1e5)
      << f << ": expected the rectified width and height in whole pixels, got " << size.first << " x "
      << size.second;
  const Eigen::Matrix3d k = pl.leftCols<3>();
  LN_CHECK_INPUT(k(0, 0) > 0 && k(1, 1) > 0 && k(2, 2) == 1 && k(1, 0) == 0 && k(2, 0) == 0 && k(2, 1) == 0)
      << f << ": " << left_key << ": its left 3x3 block is no camera matrix [f 0 cx; 0 f cy; 0 0 1]";
  LN_CHECK_INPUT((pr.leftCols<3>() - k).cwiseAbs().maxCoeff() <= 1e-6 * k(0, 0))
      << f << ": " << right_key << ": its left 3x3 block must equal " << left_key << "'s (one rectified camera matrix)";
  // Each camera's centre in the rectified frame of camera 0: t = K^-1 P[:, 3].
  const Eigen::Vector3d tl = k.inverse() * pl.col(3), tr = k.inverse() * pr.col(3);
  const double baseline_m = tl.x() - tr.x();
  LN_CHECK_INPUT(baseline_m > 0 && baseline_m <= kMaxBaselineM)
      << f << ": " << right_key << ": camera " << right_key.back() << " must be to the right of camera "
      << left_key.back() << " (" << left_key << "[0][3] > " << right_key << "[0][3]) by at most " << kMaxBaselineM
      << " m, got a baseline of " << baseline_m << " m";
  StereoRig rig = RectifiedRig(k, k, baseline_m, static_cast<int>(size.first), static_cast<int>(size.second), mast);
  const Eigen::Vector3d dropped = (tr - tl) * 1e3;
  if (std::abs(dropped.y()) >= 0.005 || std::abs(dropped.z()) >= 0.005) {
    rig.notes.push_back(f + ": " + left_key + ", " + right_key + ": the offsets between cameras " + left_key.back() +
                        " and " + right_key.back() + " along y (" + Fixed(dropped.y(), 2) + " mm) and z (" +
                        Fixed(dropped.z(), 2) + " mm) are dropped; baseline " + Fixed(baseline_m, 4) + " m along x");
  }
  rig.Validate(f);
  return rig;
}

StereoRig ImportRig(const RigImportOptions& options) {
  options.Validate();
  const std::vector<fs::path>& files = options.files;
  switch (options.format) {
    case RigFormat::kOpenCv:
      return ReadOpenCvCalibration(files[0], files[1], options.image_size_px->first, options.image_size_px->second,
                                   options.metres_per_unit, options.mast);
    case RigFormat::kRos: return ReadRosCameraInfoPair(files[0], files[1], options.mast);
    case RigFormat::kKalibr: return ReadKalibrCamchain(files[0], options.mast);
    case RigFormat::kMiddlebury: return ReadMiddleburyCalib(files[0], options.mast);
    case RigFormat::kKitti: return ReadKittiCalib(files[0], options.mast, options.kitti_pair, options.image_size_px);
  }
  throw std::invalid_argument("--from: unknown format");
}

std::string RigImportRun::BriefReport() const {
  std::ostringstream s;
  s << "baseline " << Fixed(rig.BaselineM(), 4) << " m, left fx " << Fixed(rig.left.K(0, 0), 2) << " px, "
    << (rig.rectified ? "rectified (stereo-batch --rig reads it as it is)" : "raw (rectify it first)");
  if (!rig.notes.empty()) s << "; " << rig.notes.size() << " note" << (rig.notes.size() == 1 ? "" : "s");
  return s.str();
}

RigImportRun RunRigImport(const RigImportOptions& options, const fs::path& rig_path, const fs::path& summary_path,
                          const json& invocation) {
  util::Timer timer;
  RigImportRun run;
  run.rig = ImportRig(options);
  for (const std::string& note : run.rig.notes) LN_LOG(Warning) << note;
  run.rig_path = rig_path;
  run.summary_path = summary_path;
  for (const fs::path& p : {rig_path, summary_path}) {
    if (!p.parent_path().empty()) io::CreateOutputDirectory(p.parent_path());
  }
  WriteStereoRig(rig_path, run.rig);
  run.seconds = timer.ElapsedSeconds();
  json j = util::SummaryHead("calibrate", invocation);
  j["mode"] = "import";
  json inputs = json::array();
  for (const fs::path& p : options.files) inputs.push_back(p.string());
  j["inputs"] = {{"format", ToString(options.format)}, {"files", inputs}};
  j["options"] = options.ToJson();
  j["outputs"] = {{"rig", rig_path.string()}};
  j["rig"] = {{"baseline_m", run.rig.BaselineM()},
              {"image_size_px", {run.rig.width_px, run.rig.height_px}},
              {"rectified", run.rig.rectified.has_value()}};
  j["notes"] = run.rig.notes;
  j["timings_s"] = {{"total", run.seconds}};
  io::WriteJsonAtomic(summary_path, j);
  return run;
}

}  // namespace lunarnav::calib
