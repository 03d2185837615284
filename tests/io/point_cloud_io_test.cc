#include "io/point_cloud_io.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#include "io/atomic_file.h"
#include "util/errors.h"
#include "util/testing.h"

namespace lunarnav::io {
namespace {

std::string Floats(std::initializer_list<float> values) {
  std::string bytes;
  for (float v : values) {
    char b[4];
    std::memcpy(b, &v, 4);  // the machines the project runs on are little-endian
    bytes.append(b, 4);
  }
  return bytes;
}

void ExpectRefused(const std::filesystem::path& path, const std::string& part) {
  try {
    ReadPointCloud(path);
    FAIL() << "expected InputError for " << path;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
  }
}

TEST(ReadPointCloud, ReadsKittiSweepsDroppingNonFinitePoints) {
  util::ScopedTempDir dir;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  WriteFileAtomic(dir.path() / "000000.bin", Floats({1, 2, 3, 0.5f, nan, 0, 0, 0, -4, 5.5f, 6, 1}));
  const auto points = ReadPointCloud(dir.path() / "000000.bin");
  ASSERT_EQ(points.size(), 2u);
  EXPECT_EQ(points[0], Eigen::Vector3f(1, 2, 3));
  EXPECT_EQ(points[1], Eigen::Vector3f(-4, 5.5f, 6));
  WriteFileAtomic(dir.path() / "cut.bin", Floats({1, 2, 3, 0.5f, 7}));
  ExpectRefused(dir.path() / "cut.bin", "20 bytes, not whole KITTI points");
}

TEST(ReadPointCloud, ReadsPcdAsciiAndBinary) {
  util::ScopedTempDir dir;
  const std::string head =
      "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z intensity\nSIZE 4 4 4 4\n"
      "TYPE F F F F\nCOUNT 1 1 1 1\nWIDTH 2\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\n";
  WriteFileAtomic(dir.path() / "a.pcd", head + "DATA ascii\n1 2 3 9\n4.5 -5 6 9\n");
  auto points = ReadPointCloud(dir.path() / "a.pcd");
  ASSERT_EQ(points.size(), 2u);
  EXPECT_EQ(points[1], Eigen::Vector3f(4.5f, -5, 6));
  WriteFileAtomic(dir.path() / "b.pcd", head + "DATA binary\n" + Floats({1, 2, 3, 9, 7, 8, 9, 9}));
  points = ReadPointCloud(dir.path() / "b.pcd");
  ASSERT_EQ(points.size(), 2u);
  EXPECT_EQ(points[1], Eigen::Vector3f(7, 8, 9));
  // A binary body shorter than POINTS says, a compressed one, a cloud without z.
  WriteFileAtomic(dir.path() / "short.pcd", head + "DATA binary\n" + Floats({1, 2, 3, 9, 7}));
  ExpectRefused(dir.path() / "short.pcd", "2 points of 16 bytes declared, 20 bytes of data");
  WriteFileAtomic(dir.path() / "lzf.pcd", head + "DATA binary_compressed\n");
  ExpectRefused(dir.path() / "lzf.pcd", "DATA binary_compressed is not supported");
  WriteFileAtomic(dir.path() / "noz.pcd", "FIELDS x y\nSIZE 4 4\nTYPE F F\nCOUNT 1 1\nPOINTS 1\nDATA ascii\n1 2\n");
  ExpectRefused(dir.path() / "noz.pcd", "no field z");
  ExpectRefused(dir.path() / "cloud.xyz", "not a point cloud this reads");
}

}  // namespace
}  // namespace lunarnav::io
