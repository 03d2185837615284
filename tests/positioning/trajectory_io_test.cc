#include "positioning/trajectory_io.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include <Eigen/Geometry>

#include "util/testing.h"

namespace lunarnav::positioning {
namespace {

TEST(TrajectoryCsv, RoundTrips) {
  util::ScopedTempDir tmp;
  std::vector<TrajectorySample> in(3);
  for (int i = 0; i < 3; ++i) {
    in[i] = {0.1 * i + 1e9, 1.5 * i, -2.25 * i, 0.125 * i, -0.5 + i, 0.05 * i, -0.02 * i, 0.7};
  }
  WriteTrajectoryCsv(tmp.path() / "t.csv", in);
  const std::vector<TrajectorySample> back = ReadTrajectoryCsv(tmp.path() / "t.csv");
  ASSERT_EQ(back.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_DOUBLE_EQ(back[i].t_s, in[i].t_s);
    // Written to 0.1 mm and 0.0001 deg (docs/formats.md).
    EXPECT_NEAR(back[i].y_m, in[i].y_m, 0.5e-4);
    // Headings are written in [0, 360).
    EXPECT_NEAR(std::remainder(back[i].heading_rad - in[i].heading_rad, 2 * M_PI), 0.0, 0.5e-4 * M_PI / 180);
    EXPECT_NEAR(back[i].pitch_rad, in[i].pitch_rad, 0.5e-4 * M_PI / 180);
  }
}

TEST(TrajectoryTum, QuaternionPointsTheBodyXAxisAlongTheHeading) {
  util::ScopedTempDir tmp;
  TrajectorySample p;
  p.heading_rad = M_PI / 2;  // east
  p.pitch_rad = 0.1;         // nose up
  WriteTrajectoryTum(tmp.path() / "t.tum", {p});
  std::ifstream in(tmp.path() / "t.tum");
  std::string line;
  std::getline(in, line);  // comment
  std::getline(in, line);
  std::istringstream row(line);
  double t, x, y, z, qx, qy, qz, qw;
  row >> t >> x >> y >> z >> qx >> qy >> qz >> qw;
  const Eigen::Vector3d forward = Eigen::Quaterniond(qw, qx, qy, qz) * Eigen::Vector3d::UnitX();
  // Quaternions are written with 8 decimals.
  EXPECT_NEAR(forward.x(), std::cos(0.1), 1e-7);  // east
  EXPECT_NEAR(forward.y(), 0.0, 1e-7);
  EXPECT_NEAR(forward.z(), std::sin(0.1), 1e-7);  // up
}

}  // namespace
}  // namespace lunarnav::positioning
