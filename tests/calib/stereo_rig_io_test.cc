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
}

}  // namespace
}  // namespace lunarnav::calib
