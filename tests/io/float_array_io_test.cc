#include "io/float_array_io.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>

#include <opencv2/imgproc.hpp>

#include "io/atomic_file.h"
#include "io/oiio_module.h"
#include "util/errors.h"
#include "util/testing.h"

namespace lunarnav::io {
namespace {
namespace fs = std::filesystem;

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

// A 3-channel map with distinct values, NaN holes and infinities.
cv::Mat XyzLike() {
  cv::Mat m(5, 7, CV_32FC3);
  for (int y = 0; y < m.rows; ++y)
    for (int x = 0; x < m.cols; ++x) m.at<cv::Vec3f>(y, x) = cv::Vec3f(x - 3.25f, 1e-3f * y, -1e6f / (x + 1));
  m.at<cv::Vec3f>(0, 0) = cv::Vec3f(kNaN, kNaN, kNaN);
  m.at<cv::Vec3f>(4, 6) = cv::Vec3f(kInf, -kInf, 1.0f);
  return m;
}

bool SameBitsOrBothNaN(float a, float b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

TEST(WriteExrAtomic, RoundTripsThreeChannelsWithNaNExactly) {
  util::ScopedTempDir tmp;
  const fs::path path = tmp.path() / "sub" / "xyz.exr";
  const cv::Mat m = XyzLike();
  WriteExrAtomic(path, m, {}, {{"lunarnav:units", "m"}, {"lunarnav:frame", "vehicle"}});
  const ExrImage back = ReadExr(path);
  ASSERT_EQ(back.pixels.type(), CV_32FC3);
  ASSERT_EQ(back.pixels.size(), m.size());
  for (int y = 0; y < m.rows; ++y)
    for (int x = 0; x < m.cols; ++x)
      for (int k = 0; k < 3; ++k)
        EXPECT_TRUE(SameBitsOrBothNaN(back.pixels.at<cv::Vec3f>(y, x)[k], m.at<cv::Vec3f>(y, x)[k]))
            << x << "," << y << "," << k;
  EXPECT_EQ(back.channel_names, (std::vector<std::string>{"R", "G", "B"}));
  EXPECT_EQ(back.attributes.at("lunarnav:units"), "m");
  EXPECT_EQ(back.attributes.at("lunarnav:frame"), "vehicle");
  // It is an OpenEXR file (magic number 76 2f 31 01), and no temporary file is left.
  std::ifstream in(path, std::ios::binary);
  unsigned char magic[4] = {};
  in.read(reinterpret_cast<char*>(magic), 4);
  EXPECT_EQ(magic[0], 0x76);
  EXPECT_EQ(magic[1], 0x2f);
  EXPECT_EQ(magic[2], 0x31);
  EXPECT_EQ(magic[3], 0x01);
  for (const auto& entry : fs::directory_iterator(path.parent_path())) {
    EXPECT_FALSE(IsTempFileName(entry.path())) << entry.path();
  }
}

TEST(WriteExrAtomic, WritesOneChannelRoisAndNamedChannels) {
  util::ScopedTempDir tmp;
  cv::Mat big(10, 12, CV_32FC1, cv::Scalar(2.5));
  big.at<float>(3, 4) = kNaN;
  const cv::Mat roi = big(cv::Rect(2, 1, 6, 5));  // not contiguous
  WriteExrAtomic(tmp.path() / "one.exr", roi);
  const ExrImage one = ReadExr(tmp.path() / "one.exr");
  ASSERT_EQ(one.pixels.type(), CV_32FC1);
  ASSERT_EQ(one.pixels.size(), cv::Size(6, 5));
  EXPECT_TRUE(std::isnan(one.pixels.at<float>(2, 2)));
  EXPECT_EQ(one.pixels.at<float>(0, 0), 2.5f);
  EXPECT_EQ(one.channel_names, std::vector<std::string>{"Y"});

  WriteExrAtomic(tmp.path() / "named.exr", XyzLike(), {"X", "Y", "Z"});
  EXPECT_EQ(ReadExr(tmp.path() / "named.exr").channel_names, (std::vector<std::string>{"X", "Y", "Z"}));
}

TEST(WriteExrAtomic, RefusesNonFloatMapsAndWrongChannelNames) {
  util::ScopedTempDir tmp;
  EXPECT_THROW(WriteExrAtomic(tmp.path() / "a.exr", cv::Mat(3, 3, CV_8UC1)), std::invalid_argument);
  EXPECT_THROW(WriteExrAtomic(tmp.path() / "b.exr", cv::Mat()), std::invalid_argument);
  EXPECT_THROW(WriteExrAtomic(tmp.path() / "c.exr", XyzLike(), {"X", "Y"}), std::invalid_argument);
  EXPECT_FALSE(fs::exists(tmp.path() / "a.exr"));
}

TEST(WriteExrAtomic, StampsTheFiniteRowsAndReadExrDecodesOnlyThose) {
  util::ScopedTempDir tmp;
  // Rows 0-9 and 30-39 all NaN, as a rig's default search leaves an XYZ array.
  cv::Mat m(40, 16, CV_32FC3, cv::Scalar::all(kNaN));
  for (int y = 10; y < 30; ++y) {
    for (int x = 0; x < m.cols; ++x) m.at<cv::Vec3f>(y, x) = cv::Vec3f(0.5f * x, 10.0f + y, -0.25f * y);
  }
  m.at<cv::Vec3f>(20, 3) = cv::Vec3f(kNaN, kNaN, kNaN);
  const fs::path path = tmp.path() / "xyz.exr";
  WriteExrAtomic(path, m, {}, {{kFiniteRowsAttribute, "0 0"}});  // a caller's stale value is replaced
  const ExrImage back = ReadExr(path);
  EXPECT_EQ(back.attributes.at(kFiniteRowsAttribute), "10 29");
  ASSERT_EQ(back.pixels.size(), m.size());
  for (int y = 0; y < m.rows; ++y) {
    for (int x = 0; x < m.cols; ++x) {
      for (int c = 0; c < 3; ++c) {
        EXPECT_TRUE(SameBitsOrBothNaN(back.pixels.at<cv::Vec3f>(y, x)[c], m.at<cv::Vec3f>(y, x)[c])) << y << "," << x;
      }
    }
  }
  // An array without a finite value reads back all NaN.
  WriteExrAtomic(tmp.path() / "empty.exr", cv::Mat(4, 4, CV_32FC3, cv::Scalar::all(kNaN)));
  const ExrImage empty = ReadExr(tmp.path() / "empty.exr");
  EXPECT_EQ(empty.attributes.at(kFiniteRowsAttribute), "0 -1");
  EXPECT_EQ(cv::countNonZero(empty.pixels.reshape(1) == empty.pixels.reshape(1)), 0);
}

TEST(ReadExr, HalfAndFourChannelArraysReadBackAsWritten) {
  // The project's own arrays are read through OpenEXR's core API, block by block (16 rows):
  // 16-bit storage comes back as its rounded floats (values past 65504 as +inf), four channels
  // in their order, over rows that span several blocks.
  util::ScopedTempDir tmp;
  cv::Mat m(40, 9, CV_32FC4);
  for (int y = 0; y < m.rows; ++y) {
    for (int x = 0; x < m.cols; ++x) m.at<cv::Vec4f>(y, x) = cv::Vec4f(0.001f * x * y, -3.7f * y, 1e5f + x, x - 4.5f);
  }
  m.at<cv::Vec4f>(17, 2) = cv::Vec4f(kNaN, kInf, -kInf, kNaN);
  WriteExrAtomic(tmp.path() / "four.exr", m);
  const ExrImage four = ReadExr(tmp.path() / "four.exr");
  ASSERT_EQ(four.pixels.type(), CV_32FC4);
  EXPECT_EQ(four.channel_names, (std::vector<std::string>{"R", "G", "B", "A"}));
  cv::Mat three;
  cv::cvtColor(m, three, cv::COLOR_BGRA2BGR);
  WriteExrAtomic(tmp.path() / "half.exr", three, {}, {{"lunarnav:units", "m"}}, ExrStorage::kFloat16);
  const ExrImage half = ReadExr(tmp.path() / "half.exr");
  ASSERT_EQ(half.pixels.type(), CV_32FC3);
  EXPECT_EQ(half.attributes.at("lunarnav:units"), "m");
  cv::Mat rounded;
  three.convertTo(rounded, CV_16F);
  rounded.convertTo(rounded, CV_32F);
  for (int y = 0; y < m.rows; ++y) {
    for (int x = 0; x < m.cols; ++x) {
      for (int c = 0; c < 4; ++c) {
        EXPECT_TRUE(SameBitsOrBothNaN(four.pixels.at<cv::Vec4f>(y, x)[c], m.at<cv::Vec4f>(y, x)[c])) << y << "," << x;
      }
      for (int c = 0; c < 3; ++c) {
        const float want = std::abs(three.at<cv::Vec3f>(y, x)[c]) > 65504 && std::isfinite(three.at<cv::Vec3f>(y, x)[c])
                               ? std::copysign(kInf, three.at<cv::Vec3f>(y, x)[c])
                               : rounded.at<cv::Vec3f>(y, x)[c];
        EXPECT_TRUE(SameBitsOrBothNaN(half.pixels.at<cv::Vec3f>(y, x)[c], want)) << y << "," << x << "," << c;
      }
    }
  }
}

TEST(ReadExr, ReadsOnlyTheRowsTheStampNames) {
  // A stamp that names fewer rows than hold values (rows 12-20 of 40): the others read NaN,
  // also within the 16-row blocks the named rows share with them.
  util::ScopedTempDir tmp;
  cv::Mat m(40, 5, CV_32FC3);
  for (int y = 0; y < m.rows; ++y) {
    for (int x = 0; x < m.cols; ++x) m.at<cv::Vec3f>(y, x) = cv::Vec3f(1.0f * y, 2.0f * x, 3.0f);
  }
  std::string error;
  ASSERT_TRUE(internal::Oiio().WriteExr((tmp.path() / "stamped.exr").string(), m, {"R", "G", "B"},
                                        {{kFiniteRowsAttribute, "12 20"}}, false, &error))
      << error;
  const ExrImage back = ReadExr(tmp.path() / "stamped.exr");
  ASSERT_EQ(back.pixels.size(), m.size());
  for (int y = 0; y < m.rows; ++y) {
    const bool named = y >= 12 && y <= 20;
    for (int c = 0; c < 3; ++c) {
      const float v = back.pixels.at<cv::Vec3f>(y, 2)[c];
      EXPECT_TRUE(named ? v == m.at<cv::Vec3f>(y, 2)[c] : std::isnan(v)) << y << "," << c;
    }
  }
}

TEST(ReadExr, ReportsMissingAndCorruptFiles) {
  util::ScopedTempDir tmp;
  EXPECT_THROW(ReadExr(tmp.path() / "none.exr"), InputError);
  std::ofstream(tmp.path() / "junk.exr") << "not an image at all";
  EXPECT_THROW(ReadExr(tmp.path() / "junk.exr"), InputError);
  // A truncated EXR.
  WriteExrAtomic(tmp.path() / "full.exr", cv::Mat(64, 64, CV_32FC3, cv::Scalar(1, 2, 3)));
  std::ifstream in(tmp.path() / "full.exr", std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::ofstream(tmp.path() / "cut.exr", std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size() / 2));
  EXPECT_THROW(ReadExr(tmp.path() / "cut.exr"), InputError);
}

}  // namespace
}  // namespace lunarnav::io
