#include "calib/rig_import.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <fstream>
#include <string>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/paper_rig.h"
#include "calib/rectify.h"
#include "calib/stereo_rig_io.h"
#include "calib/triangulation.h"
#include "util/errors.h"
#include "util/testing.h"

namespace lunarnav::calib {
namespace {

namespace fs = std::filesystem;

void WriteText(const fs::path& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
}

// Numbers as a calibration tool prints them: 9 significant digits.
std::string Num(double v) {
  char text[48];
  std::snprintf(text, sizeof(text), "%.9g", v);
  return text;
}

template <typename Derived>
std::string FlatList(const Eigen::MatrixBase<Derived>& m) {
  std::string s = "[";
  for (int r = 0; r < m.rows(); ++r) {
    for (int c = 0; c < m.cols(); ++c) s += (r + c > 0 ? ", " : "") + Num(m(r, c));
  }
  return s + "]";
}

std::string List(const std::vector<double>& v) {
  std::string s = "[";
  for (std::size_t i = 0; i < v.size(); ++i) s += (i > 0 ? ", " : "") + Num(v[i]);
  return s + "]";
}

template <typename Error = InputError, typename F>
void ExpectError(F&& f, const std::string& words) {
  try {
    f();
    ADD_FAILURE() << "no error; expected one with: " << words;
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
  }
}

TEST(ReadRosCameraInfoPair, AgreesWithTheRigItDescribes) {
  util::ScopedTempDir tmp;
  const StereoRig truth = RectifyRig(testing::PaperRig());
  const RectifiedGeometry& g = *truth.rectified;
  // left.yaml as ROS's camera_calibration writes it; right.yaml as a CameraInfo message
  // echoed to YAML (ROS 1 field names).
  WriteText(tmp.path() / "left.yaml",
            "image_width: 640\nimage_height: 480\ncamera_name: stereo/left\ncamera_matrix:\n  rows: 3\n  cols: 3\n"
            "  data: " + FlatList(truth.left.K) + "\ndistortion_model: plumb_bob\ndistortion_coefficients:\n"
            "  rows: 1\n  cols: 5\n  data: " + List(truth.left.distortion) + "\nrectification_matrix:\n"
            "  rows: 3\n  cols: 3\n  data: " + FlatList(g.rect_from_left) + "\nprojection_matrix:\n  rows: 3\n"
            "  cols: 4\n  data: " + FlatList(g.P_left) + "\n");
  WriteText(tmp.path() / "right.yaml",
            "header:\n  seq: 0\n  stamp:\n    secs: 0\n    nsecs: 0\n  frame_id: \"right\"\nheight: 480\nwidth: 640\n"
            "distortion_model: \"plumb_bob\"\nD: " + List(truth.right.distortion) + "\nK: " + FlatList(truth.right.K) +
            "\nR: " + FlatList(g.rect_from_right) + "\nP: " + FlatList(g.P_right) + "\nbinning_x: 0\nbinning_y: 0\n");
  const StereoRig rig = ReadRosCameraInfoPair(tmp.path() / "left.yaml", tmp.path() / "right.yaml", truth.mast);
  EXPECT_EQ(rig.width_px, 640);
  EXPECT_TRUE(rig.left.K.isApprox(truth.left.K, 1e-8));
  EXPECT_NEAR(rig.right.distortion[0], truth.right.distortion[0], 1e-9);
  // The raw pose comes back from R1, R2 and P2 to the printing's precision.
  EXPECT_LT((rig.right_from_left_R - truth.right_from_left_R).cwiseAbs().maxCoeff(), 1e-7);
  EXPECT_LT((rig.right_from_left_t_m - truth.right_from_left_t_m).norm(), 1e-7);
  ASSERT_TRUE(rig.rectified.has_value());
  EXPECT_TRUE(rig.rectified->P_right.isApprox(g.P_right, 1e-8));
  // A rectified rig: rectify keeps its own rectification, and its rows agree.
  const Rectifier rectifier(rig);
  const Eigen::Vector3d point_left(0.3, -0.2, 6.0);
  const Eigen::Vector3d point_right = truth.right_from_left_R * point_left + truth.right_from_left_t_m;
  cv::Mat rvec = cv::Mat::zeros(3, 1, CV_64F), tvec = cv::Mat::zeros(3, 1, CV_64F);
  std::vector<cv::Point2d> pl, pr;
  cv::Mat kl_cv, kr_cv;
  cv::eigen2cv(truth.left.K, kl_cv);
  cv::eigen2cv(truth.right.K, kr_cv);
  cv::projectPoints(std::vector<cv::Point3d>{{point_left.x(), point_left.y(), point_left.z()}}, rvec, tvec, kl_cv,
                    truth.left.distortion, pl);
  cv::projectPoints(std::vector<cv::Point3d>{{point_right.x(), point_right.y(), point_right.z()}}, rvec, tvec,
                    kr_cv, truth.right.distortion, pr);
  EXPECT_NEAR(rectifier.RectifyPoints(pl, true)[0].y, rectifier.RectifyPoints(pr, false)[0].y, 1e-4);

  // Errors name the file and the field.
  WriteText(tmp.path() / "bad.yaml", "image_width: 640\nimage_height: 480\ndistortion_model: plumb_bob\n"
                                     "camera_matrix: [1, 0, 0, 0, 1, 0, 0, 0, 1]\nD: [0, 0, 0, 0, 0]\n"
                                     "R: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n");
  ExpectError([&] { ReadRosCameraInfoPair(tmp.path() / "bad.yaml", tmp.path() / "right.yaml", truth.mast); },
              "bad.yaml: missing field 'projection_matrix'");
  WriteText(tmp.path() / "fisheye.yaml", "width: 640\nheight: 480\ndistortion_model: equidistant\n");
  ExpectError([&] { ReadRosCameraInfoPair(tmp.path() / "fisheye.yaml", tmp.path() / "right.yaml", truth.mast); },
              "fisheye.yaml.distortion_model: 'equidistant' is not supported");
  // The files in the wrong order: the left P carries the baseline.
  ExpectError([&] { ReadRosCameraInfoPair(tmp.path() / "right.yaml", tmp.path() / "left.yaml", truth.mast); },
              "right.yaml.projection_matrix");
}

TEST(ReadKalibrCamchain, AgreesWithTheRigItDescribes) {
  util::ScopedTempDir tmp;
  StereoRig truth = testing::PaperRig();
  truth.left.distortion.resize(4);  // radtan: k1 k2 r1 r2
  truth.right.distortion.resize(4);
  auto camera = [&](const CameraIntrinsics& c) {
    return "  camera_model: pinhole\n  distortion_coeffs: " + List(c.distortion) +
           "\n  distortion_model: radtan\n  intrinsics: [" + Num(c.K(0, 0)) + ", " + Num(c.K(1, 1)) + ", " +
           Num(c.K(0, 2)) + ", " + Num(c.K(1, 2)) + "]\n  resolution: [640, 480]\n";
  };
  std::string t = "  T_cn_cnm1:\n";  // Kalibr writes the rows at the key's indentation
  for (int r = 0; r < 3; ++r) {
    t += "  - [" + Num(truth.right_from_left_R(r, 0)) + ", " + Num(truth.right_from_left_R(r, 1)) + ", " +
         Num(truth.right_from_left_R(r, 2)) + ", " + Num(truth.right_from_left_t_m(r)) + "]\n";
  }
  t += "  - [0.0, 0.0, 0.0, 1.0]\n";
  WriteText(tmp.path() / "camchain.yaml", "cam0:\n  cam_overlaps: [1]\n" + camera(truth.left) +
                                              "  rostopic: /cam0/image_raw\ncam1:\n" + t + "  cam_overlaps: [0]\n" +
                                              camera(truth.right) + "  rostopic: /cam1/image_raw\n");
  const StereoRig rig = ReadKalibrCamchain(tmp.path() / "camchain.yaml", truth.mast);
  EXPECT_TRUE(rig.left.K.isApprox(truth.left.K, 1e-8));
  EXPECT_EQ(rig.right.distortion.size(), 4u);
  EXPECT_NEAR(rig.right.distortion[1], truth.right.distortion[1], 1e-9);
  EXPECT_LT((rig.right_from_left_R - truth.right_from_left_R).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_LT((rig.right_from_left_t_m - truth.right_from_left_t_m).norm(), 1e-8);
  EXPECT_FALSE(rig.rectified.has_value());
  // Round trip through the rig file.
  WriteStereoRig(tmp.path() / "rig.json", rig);
  EXPECT_TRUE(ReadStereoRig(tmp.path() / "rig.json").right_from_left_R.isApprox(rig.right_from_left_R, 1e-15));

  WriteText(tmp.path() / "equi.yaml", "cam0:\n  camera_model: pinhole\n  distortion_model: equidistant\n");
  ExpectError([&] { ReadKalibrCamchain(tmp.path() / "equi.yaml", truth.mast); },
              "equi.yaml.cam0.distortion_model: 'equidistant' is not supported");
  WriteText(tmp.path() / "nocam1.yaml", "cam0:\n" + camera(truth.left));
  ExpectError([&] { ReadKalibrCamchain(tmp.path() / "nocam1.yaml", truth.mast); },
              "nocam1.yaml: missing field 'cam1'");
}

// Middlebury 2014's calib.txt for Adirondack at quarter size (MiddEval3 trainingQ).
constexpr const char* kMiddleburyCalib =
    "cam0=[1038.018 0 322.037; 0 1038.018 243.393; 0 0 1]\n"
    "cam1=[1038.018 0 375.308; 0 1038.018 243.393; 0 0 1]\n"
    "doffs=53.271\n"
    "baseline=176.252\n"
    "width=718\n"
    "height=496\n"
    "ndisp=73\n"
    "isint=0\n"
    "vmin=8\n"
    "vmax=65\n"
    "dyavg=0\n"
    "dymax=0\n";

TEST(ReadMiddleburyCalib, IsARectifiedRigWhoseXyzHonoursDoffs) {
  util::ScopedTempDir tmp;
  WriteText(tmp.path() / "calib.txt", kMiddleburyCalib);
  const StereoRig rig = ReadMiddleburyCalib(tmp.path() / "calib.txt", MastPose{});
  EXPECT_EQ(rig.width_px, 718);
  // The same file with a byte-order mark, as an editor may save it.
  WriteText(tmp.path() / "bom.txt", std::string("\xEF\xBB\xBF") + kMiddleburyCalib);
  EXPECT_EQ(ReadMiddleburyCalib(tmp.path() / "bom.txt", MastPose{}).width_px, 718);
  EXPECT_EQ(rig.height_px, 496);
  EXPECT_NEAR(rig.BaselineM(), 0.176252, 1e-12);
  ASSERT_TRUE(rig.rectified.has_value());
  EXPECT_EQ(rig.rectified->width_px, 718);
  // Middlebury's depth: Z = baseline f / (d + doffs), in the rectified left (= camera) frame.
  cv::Mat disparity(496, 718, CV_32FC1, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  disparity.at<float>(200, 300) = 40.0f;
  const cv::Mat xyz = TriangulateDisparity(rig, disparity, ReferenceImage::kLeft);
  const cv::Vec3f p = xyz.at<cv::Vec3f>(200, 300);
  const Eigen::Vector3d in_left = rig.VehicleFromLeft().inverse() * Eigen::Vector3d(p[0], p[1], p[2]);
  const double z = 0.176252 * 1038.018 / (40.0 + 53.271);
  EXPECT_NEAR(in_left.z(), z, 1e-5 * z);
  EXPECT_NEAR(in_left.x(), (300 - 322.037) * z / 1038.018, 1e-5);
  // Round trip through the rig file; the rectified rig is used as it is.
  WriteStereoRig(tmp.path() / "rig.json", rig);
  const StereoRig back = ReadStereoRig(tmp.path() / "rig.json");
  EXPECT_TRUE(back.rectified->P_right.isApprox(rig.rectified->P_right, 1e-15));

  std::string text = kMiddleburyCalib;
  WriteText(tmp.path() / "nodoffs.txt", text.substr(0, text.find("doffs")) + text.substr(text.find("baseline")));
  ExpectError([&] { ReadMiddleburyCalib(tmp.path() / "nodoffs.txt", MastPose{}); },
              "nodoffs.txt: missing field 'doffs'");
  text.replace(text.find("53.271"), 6, "50.000");
  WriteText(tmp.path() / "baddoffs.txt", text);
  ExpectError([&] { ReadMiddleburyCalib(tmp.path() / "baddoffs.txt", MastPose{}); }, "baddoffs.txt: doffs: 50");
  WriteText(tmp.path() / "badnumber.txt", "cam0=[1038.018 0 322.037; 0 1038.018 x; 0 0 1]\n");
  ExpectError([&] { ReadMiddleburyCalib(tmp.path() / "badnumber.txt", MastPose{}); },
              "badnumber.txt:1: cam0: 'x' is not a number");
}

// KITTI raw data's calib_cam_to_cam.txt (2011_09_26), the lines of cameras 0, 2 and 3.
constexpr const char* kKittiCalib =
    "calib_time: 09-Jan-2012 13:57:47\n"
    "corner_dist: 9.950000e-02\n"
    "S_00: 1.392000e+03 5.120000e+02\n"
    "P_rect_00: 7.215377e+02 0.000000e+00 6.095593e+02 0.000000e+00 0.000000e+00 7.215377e+02 1.728540e+02 "
    "0.000000e+00 0.000000e+00 0.000000e+00 1.000000e+00 0.000000e+00\n"
    "S_rect_02: 1.242000e+03 3.750000e+02\n"
    "P_rect_02: 7.215377e+02 0.000000e+00 6.095593e+02 4.485728e+01 0.000000e+00 7.215377e+02 1.728540e+02 "
    "2.163791e-01 0.000000e+00 0.000000e+00 1.000000e+00 2.745884e-03\n"
    "S_rect_03: 1.242000e+03 3.750000e+02\n"
    "P_rect_03: 7.215377e+02 0.000000e+00 6.095593e+02 -3.395242e+02 0.000000e+00 7.215377e+02 1.728540e+02 "
    "2.199936e+00 0.000000e+00 0.000000e+00 1.000000e+00 2.729905e-03\n";

TEST(ReadKittiCalib, IsTheRectifiedColourPair) {
  util::ScopedTempDir tmp;
  WriteText(tmp.path() / "calib_cam_to_cam.txt", kKittiCalib);
  const StereoRig rig = ReadKittiCalib(tmp.path() / "calib_cam_to_cam.txt", MastPose{}, KittiPair::kColour);
  EXPECT_EQ(rig.width_px, 1242);
  EXPECT_EQ(rig.height_px, 375);
  // The x offset of the centres K^-1 P[:, 3]: (P[0][3] - cx P[2][3]) / f for each camera.
  const double x2 = (44.85728 - 609.5593 * 2.745884e-03) / 721.5377;
  const double x3 = (-339.5242 - 609.5593 * 2.729905e-03) / 721.5377;
  EXPECT_NEAR(rig.BaselineM(), x2 - x3, 1e-12);
  // KITTI's 0.54 m stereo baseline, (44.85728 + 339.5242) / 721.5377 = 0.53273 m the usual way.
  EXPECT_NEAR(rig.BaselineM(), (44.85728 + 339.5242) / 721.5377, 1e-4);
  ASSERT_TRUE(rig.rectified.has_value());
  EXPECT_EQ(rig.rectified->P_left(0, 2), 609.5593);
  EXPECT_NEAR(rig.rectified->P_right(0, 3), -721.5377 * rig.BaselineM(), 1e-9);
  ASSERT_EQ(rig.notes.size(), 1u);
  EXPECT_NE(rig.notes[0].find("dropped"), std::string::npos);

  std::string text = kKittiCalib;
  text.replace(text.find("-3.395242e+02"), 13, "-3.395242e+0x");
  WriteText(tmp.path() / "bad.txt", text);
  ExpectError([&] { ReadKittiCalib(tmp.path() / "bad.txt", MastPose{}, KittiPair::kColour); },
              "bad.txt:8: P_rect_03: '-3.395242e+0x' is not a number");
  text = kKittiCalib;
  WriteText(tmp.path() / "no3.txt", text.substr(0, text.find("S_rect_03")));
  ExpectError([&] { ReadKittiCalib(tmp.path() / "no3.txt", MastPose{}, KittiPair::kColour); }, "no3.txt: missing field 'P_rect_03'");
}

TEST(ReadKittiCalib, ReadsTheGreyPairOfTheRawFormat) {
  util::ScopedTempDir tmp;
  std::string text = kKittiCalib;
  // The raw format's grey pair: P_rect_00 (camera 0 itself) and P_rect_01.
  text += "S_rect_00: 1.242000e+03 3.750000e+02\n"
          "P_rect_01: 7.215377e+02 0.000000e+00 6.095593e+02 -3.875744e+02 0.000000e+00 7.215377e+02 1.728540e+02 "
          "0.000000e+00 0.000000e+00 0.000000e+00 1.000000e+00 0.000000e+00\n";
  WriteText(tmp.path() / "calib_cam_to_cam.txt", text);
  const StereoRig rig = ReadKittiCalib(tmp.path() / "calib_cam_to_cam.txt", MastPose{1.65, 0, 0, 0}, KittiPair::kGrey);
  EXPECT_NEAR(rig.BaselineM(), 387.5744 / 721.5377, 1e-12);
  EXPECT_EQ(rig.width_px, 1242);
  EXPECT_EQ(rig.mast.height_m, 1.65);
  EXPECT_TRUE(rig.notes.empty());  // camera 0 and 1 share their rows exactly: nothing dropped
}

TEST(ReadKittiCalib, ReadsTheOdometryCalibTxtWithTheSizeGivenOrFromTheSequence) {
  util::ScopedTempDir tmp;
  const std::string calib =
      "P0: 7.070912e+02 0.000000e+00 6.018873e+02 0.000000e+00 0.000000e+00 7.070912e+02 1.831104e+02 0.000000e+00 "
      "0.000000e+00 0.000000e+00 1.000000e+00 0.000000e+00\n"
      "P1: 7.070912e+02 0.000000e+00 6.018873e+02 -3.798145e+02 0.000000e+00 7.070912e+02 1.831104e+02 0.000000e+00 "
      "0.000000e+00 0.000000e+00 1.000000e+00 0.000000e+00\n"
      "P2: 7.070912e+02 0.000000e+00 6.018873e+02 4.688783e+01 0.000000e+00 7.070912e+02 1.831104e+02 1.178601e-01 "
      "0.000000e+00 0.000000e+00 1.000000e+00 6.203223e-03\n"
      "P3: 7.070912e+02 0.000000e+00 6.018873e+02 -3.334597e+02 0.000000e+00 7.070912e+02 1.831104e+02 1.930130e+00 "
      "0.000000e+00 0.000000e+00 1.000000e+00 3.318498e-03\n"
      "Tr: -1.857739e-03 -9.999659e-01 -8.039975e-03 -4.784029e-03 -6.481465e-03 8.051860e-03 -9.999466e-01 "
      "-7.337429e-02 9.999773e-01 -1.805528e-03 -6.496203e-03 -3.339968e-01\n";
  WriteText(tmp.path() / "calib.txt", calib);
  const StereoRig grey =
      ReadKittiCalib(tmp.path() / "calib.txt", MastPose{}, KittiPair::kGrey, std::pair<int, int>{1226, 370});
  EXPECT_NEAR(grey.BaselineM(), 379.8145 / 707.0912, 1e-12);  // KITTI's baseline = -P1[0][3] / P1[0][0]
  EXPECT_EQ(grey.width_px, 1226);
  const StereoRig colour =
      ReadKittiCalib(tmp.path() / "calib.txt", MastPose{}, KittiPair::kColour, std::pair<int, int>{1226, 370});
  // The colour cameras' centres K^-1 P[:, 3] (their z offsets move the x ones by a few mm).
  const double x2 = (46.88783 - 601.8873 * 6.203223e-03) / 707.0912;
  const double x3 = (-333.4597 - 601.8873 * 3.318498e-03) / 707.0912;
  EXPECT_NEAR(colour.BaselineM(), x2 - x3, 1e-12);
  // Without a size: the first image of the pair's folder beside calib.txt; with neither, a
  // usage error naming the option.
  EXPECT_THROW(ReadKittiCalib(tmp.path() / "calib.txt", MastPose{}, KittiPair::kGrey), std::invalid_argument);
  fs::create_directories(tmp.path() / "image_0");
  cv::imwrite((tmp.path() / "image_0" / "000000.png").string(), cv::Mat(370, 1226, CV_8UC1, cv::Scalar(9)));
  const StereoRig sized = ReadKittiCalib(tmp.path() / "calib.txt", MastPose{}, KittiPair::kGrey);
  EXPECT_EQ(sized.width_px, 1226);
  EXPECT_EQ(sized.height_px, 370);
}

TEST(RunRigImport, WritesTheRigAndASummaryWithItsNotes) {
  util::ScopedTempDir tmp;
  WriteText(tmp.path() / "calib_cam_to_cam.txt", kKittiCalib);
  RigImportOptions options;
  options.format = RigFormatNames().at("kitti");
  options.files = {tmp.path() / "calib_cam_to_cam.txt"};
  const RigImportRun run = RunRigImport(options, tmp.path() / "out" / "rig.json", tmp.path() / "out" / "summary.json");
  EXPECT_NEAR(ReadStereoRig(run.rig_path).BaselineM(), run.rig.BaselineM(), 1e-15);
  std::ifstream in(run.summary_path);
  const nlohmann::json summary = nlohmann::json::parse(in);
  EXPECT_EQ(summary["mode"], "import");
  EXPECT_EQ(summary["inputs"]["format"], "kitti");
  EXPECT_EQ(summary["notes"].size(), 1u);
  EXPECT_EQ(summary["rig"]["rectified"], true);
  // Usage errors: the wrong number of files; opencv without its image size.
  options.files.push_back(options.files[0]);
  ExpectError<std::invalid_argument>([&] { ImportRig(options); }, "--from kitti: expected 1 file");
  options.format = RigFormat::kOpenCv;
  ExpectError<std::invalid_argument>([&] { ImportRig(options); }, "--image-size");
}

}  // namespace
}  // namespace lunarnav::calib
