#include "io/ply_io.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>

#include "io/atomic_file.h"
#include "util/errors.h"
#include "util/testing.h"

namespace lunarnav::io {
namespace {
namespace fs = std::filesystem;

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

std::string ReadBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// A 3 x 4 map: (x, y, x + 10 y) with three invalid points (NaN in one or all coordinates).
cv::Mat Xyz() {
  cv::Mat m(3, 4, CV_32FC3);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 4; ++x) m.at<cv::Vec3f>(y, x) = cv::Vec3f(0.5f * x, -1.25f * y, x + 10.0f * y);
  m.at<cv::Vec3f>(0, 1) = cv::Vec3f(kNaN, kNaN, kNaN);
  m.at<cv::Vec3f>(1, 2)[2] = kNaN;
  m.at<cv::Vec3f>(2, 0)[0] = std::numeric_limits<float>::infinity();
  return m;
}

TEST(WritePlyAtomic, WritesTheStandardHeaderAndOnlyValidPointsInRowOrder) {
  util::ScopedTempDir tmp;
  const fs::path path = tmp.path() / "cloud" / "a.ply";
  cv::Mat grey(3, 4, CV_8UC1);
  for (int i = 0; i < 12; ++i) grey.data[i] = static_cast<std::uint8_t>(20 * i);
  EXPECT_EQ(WritePlyAtomic(path, Xyz(), grey, {"frame vehicle", "units m"}), 9);
  const std::string bytes = ReadBytes(path);
  const std::string header =
      "ply\nformat binary_little_endian 1.0\ncomment frame vehicle\ncomment units m\n"
      "element vertex 9\nproperty float x\nproperty float y\nproperty float z\n"
      "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n";
  ASSERT_EQ(bytes.substr(0, header.size()), header);
  ASSERT_EQ(bytes.size(), header.size() + 9 * 15);  // 3 floats + 3 bytes per point
  // The first record is pixel (0, 0): (0, 0, 0), grey 0; the second pixel (2, 0) (pixel (1, 0)
  // has no point): (1, 0, 2), grey 40 in all three colour bytes, little-endian floats.
  const unsigned char* r = reinterpret_cast<const unsigned char*>(bytes.data()) + header.size() + 15;
  const std::uint32_t bits = r[0] | (r[1] << 8) | (r[2] << 16) | (static_cast<std::uint32_t>(r[3]) << 24);
  float x;
  std::memcpy(&x, &bits, 4);
  EXPECT_EQ(x, 1.0f);
  EXPECT_EQ(r[12], 40);
  EXPECT_EQ(r[13], 40);
  EXPECT_EQ(r[14], 40);
  for (const auto& entry : fs::directory_iterator(path.parent_path())) {
    EXPECT_FALSE(IsTempFileName(entry.path())) << entry.path();
  }
}

TEST(ReadPly, RoundTripsPointsAndColours) {
  util::ScopedTempDir tmp;
  const cv::Mat xyz = Xyz();
  cv::Mat rgb(3, 4, CV_8UC3);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 4; ++x) rgb.at<cv::Vec3b>(y, x) = cv::Vec3b(x, y, 200);
  WritePlyAtomic(tmp.path() / "rgb.ply", xyz, rgb, {"hello"});
  WritePlyAtomic(tmp.path() / "plain.ply", xyz);
  const PlyPointCloud with = ReadPly(tmp.path() / "rgb.ply");
  const PlyPointCloud without = ReadPly(tmp.path() / "plain.ply");
  EXPECT_EQ(with.comments, std::vector<std::string>{"hello"});
  EXPECT_TRUE(without.colours.empty());
  std::size_t k = 0;
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 4; ++x) {
      const cv::Vec3f p = xyz.at<cv::Vec3f>(y, x);
      if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) continue;
      ASSERT_LT(k, with.points.size());
      EXPECT_EQ(with.points[k], cv::Point3f(p[0], p[1], p[2]));
      EXPECT_EQ(without.points[k], cv::Point3f(p[0], p[1], p[2]));
      EXPECT_EQ(with.colours[k], cv::Vec3b(x, y, 200));  // red, green, blue as given
      ++k;
    }
  EXPECT_EQ(k, 9u);
  EXPECT_EQ(with.points.size(), 9u);
}

TEST(WritePlyAtomic, WritesAnEmptyCloudAndRefusesBadArguments) {
  util::ScopedTempDir tmp;
  EXPECT_EQ(WritePlyAtomic(tmp.path() / "empty.ply", cv::Mat(2, 2, CV_32FC3, cv::Scalar::all(kNaN))), 0);
  EXPECT_TRUE(ReadPly(tmp.path() / "empty.ply").points.empty());
  EXPECT_THROW(WritePlyAtomic(tmp.path() / "b.ply", cv::Mat(2, 2, CV_32FC1)), std::invalid_argument);
  EXPECT_THROW(WritePlyAtomic(tmp.path() / "c.ply", Xyz(), cv::Mat(2, 2, CV_8UC1)), std::invalid_argument);
  EXPECT_THROW(WritePlyAtomic(tmp.path() / "d.ply", Xyz(), {}, {"two\nlines"}), std::invalid_argument);
  EXPECT_FALSE(fs::exists(tmp.path() / "b.ply"));
}

TEST(ReadPly, ReportsUnsupportedAndTruncatedFiles) {
  util::ScopedTempDir tmp;
  std::ofstream(tmp.path() / "ascii.ply") << "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                                             "property float y\nproperty float z\nend_header\n1 2 3\n";
  EXPECT_THROW(ReadPly(tmp.path() / "ascii.ply"), InputError);
  std::ofstream(tmp.path() / "other.ply") << "solid ascii stl\n";
  EXPECT_THROW(ReadPly(tmp.path() / "other.ply"), InputError);
  WritePlyAtomic(tmp.path() / "full.ply", Xyz());
  const std::string bytes = ReadBytes(tmp.path() / "full.ply");
  std::ofstream(tmp.path() / "cut.ply", std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size() - 5));
  EXPECT_THROW(ReadPly(tmp.path() / "cut.ply"), InputError);
  // A header announcing four billion vertices over a few bytes is refused before anything is
  // allocated for them (it ran out of memory, exit 1), naming what the file holds.
  std::ofstream(tmp.path() / "forged.ply", std::ios::binary)
      << "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\n"
         "property float y\nproperty float z\nend_header\n"
      << std::string(120, '\0');
  try {
    ReadPly(tmp.path() / "forged.ply");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("forged.ply: truncated (4000000000 vertices of 12 bytes announced, 120 bytes"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace lunarnav::io
