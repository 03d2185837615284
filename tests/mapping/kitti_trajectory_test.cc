#include "mapping/kitti_trajectory.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <string>

#include "calib/stereo_rig.h"
#include "io/atomic_file.h"
#include "util/errors.h"
#include "util/testing.h"

namespace lunarnav::mapping {
namespace {

namespace fs = std::filesystem;
constexpr double kDeg = M_PI / 180.0;

// The camera of a level rig on a mast 1.65 m up (KITTI's), 0.27 m left of the mast.
Eigen::Isometry3d KittiLikeVehicleFromCamera() {
  calib::StereoRig rig;
  rig.right_from_left_t_m = Eigen::Vector3d(-0.54, 0, 0);
  rig.mast = calib::MastPose{1.65, 0.0, 0.0, 0.0};
  return rig.VehicleFromLeft();
}

std::string PoseLine(const Eigen::Isometry3d& p) {
  std::string line;
  char text[64];
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 4; ++j) {
      std::snprintf(text, sizeof(text), "%s%.12e", line.empty() ? "" : " ", p.matrix()(i, j));
      line += text;
    }
  }
  return line + "\n";
}

TEST(FramePoseOf, InvertsWorldFromVehicle) {
  for (const double h : {-170.0, -30.0, 0.0, 45.0, 179.0}) {
    for (const double p : {-20.0, 0.0, 10.0}) {
      for (const double r : {-15.0, 0.0, 5.0}) {
        const FramePose pose = FramePoseOf(WorldFromVehicle(1, 2, 3, h * kDeg, p * kDeg, r * kDeg));
        EXPECT_NEAR(pose.heading_rad, h * kDeg, 1e-12);
        EXPECT_NEAR(pose.pitch_rad, p * kDeg, 1e-12);
        EXPECT_NEAR(pose.roll_rad, r * kDeg, 1e-12);
        EXPECT_DOUBLE_EQ(pose.z_m, 3);
      }
    }
  }
}

TEST(ReadKittiFrameTimes, ReadsSecondsAndDatesWithKittisStems) {
  util::ScopedTempDir dir;
  io::WriteFileAtomic(dir.path() / "times.txt", "0.000000e+00\n1.041284e-01\n2.082536e-01\n");
  EXPECT_TRUE(IsKittiFrameTimes(dir.path() / "times.txt"));
  const auto odometry = ReadKittiFrameTimes(dir.path() / "times.txt");
  ASSERT_EQ(odometry.size(), 3u);
  EXPECT_EQ(odometry[2].stem, "000002");
  EXPECT_DOUBLE_EQ(odometry[1].t_s, 0.1041284);
  io::WriteFileAtomic(dir.path() / "timestamps.txt",
                      "2011-09-26 13:04:32.351950336\n2011-09-26 13:04:32.455323904\n2011-09-27 00:00:00.5\n");
  const auto raw = ReadKittiFrameTimes(dir.path() / "timestamps.txt");
  ASSERT_EQ(raw.size(), 3u);
  EXPECT_EQ(raw[1].stem, "0000000001");
  EXPECT_NEAR(raw[1].t_s - raw[0].t_s, 0.103373568, 1e-6);
  EXPECT_NEAR(raw[0].t_s, 1317042272.351950336, 1e-5);  // 2011-09-26 13:04:32 UTC
  EXPECT_NEAR(raw[2].t_s - raw[0].t_s, 10 * 3600 + 55 * 60 + 28.148049664, 1e-5);
  // The project's own frame-times CSV is not KITTI's.
  io::WriteFileAtomic(dir.path() / "frame_times.csv", "stem,t_s\nA,0\n");
  EXPECT_FALSE(IsKittiFrameTimes(dir.path() / "frame_times.csv"));
  // A bad line is named.
  io::WriteFileAtomic(dir.path() / "bad.txt", "2011-09-26 13:04:32.3\n2011-09-26 25:04:32.4\n");
  try {
    ReadKittiFrameTimes(dir.path() / "bad.txt");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.txt:2: expected a date"), std::string::npos) << e.what();
  }
}

