// Integration tests of the rig-check tool with the shipped Ratler vehicle file.
#include <gtest/gtest.h>

#include <fstream>

#include <nlohmann/json.hpp>

#include "calib/paper_rig.h"
#include "calib/stereo_rig_io.h"
#include "integration/run_tool.h"
#include "io/json_io.h"
#include "util/testing.h"

namespace lunarnav {
namespace {
namespace fs = std::filesystem;
using testing::RunTool;

TEST(RigCheck, ReproducesThePapersNumbersAndReportsTheFailingRequirement) {
  util::ScopedTempDir tmp;
  calib::WriteStereoRig(tmp.path() / "rig.json", calib::testing::PaperRig());
  const std::string vehicle = util::TestDataPath("vehicles/ratler.json").string();
  const auto run = RunTool("rig-check",
                           {"--rig", (tmp.path() / "rig.json").string(), "--vehicle", vehicle, "--json",
                            (tmp.path() / "check.json").string()},
                           tmp.path());
  // The paper-like rig's 740 px lenses see too narrow a strip at the lookahead distance.
  EXPECT_EQ(run.exit_code, 4) << run.stderr_text;
  EXPECT_EQ(run.ErrorLines(), 0);
  const nlohmann::json j = io::ReadJson(tmp.path() / "check.json");
  EXPECT_EQ(j["tool"], "rig-check");
  EXPECT_EQ(j["options"]["gravity"], "earth");
  EXPECT_NEAR(j["stopping_distance_m"].get<double>(), 1.5, 0.001);  // sec. 3.1
  ASSERT_EQ(j["checks"].size(), 4u);
  EXPECT_EQ(j["checks"][1]["key"], "camera_height");
  EXPECT_NEAR(j["checks"][1]["limit"].get<double>(), 0.66, 0.005);  // "at least 66 cm"
  EXPECT_EQ(j["checks"][2]["key"], "fov_width");
  EXPECT_EQ(j["checks"][2]["pass"], false);
  EXPECT_EQ(j["all_pass"], false);
}

TEST(RigCheck, AllPassIsExitZeroAndTheMoonLengthensTheStop) {
  util::ScopedTempDir tmp;
  calib::StereoRig wide = calib::testing::PaperRig();
  for (calib::CameraIntrinsics* c : {&wide.left, &wide.right}) {
    c->K << 250, 0, 319.5, 0, 250, 239.5, 0, 0, 1;  // a wide-angle lens (104 deg across)
    c->distortion.clear();
  }
  calib::WriteStereoRig(tmp.path() / "rig.json", wide);
  const std::string vehicle = util::TestDataPath("vehicles/ratler.json").string();
  const std::string rig = (tmp.path() / "rig.json").string(), out = (tmp.path() / "moon.json").string();
  EXPECT_EQ(RunTool("rig-check", {"--rig", rig, "--vehicle", vehicle, "-q"}, tmp.path()).exit_code, 0);
  EXPECT_EQ(RunTool("rig-check", {"--rig", rig, "--vehicle", vehicle, "--gravity", "moon", "--json", out}, tmp.path())
                .exit_code,
            0);
  EXPECT_NEAR(io::ReadJson(out)["stopping_distance_m"].get<double>(), 2.003, 0.001);
}

TEST(RigCheck, BadInputsAndOptions) {
  util::ScopedTempDir tmp;
  calib::WriteStereoRig(tmp.path() / "rig.json", calib::testing::PaperRig());
  const std::string rig = (tmp.path() / "rig.json").string();
  const std::string vehicle = util::TestDataPath("vehicles/ratler.json").string();
  std::ofstream(tmp.path() / "bad.json") << R"({"format": "lunarnav.vehicle/1", "max_speed_m_s": 0.7})";
  const auto bad = RunTool("rig-check", {"--rig", rig, "--vehicle", (tmp.path() / "bad.json").string()}, tmp.path());
  EXPECT_EQ(bad.exit_code, 3);
  EXPECT_EQ(bad.ErrorLines(), 1);
  EXPECT_NE(bad.stderr_text.find("missing field"), std::string::npos) << bad.stderr_text;
  EXPECT_EQ(RunTool("rig-check", {"--rig", rig, "--vehicle", vehicle, "--gravity", "mars"}, tmp.path()).exit_code, 2);
  EXPECT_EQ(RunTool("rig-check", {"--rig", rig}, tmp.path()).exit_code, 2);
  EXPECT_EQ(RunTool("rig-check", {"--rig", (tmp.path() / "none.json").string(), "--vehicle", vehicle}, tmp.path())
                .exit_code,
            3);
}

}  // namespace
}  // namespace lunarnav
