#include "mapping/frame_poses.h"

#include <cmath>

#include <gtest/gtest.h>

#include "io/atomic_file.h"
#include "positioning/trajectory_io.h"
#include "util/errors.h"
#include "util/testing.h"

namespace lunarnav::mapping {
namespace {

TEST(ReadPosesCsv, ReadsTheSimulatorsColumnsAndKeepsNonFiniteValuesForLater) {
  util::ScopedTempDir dir;
  const auto path = dir.path() / "poses.csv";
  io::WriteFileAtomic(path,
                      "# comment\nstem,t_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg,fault\n"
                      "000000,0.000,1.5,2.5,0.1,90,1,-2,none\n000001,3.2,nan,2.5,0.1,90,1,-2,none\n");
  const auto poses = ReadPosesCsv(path);
  ASSERT_EQ(poses.size(), 2u);
  EXPECT_EQ(poses[0].stem, "000000");
  EXPECT_DOUBLE_EQ(poses[0].x_m, 1.5);
  EXPECT_NEAR(poses[0].heading_rad, M_PI / 2, 1e-12);
  EXPECT_TRUE(poses[0].IsFinite());
  EXPECT_FALSE(poses[1].IsFinite());
  // Heading 90 deg (east): the vehicle's forward axis (Y) points along world x.
  const Eigen::Vector3d forward = poses[0].WorldFromVehicle().linear() * Eigen::Vector3d::UnitY();
  EXPECT_NEAR(forward.x(), std::cos(M_PI / 180), 1e-9);
  // A spreadsheet's byte-order mark before the header.
  io::WriteFileAtomic(path, "\xEF\xBB\xBFstem,t_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg\n000000,0,1,2,0,0,0,0\n");
  ASSERT_EQ(ReadPosesCsv(path).size(), 1u);
}

TEST(ReadPosesCsv, NamesFileAndLineOfABadRow) {
  util::ScopedTempDir dir;
  const auto path = dir.path() / "poses.csv";
  io::WriteFileAtomic(path, "stem,t_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg\nA,0,1,2,3,4,5,six\n");
  try {
    ReadPosesCsv(path);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("poses.csv:2"), std::string::npos) << e.what();
  }
}

TEST(InterpolateTrajectory, CsvAndTumGiveTheSamePosesBetweenSamples) {
  util::ScopedTempDir dir;
  std::vector<positioning::TrajectorySample> samples;
  for (int k = 0; k <= 10; ++k) {
    positioning::TrajectorySample s;
    s.t_s = k;
    s.x_m = 0.15 * k;
    s.y_m = 0.05 * k * k;
    s.heading_rad = 0.1 * k;
    s.pitch_rad = 0.02;
    s.roll_rad = -0.01 * k;
    samples.push_back(s);
  }
  positioning::WriteTrajectoryCsv(dir.path() / "t.csv", samples);
  positioning::WriteTrajectoryTum(dir.path() / "t.tum", samples);
  FramePose f;
  f.stem = "a";
  f.t_s = 4.5;
  const FramePose a = InterpolateTrajectory(dir.path() / "t.csv", {f}).front();
  const FramePose b = InterpolateTrajectory(dir.path() / "t.tum", {f}).front();
  EXPECT_NEAR(a.x_m, 0.15 * 4.5, 1e-4);
  EXPECT_NEAR(a.y_m, 0.5 * (0.05 * 16 + 0.05 * 25), 1e-4);
  EXPECT_NEAR(a.heading_rad, 0.45, 1e-5);
  EXPECT_TRUE(a.WorldFromVehicle().isApprox(b.WorldFromVehicle(), 1e-6));
  f.t_s = 11;
  EXPECT_THROW(InterpolateTrajectory(dir.path() / "t.csv", {f}), InputError);
}

}  // namespace
}  // namespace lunarnav::mapping