TEST(ReadKittiPoseTrajectory, PlacesCameraPosesOnTheVehicle) {
  util::ScopedTempDir dir;
  // Camera 0 drives 1 m forward (its z) per frame, turning right (about its y, which points
  // down) by 10 deg per frame after the first; the world is camera 0 of frame 0.
  std::string text;
  Eigen::Isometry3d camera = Eigen::Isometry3d::Identity();
  for (int i = 0; i < 4; ++i) {
    text += PoseLine(camera);
    camera = camera * Eigen::Translation3d(0, 0, 1) * Eigen::AngleAxisd(10 * kDeg, Eigen::Vector3d::UnitY());
  }
  io::WriteFileAtomic(dir.path() / "poses.txt", text);
  io::WriteFileAtomic(dir.path() / "times.txt", "0\n0.1\n0.2\n0.3\n0.4\n");
  const Eigen::Isometry3d v = KittiLikeVehicleFromCamera();
  const auto samples = ReadKittiPoseTrajectory(dir.path() / "poses.txt", dir.path() / "times.txt", v);
  ASSERT_EQ(samples.size(), 4u);
  EXPECT_DOUBLE_EQ(samples[3].t_s, 0.3);
  // Frame 0's vehicle is the world's origin, level, facing along y.
  EXPECT_NEAR(samples[0].x_m, 0, 1e-9);
  EXPECT_NEAR(samples[0].y_m, 0, 1e-9);
  EXPECT_NEAR(samples[0].z_m, 0, 1e-9);
  EXPECT_NEAR(samples[0].heading_rad, 0, 1e-9);
  // Frame 1: the camera moved 1 m forward and turned right by 10 deg: heading +10 deg (clockwise
  // from the world's y); the mast base, 0.27 m right of the camera, swings with it.
  EXPECT_NEAR(samples[1].heading_rad, 10 * kDeg, 1e-9);
  EXPECT_NEAR(samples[1].pitch_rad, 0, 1e-9);
  EXPECT_NEAR(samples[1].roll_rad, 0, 1e-9);
  const Eigen::Vector3d mast = Eigen::Vector3d(-0.27, 1.0, 0.0) +
                               Eigen::AngleAxisd(-10 * kDeg, Eigen::Vector3d::UnitZ()) * Eigen::Vector3d(0.27, 0, 0);
  EXPECT_NEAR(samples[1].x_m, mast.x(), 1e-9);
  EXPECT_NEAR(samples[1].y_m, mast.y(), 1e-9);
  EXPECT_NEAR(samples[3].heading_rad, 30 * kDeg, 1e-9);
  // Without KITTI times the poses have no time.
  io::WriteFileAtomic(dir.path() / "frame_times.csv", "stem,t_s\n000000,0\n");
  EXPECT_THROW(ReadKittiPoseTrajectory(dir.path() / "poses.txt", dir.path() / "frame_times.csv", v), InputError);
  EXPECT_THROW(ReadKittiPoseTrajectory(dir.path() / "poses.txt", "", v), std::invalid_argument);
  // Fewer times than poses.
  io::WriteFileAtomic(dir.path() / "short.txt", "0\n0.1\n");
  EXPECT_THROW(ReadKittiPoseTrajectory(dir.path() / "poses.txt", dir.path() / "short.txt", v), InputError);
  // Each damaged file is named at its line, with what is wrong there: a line of 11 numbers, a
  // field that is no number, a first line neither KITTI's (12) nor TUM's (8), and times that do
  // not increase, which are the times file's fault, not the pose file's.
  auto message = [&](const std::function<void()>& read) {
    try {
      read();
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string identity = PoseLine(Eigen::Isometry3d::Identity());
  io::WriteFileAtomic(dir.path() / "bad.txt", identity + "1 0 0 0 0 1 0 0 0 0 1\n");
  EXPECT_NE(message([&] { ReadKittiPoses(dir.path() / "bad.txt"); }).find("bad.txt:2: expected 12 numbers"),
            std::string::npos)
      << message([&] { ReadKittiPoses(dir.path() / "bad.txt"); });
  io::WriteFileAtomic(dir.path() / "nan.txt", identity + "1 0 0 0 0 1 0 0 0 0 1 nan\n");
  EXPECT_NE(message([&] { ReadKittiPoses(dir.path() / "nan.txt"); }).find("nan.txt:2: field 12, 'nan', is not a finite"),
            std::string::npos);
  io::WriteFileAtomic(dir.path() / "thirteen.txt", "1 0 0 0 0 1 0 0 0 0 1 0 5\n");
  EXPECT_NE(message([&] { DetectTrajectoryFormat(dir.path() / "thirteen.txt"); })
                .find("thirteen.txt: its first line holds 13 numbers"),
            std::string::npos);
  io::WriteFileAtomic(dir.path() / "back.txt", "0\n0.1\n0.05\n0.3\n");
  EXPECT_NE(message([&] { ReadKittiPoseTrajectory(dir.path() / "poses.txt", dir.path() / "back.txt", v); })
                .find("back.txt:3: time 0.05 s is not after the previous frame's (0.1 s)"),
            std::string::npos);
}

TEST(PosesOfPairs, ReadsKittiPosesAtKittiTimesThroughTheRig) {
  util::ScopedTempDir dir;
  std::string text;
  for (int i = 0; i < 3; ++i) text += PoseLine(Eigen::Isometry3d(Eigen::Translation3d(0, 0, 2.0 * i)));
  io::WriteFileAtomic(dir.path() / "poses.txt", text);
  io::WriteFileAtomic(dir.path() / "times.txt", "0\n0.1\n0.2\n");
  const auto poses = PosesOfPairs("", dir.path() / "poses.txt", dir.path() / "times.txt", {"000002", "000001"},
                                  KittiLikeVehicleFromCamera());
  ASSERT_EQ(poses.size(), 2u);
  EXPECT_EQ(poses[0].stem, "000001");
  EXPECT_NEAR(poses[0].y_m, 2.0, 1e-9);
  EXPECT_NEAR(poses[1].y_m, 4.0, 1e-9);
  // Camera poses without a rig are a usage error.
  EXPECT_THROW(PosesOfPairs("", dir.path() / "poses.txt", dir.path() / "times.txt", {"000001"}), std::invalid_argument);
  EXPECT_EQ(DetectTrajectoryFormat(dir.path() / "poses.txt"), TrajectoryFormat::kKittiPoses);
  io::WriteFileAtomic(dir.path() / "tum.txt", "# t x y z qx qy qz qw\n0 0 0 0 0 0 0 1\n");
  EXPECT_EQ(DetectTrajectoryFormat(dir.path() / "tum.txt"), TrajectoryFormat::kTum);
  // A first line of numbers of another count is neither (said at once; other lines are left to
  // the format's reader, which names them).
  io::WriteFileAtomic(dir.path() / "odd.txt", "0 0 0\n");
  EXPECT_THROW(DetectTrajectoryFormat(dir.path() / "odd.txt"), InputError);
  EXPECT_THROW(DetectTrajectoryFormat(dir.path() / "missing.txt"), InputError);
  EXPECT_THROW(DetectTrajectoryFormat(dir.path()), InputError);  // a directory that is no oxts/
}

TEST(ReadKittiOxtsTrajectory, FollowsTheDevkitsProjectionAndTheCalibrationChain) {
  util::ScopedTempDir dir;
  const fs::path drive = dir.path() / "drive", oxts = drive / "oxts";
  fs::create_directories(oxts / "data");
  // The camera looks along the IMU's x (forward), its x right (the IMU's -y), its y down.
  io::WriteFileAtomic(drive / "calib_imu_to_velo.txt", "R: 1 0 0 0 1 0 0 0 1\nT: 0 0 0\n");
  io::WriteFileAtomic(drive / "calib_velo_to_cam.txt", "R: 0 -1 0 0 0 -1 1 0 0\nT: 0 0 0\n");
  io::WriteFileAtomic(drive / "calib_cam_to_cam.txt", "R_rect_00: 1 0 0 0 1 0 0 0 1\n");
  // Packet 0 faces east (yaw 0); packet 1 lies 1e-5 deg further north, facing north.
  const std::string rest = " 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0\n";
  io::WriteFileAtomic(oxts / "data" / "0000000000.txt", "49.0 8.4 110.0 0 0 0" + rest);
  io::WriteFileAtomic(oxts / "data" / "0000000001.txt", "49.00001 8.4 110.5 0 0 1.5707963267948966" + rest);
  io::WriteFileAtomic(oxts / "timestamps.txt", "2011-09-26 13:04:32.3\n2011-09-26 13:04:32.4\n");
  const auto samples = ReadKittiOxtsTrajectory(oxts, KittiLikeVehicleFromCamera());
  ASSERT_EQ(samples.size(), 2u);
  EXPECT_NEAR(samples[0].heading_rad, 90 * kDeg, 1e-9);  // east
  EXPECT_NEAR(samples[1].heading_rad, 0, 1e-9);          // north
  EXPECT_NEAR(samples[0].pitch_rad, 0, 1e-9);
  EXPECT_NEAR(samples[0].x_m, 0, 1e-9);
  // The vehicle's mast base: 1.65 m below the camera, 0.27 m to its right (south, then east).
  // Between the packets: 1e-5 deg of latitude north (6378137 pi / 180 1e-5 m on the
  // devkit's sphere) and the base's swing about the turning camera. The altitude's 0.5 m jump
  // in 0.1 s, with the INS's vertical velocity 0, moves the height by 0.5 x 0.1 / 60 only.
  const double north = 6378137.0 * M_PI / 180 * 1e-5;
  EXPECT_NEAR(samples[1].y_m, north + 0.27, 1e-3);
  EXPECT_NEAR(samples[1].x_m, 0.27, 1e-6);
  EXPECT_NEAR(samples[1].z_m, 0.5 * 0.1 / kOxtsAltitudeTimeConstantS, 1e-6);
  // A vertical velocity of 1 m/s over the next 0.1 s raises it by 0.1 m (and the altitude's
  // pull, 0.5 m away, by 0.5 x 0.1 / 60 more).
  const std::string climbing = " 0 0 0 0 1" + rest.substr(10);
  io::WriteFileAtomic(oxts / "data" / "0000000001.txt", "49.00001 8.4 110.5 0 0 1.5707963267948966" + climbing);
  io::WriteFileAtomic(oxts / "data" / "0000000002.txt", "49.00001 8.4 110.5 0 0 1.5707963267948966" + climbing);
  io::WriteFileAtomic(oxts / "timestamps.txt", "2011-09-26 13:04:32.3\n2011-09-26 13:04:32.4\n2011-09-26 13:04:32.5\n");
  const auto climb = ReadKittiOxtsTrajectory(oxts, KittiLikeVehicleFromCamera());
  ASSERT_EQ(climb.size(), 3u);
  const double z1 = 0.05 + (0.5 - 0.05) * 0.1 / kOxtsAltitudeTimeConstantS;  // vu 0 then 1: a trapezoid
  EXPECT_NEAR(climb[1].z_m, z1, 1e-6);
  EXPECT_NEAR(climb[2].z_m, z1 + 0.1 + (0.5 - z1 - 0.1) * 0.1 / kOxtsAltitudeTimeConstantS, 1e-6);
  // The LiDAR here is the camera's frame turned: KittiLidarInVehicle composes the mounting.
  const Eigen::Isometry3d lidar = KittiLidarInVehicle(drive / "calib_velo_to_cam.txt", KittiLikeVehicleFromCamera());
  EXPECT_NEAR((lidar.linear() * Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitY()).norm(), 0, 1e-9);  // x forward
  EXPECT_NEAR((lidar.translation() - Eigen::Vector3d(-0.27, 0, 1.65)).norm(), 0, 1e-9);
  // Without the calibration files the packets cannot be placed.
  fs::remove(drive / "calib_imu_to_velo.txt");
  EXPECT_THROW(ReadKittiOxtsTrajectory(oxts, KittiLikeVehicleFromCamera()), InputError);
}

}  // namespace
}  // namespace lunarnav::mapping
