#include "calib/stereo_rig_io.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>

#include <opencv2/core.hpp>

#include "calib/opencv_calibration_files.h"
#include "calib/paper_rig.h"
#include "util/errors.h"
#include "util/testing.h"

namespace lunarnav::calib {
namespace {

void ExpectSameRig(const StereoRig& a, const StereoRig& b) {
  EXPECT_EQ(a.width_px, b.width_px);
  EXPECT_TRUE(a.left.K.isApprox(b.left.K, 1e-15));
  EXPECT_TRUE(a.right.K.isApprox(b.right.K, 1e-15));
  EXPECT_EQ(a.left.distortion, b.left.distortion);
  EXPECT_TRUE(a.right_from_left_R.isApprox(b.right_from_left_R, 1e-15));
  EXPECT_TRUE(a.right_from_left_t_m.isApprox(b.right_from_left_t_m, 1e-15));
  EXPECT_EQ(a.mast.tilt_deg, b.mast.tilt_deg);
  ASSERT_EQ(a.rectified.has_value(), b.rectified.has_value());
  if (a.rectified) {
    EXPECT_TRUE(a.rectified->P_right.isApprox(b.rectified->P_right, 1e-15));
  }
}

TEST(StereoRigJson, RoundTrips) {
  util::ScopedTempDir tmp;
  StereoRig rig = testing::PaperRig();
  RectifiedGeometry g;
  g.P_left << 700, 0, 320, 0, 0, 700, 240, 0, 0, 0, 1, 0;
  g.P_right << 700, 0, 320, -630, 0, 700, 240, 0, 0, 0, 1, 0;
  g.width_px = 640;
  g.height_px = 480;
  rig.rectified = g;
  WriteStereoRig(tmp.path() / "rig.json", rig);
  ExpectSameRig(ReadStereoRig(tmp.path() / "rig.json"), rig);
}

TEST(StereoRigJson, NamesUnknownAndMissingFields) {
  auto expect_error = [](nlohmann::json j, const std::string& words) {
    try {
      StereoRigFromJson(j, "rig.json");
      ADD_FAILURE() << "accepted: " << words;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  const nlohmann::json good = StereoRigToJson(testing::PaperRig());
  nlohmann::json j = good;
  j["left"]["focal"] = 740;
  expect_error(j, "rig.json.left: unknown field 'focal'");
  j = good;
  j.erase("right_from_left");
  expect_error(j, "rig.json: missing field 'right_from_left'");
  j = good;
  j["left"]["K"][1] = {0, 740};
  expect_error(j, "rig.json.left.K: expected 3 rows of 3");
  j = good;
  j["format"] = "lunarnav.rig/2";
  expect_error(j, "rig.json.format");
  // The translation: three numbers, neither fewer (found by fuzzing: an index error escaped
  // as an internal error) nor more, nor anything else.
  for (const nlohmann::json& t : {nlohmann::json{0.0, 0.001}, nlohmann::json{0.5, 0.0, 0.0, 1.0},
                                  nlohmann::json(0.5), nlohmann::json{{"x", 0.5}}}) {
    j = good;
    j["right_from_left"]["t_m"] = t;
    expect_error(j, "rig.json.right_from_left.t_m: expected 3 numbers");
  }
}

// A rotation as a paper prints it: every element rounded to `digits` significant digits.
Eigen::Matrix3d Printed(const Eigen::Matrix3d& r, int digits) {
  Eigen::Matrix3d out;
  for (int i = 0; i < 9; ++i) {
    char text[64];
    std::snprintf(text, sizeof(text), "%.*g", digits, r(i));
    out(i) = std::strtod(text, nullptr);
  }
  return out;
}

TEST(StereoRigJson, AcceptsARotationPrintedToSixDigitsAndRefusesOneOffByAHundredth) {
  StereoRig truth = testing::PaperRig();
  // A rotation with every element non-trivial (about 3 deg about a skew axis).
  truth.right_from_left_R = Eigen::AngleAxisd(0.05, Eigen::Vector3d(0.3, 0.9, 0.2).normalized()).toRotationMatrix();
  nlohmann::json j = StereoRigToJson(truth);
  const Eigen::Matrix3d printed = Printed(truth.right_from_left_R, 6);
  ASSERT_GT((printed.transpose() * printed - Eigen::Matrix3d::Identity()).norm(), 1e-7);  // not exact
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) j["right_from_left"]["R"][r][c] = printed(r, c);
  }
  const StereoRig read = StereoRigFromJson(j, "paper.json");
  const Eigen::Matrix3d& r = read.right_from_left_R;
  EXPECT_LT((r.transpose() * r - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  EXPECT_NEAR(r.determinant(), 1.0, 1e-12);
  // The nearest rotation is the true one to the printing's round-off (5e-7 per element).
  EXPECT_LT((r - truth.right_from_left_R).cwiseAbs().maxCoeff(), 1e-6);
  ASSERT_EQ(read.notes.size(), 1u);
  EXPECT_NE(read.notes[0].find("paper.json.right_from_left.R"), std::string::npos) << read.notes[0];
  EXPECT_NE(read.notes[0].find("nearest rotation"), std::string::npos) << read.notes[0];
  // An exact rotation is taken as it is, with no note.
  EXPECT_TRUE(StereoRigFromJson(StereoRigToJson(truth), "exact.json").notes.empty());

  // One element off by 1e-2: not a rotation, whatever the printing.
  j["right_from_left"]["R"][0][1] = printed(0, 1) + 1e-2;
  try {
    StereoRigFromJson(j, "paper.json");
    ADD_FAILURE() << "accepted a matrix 1e-2 from a rotation";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("paper.json.right_from_left.R: not a rotation matrix"), std::string::npos)
        << e.what();
  }
}

TEST(StereoRigJson, RepairsPrintedRectifiedRotationsAndProjections) {
  StereoRig rig = testing::PaperRig();
  RectifiedGeometry g;
  g.rect_from_left = Printed(Eigen::AngleAxisd(0.02, Eigen::Vector3d(0.2, 1, 0).normalized()).toRotationMatrix(), 6);
  g.rect_from_right = Printed(Eigen::AngleAxisd(0.03, Eigen::Vector3d(0.1, 1, 0.1).normalized()).toRotationMatrix(), 6);
  g.P_left << 712.345, 0, 320, 0, 0, 712.345, 240.5, 0, 0, 0, 1, 0;
  // The right's focal length printed from another rounding of the same value.
  g.P_right << 712.3450001, 0, 320, -641.1, 0, 712.345, 240.5, 0, 0, 0, 1, 0;
  g.width_px = 640;
  g.height_px = 480;
  rig.rectified = g;
  const StereoRig read = StereoRigFromJson(StereoRigToJson(rig), "rig.json");
  EXPECT_EQ(read.notes.size(), 3u);
  EXPECT_EQ(read.rectified->P_right(0, 0), read.rectified->P_left(0, 0));
  const Eigen::Matrix3d& r = read.rectified->rect_from_right;
  EXPECT_LT((r.transpose() * r - Eigen::Matrix3d::Identity()).norm(), 1e-12);
}

TEST(ReadOpenCvCalibration, AgreesWithTheJsonItProduces) {
  // intrinsics.yml and extrinsics.yml as OpenCV's stereo_calib sample writes them, with T in
  // units of 10 cm squares.
  util::ScopedTempDir tmp;
  const StereoRig truth = testing::PaperRig();
  testing::WriteOpenCvCalibration(tmp.path(), truth, 0.1);
  const StereoRig imported = ReadOpenCvCalibration(tmp.path() / "intrinsics.yml", tmp.path() / "extrinsics.yml",
                                                   640, 480, 0.1, truth.mast);
  EXPECT_TRUE(imported.right_from_left_t_m.isApprox(truth.right_from_left_t_m, 1e-12));
  WriteStereoRig(tmp.path() / "rig.json", imported);
  ExpectSameRig(ReadStereoRig(tmp.path() / "rig.json"), imported);
  EXPECT_THROW(ReadOpenCvCalibration(tmp.path() / "missing.yml", tmp.path() / "extrinsics.yml", 640, 480, 0.1,
                                     truth.mast),
               InputError);
  // A zero focal length is the intrinsics file's fault, and its message names that file.
  StereoRig flat = truth;
  flat.right.K(0, 0) = 0;
  testing::WriteOpenCvCalibration(tmp.path(), flat, 0.1);
  try {
    ReadOpenCvCalibration(tmp.path() / "intrinsics.yml", tmp.path() / "extrinsics.yml", 640, 480, 0.1, truth.mast);
    ADD_FAILURE() << "accepted a zero focal length";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("intrinsics.yml: M2.K: focal lengths must be positive"), std::string::npos)
        << e.what();
  }
}

TEST(ReadOpenCvCalibration, ReadsTheXmlFormToo) {
  util::ScopedTempDir tmp;
  const StereoRig truth = testing::PaperRig();
  testing::WriteOpenCvCalibration(tmp.path(), truth, 0.1);
  for (const char* name : {"intrinsics", "extrinsics"}) {  // the same nodes, written as XML by OpenCV
    cv::FileStorage yml((tmp.path() / (std::string(name) + ".yml")).string(), cv::FileStorage::READ);
    cv::FileStorage xml((tmp.path() / (std::string(name) + ".xml")).string(), cv::FileStorage::WRITE);
    for (const char* key : {"M1", "D1", "M2", "D2", "R", "T"}) {
      cv::Mat m;
      yml[key] >> m;
      if (!m.empty()) xml << key << m;
    }
  }
  const StereoRig xml = ReadOpenCvCalibration(tmp.path() / "intrinsics.xml", tmp.path() / "extrinsics.xml", 640,
                                              480, 0.1, truth.mast);
  const StereoRig yml = ReadOpenCvCalibration(tmp.path() / "intrinsics.yml", tmp.path() / "extrinsics.yml", 640,
                                              480, 0.1, truth.mast);
  ExpectSameRig(xml, yml);
}

// An XML file cut short is refused with the file's name, wherever the cut falls: OpenCV's
// parser crashed (a null pointer) on one cut just after an attribute's '=' (`<?xml
// version=`, found by the rig_import fuzz target).
TEST(ReadOpenCvCalibration, AnXmlFileCutShortIsRefusedWhereverTheCut) {
  util::ScopedTempDir tmp;
  const StereoRig truth = testing::PaperRig();
  testing::WriteOpenCvCalibration(tmp.path(), truth, 0.1);
  std::string whole;
  {
    cv::FileStorage yml((tmp.path() / "intrinsics.yml").string(), cv::FileStorage::READ);
    cv::FileStorage xml(".xml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
    for (const char* key : {"M1", "D1", "M2", "D2"}) {
      cv::Mat m;
      yml[key] >> m;
      xml << key << m;
    }
    whole = xml.releaseAndGetString();
  }
  ASSERT_EQ(whole.rfind("<?xml version=", 0), 0u) << whole.substr(0, 40);
  const std::filesystem::path cut = tmp.path() / "cut.xml";
  int refused = 0;
  for (std::size_t n = 1; n < whole.size() - 2; n += (n < 200 ? 1 : 7)) {  // every byte of the head
    if (whole.find_last_not_of(" \t\r\n", n - 1) == std::string::npos) continue;
    std::FILE* f = std::fopen(cut.string().c_str(), "wb");
    ASSERT_NE(f, nullptr);
    std::fwrite(whole.data(), 1, n, f);
    std::fclose(f);
    try {
      ReadOpenCvCalibration(cut, tmp.path() / "extrinsics.yml", 640, 480, 0.1, truth.mast);
      ADD_FAILURE() << "accepted the file cut after " << n << " bytes";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("cut.xml"), std::string::npos) << e.what();
      ++refused;
    }
  }
  EXPECT_GT(refused, 200);
}

// Texts OpenCV's parser looped forever on (`%YAML:1.0`, ` s: 0`, `Jan-x`, `c`: the rig_import
// fuzz target) never reach it: yaml-cpp reads them, and what they lack (a matrix) is bad input
// naming the file. Files as OpenCV writes them, with a matrix's data over several lines, pass.
TEST(ReadOpenCvCalibration, TextsOpenCvsParserLoopedOnAreRefusedNamingTheFile) {
  util::ScopedTempDir tmp;
  const StereoRig truth = testing::PaperRig();
  testing::WriteOpenCvCalibration(tmp.path(), truth, 0.1);
  const std::filesystem::path bad = tmp.path() / "bad.yml";
  for (const char* text : {"%YAML:1.0\n s: 0\nJan-x\nc\n", "%YAML:1.0\n---\nM1: 3\nstray words\n"}) {
    std::FILE* f = std::fopen(bad.string().c_str(), "w");
    ASSERT_NE(f, nullptr);
    std::fputs(text, f);
    std::fclose(f);
    try {
      ReadOpenCvCalibration(bad, tmp.path() / "extrinsics.yml", 640, 480, 0.1, truth.mast);
      ADD_FAILURE() << "accepted " << text;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("bad.yml: "), std::string::npos) << e.what();
    }
  }
  // A flow sequence continued over lines (indented, as OpenCV writes it), quoted colons and
  // comments pass.
  std::FILE* f = std::fopen((tmp.path() / "wrapped.yml").string().c_str(), "w");
  ASSERT_NE(f, nullptr);
  std::fputs("%YAML:1.0\n---\n# written by hand\ncalibration_time: \"09-Jan-2012 13:57:47\"\n"
             "M1: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 700., 0., 320.,\n"
             "       0., 700., 240.,\n       0., 0., 1. ]\nD1: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n"
             "   data: [ 0., 0., 0., 0., 0. ]\nM2: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
             "   data: [ 700., 0., 320., 0., 700., 240., 0., 0., 1. ]\nD2: !!opencv-matrix\n   rows: 1\n"
             "   cols: 5\n   dt: d\n   data: [ 0., 0., 0., 0., 0. ]\n",
             f);
  std::fclose(f);
  const StereoRig rig = ReadOpenCvCalibration(tmp.path() / "wrapped.yml", tmp.path() / "extrinsics.yml", 640, 480,
                                              0.1, truth.mast);
  EXPECT_EQ(rig.left.K(1, 2), 240.0);
}

// Writes extrinsics.yml with R as given (a YAML opencv-matrix body) and a valid T.
void WriteExtrinsics(const std::filesystem::path& dir, const std::string& r_body) {
  std::FILE* f = std::fopen((dir / "extrinsics.yml").string().c_str(), "w");
  ASSERT_NE(f, nullptr);
  std::fprintf(f, "%%YAML:1.0\n---\nR: !!opencv-matrix\n%s\nT: !!opencv-matrix\n   rows: 3\n   cols: 1\n"
               "   dt: d\n   data: [ -1., 0., 0. ]\n", r_body.c_str());
  std::fclose(f);
}

std::string ImportError(const std::filesystem::path& dir) {
  try {
    ReadOpenCvCalibration(dir / "intrinsics.yml", dir / "extrinsics.yml", 640, 480, 0.1, MastPose{});
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(ReadOpenCvCalibration, RefusesAMatrixHeaderBeforeAllocatingIt) {
  // A header claiming 40000 x 50000 doubles (16 GB) over three values: OpenCV's own reader
  // allocated it before noticing (a fuzz finding); it is bad input, named, without memory.
  util::ScopedTempDir tmp;
  testing::WriteOpenCvCalibration(tmp.path(), testing::PaperRig(), 0.1);
  WriteExtrinsics(tmp.path(), "   rows: 40000\n   cols: 50000\n   dt: d\n   data: [ 1., 0., 0. ]");
  std::string error = ImportError(tmp.path());
  EXPECT_NE(error.find("extrinsics.yml: matrix 'R': 40000 x 50000 is not the size"), std::string::npos) << error;
  WriteExtrinsics(tmp.path(), "   rows: -3\n   cols: 3\n   dt: d\n   data: [ 1., 0., 0. ]");
  EXPECT_NE(ImportError(tmp.path()).find("matrix 'R': -3 x 3"), std::string::npos);
  WriteExtrinsics(tmp.path(), "   rows: 3\n   cols: 3\n   dt: d\n   data: [ 1., 0., 0. ]");
  error = ImportError(tmp.path());
  EXPECT_NE(error.find("3 x 3 needs 9 values, data has 3"), std::string::npos) << error;
  WriteExtrinsics(tmp.path(), "   rows: 3\n   cols: 3\n   dt: d\n   data: [ 1., 0., 0., 0., 1., 0., 0., 0., x ]");
  error = ImportError(tmp.path());
  EXPECT_NE(error.find("value 9 is not a number"), std::string::npos) << error;
}

TEST(ReadOpenCvCalibration, ReadsValuesAsWrittenWhateverTheDeclaredType) {
  // `dt: u` (8-bit) over a focal length of 800: OpenCV's reader saturated it to 255; the
  // calibration means 800.
  util::ScopedTempDir tmp;
  const StereoRig truth = testing::PaperRig();
  testing::WriteOpenCvCalibration(tmp.path(), truth, 0.1);
  WriteExtrinsics(tmp.path(), "   rows: 3\n   cols: 3\n   dt: u\n   data: [ 1, 0, 0, 0, 1, 0, 0, 0, 1 ]");
  std::FILE* f = std::fopen((tmp.path() / "intrinsics.yml").string().c_str(), "w");
  ASSERT_NE(f, nullptr);
  std::fprintf(f, "%%YAML:1.0\n---\n");
  for (const char* k : {"M1", "M2"}) {
    std::fprintf(f, "%s: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: u\n   data: [ 800, 0, 320, 0, 800, 240, 0, 0, 1 ]\n", k);
  }
  std::fclose(f);
  const StereoRig rig = ReadOpenCvCalibration(tmp.path() / "intrinsics.yml", tmp.path() / "extrinsics.yml", 640,
                                              480, 0.1, truth.mast);
  EXPECT_EQ(rig.left.K(0, 0), 800.0);
  EXPECT_EQ(rig.right.K(1, 1), 800.0);
}

}  // namespace
}  // namespace lunarnav::calib
