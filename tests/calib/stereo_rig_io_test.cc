#include "calib/stereo_rig_io.h"

#include <gtest/gtest.h>

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
