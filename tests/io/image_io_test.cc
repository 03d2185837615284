#include "io/image_io.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <png.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "util/errors.h"
#include "util/testing.h"

namespace lunarnav::io {
namespace {
namespace fs = std::filesystem;

cv::Mat Ramp(int type) {
  cv::Mat m(7, 11, type);
  for (int y = 0; y < m.rows; ++y)
    for (int x = 0; x < m.cols; ++x) {
      if (type == CV_8UC1) m.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(20 * y + x);
      if (type == CV_16UC1) m.at<std::uint16_t>(y, x) = static_cast<std::uint16_t>(5000 * y + x);
    }
  return m;
}

TEST(ReadGreyImage, RoundTripsEightAndSixteenBitFormats) {
  util::ScopedTempDir tmp;
  for (const char* ext : {".png", ".pgm", ".tif"}) {
    for (int type : {CV_8UC1, CV_16UC1}) {
      const fs::path path = tmp.path() / (std::string("ramp") + std::to_string(type) + ext);
      const cv::Mat m = Ramp(type);
      ASSERT_TRUE(cv::imwrite(path.string(), m));
      const cv::Mat back = ReadGreyImage(path);
      ASSERT_EQ(back.type(), type) << path;
      EXPECT_EQ(cv::norm(back, m, cv::NORM_INF), 0) << path;
    }
  }
}

TEST(ReadGreyImage, ConvertsColourWithRec601Weights) {
  util::ScopedTempDir tmp;
  cv::Mat bgr(4, 4, CV_8UC3, cv::Scalar(10, 200, 40));  // B, G, R
  ASSERT_TRUE(cv::imwrite((tmp.path() / "c.png").string(), bgr));
  const cv::Mat grey = ReadGreyImage(tmp.path() / "c.png");
  ASSERT_EQ(grey.type(), CV_8UC1);
  EXPECT_NEAR(grey.at<std::uint8_t>(0, 0), 0.299 * 40 + 0.587 * 200 + 0.114 * 10, 1.0);
}

TEST(ReadImage, KeepsColourInBgrOrderAndDropsAlpha) {
  util::ScopedTempDir tmp;
  cv::Mat bgra(3, 5, CV_16UC4, cv::Scalar(1000, 20000, 40000, 65535));
  bgra.at<cv::Vec<std::uint16_t, 4>>(2, 4) = {7, 8, 9, 0};
  ASSERT_TRUE(cv::imwrite((tmp.path() / "c.png").string(), bgra));
  const cv::Mat image = ReadImage(tmp.path() / "c.png");
  ASSERT_EQ(image.type(), CV_16UC3);
  EXPECT_EQ(image.at<cv::Vec3w>(0, 0), cv::Vec3w(1000, 20000, 40000));
  EXPECT_EQ(image.at<cv::Vec3w>(2, 4), cv::Vec3w(7, 8, 9));
  cv::Mat grey(2, 2, CV_8UC1, cv::Scalar(77));
  ASSERT_TRUE(cv::imwrite((tmp.path() / "g.pgm").string(), grey));
  EXPECT_EQ(ReadImage(tmp.path() / "g.pgm").type(), CV_8UC1);
}

// A PNG written by libpng with one row filter for every row (or its adaptive choice), any
// colour type and depth, interlaced or not: `pixels` in the file's channel order (RGB(A)).
void WritePngWithFilter(const fs::path& path, const cv::Mat& pixels, int filters, bool interlaced, bool palette) {
  std::FILE* file = std::fopen(path.c_str(), "wb");
  ASSERT_NE(file, nullptr);
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  png_init_io(png, file);
  static const int kColourTypes[] = {PNG_COLOR_TYPE_GRAY, PNG_COLOR_TYPE_GRAY_ALPHA, PNG_COLOR_TYPE_RGB,
                                     PNG_COLOR_TYPE_RGB_ALPHA};
  const int depth = pixels.depth() == CV_16U ? 16 : 8;
  png_set_IHDR(png, info, pixels.cols, pixels.rows, depth,
               palette ? PNG_COLOR_TYPE_PALETTE : kColourTypes[pixels.channels() - 1],
               interlaced ? PNG_INTERLACE_ADAM7 : PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  std::vector<png_color> colours(256);
  if (palette) {
    for (int i = 0; i < 256; ++i) colours[i] = {static_cast<png_byte>(i), static_cast<png_byte>(255 - i), 7};
    png_set_PLTE(png, info, colours.data(), 256);
  }
  png_set_filter(png, 0, filters);
  png_write_info(png, info);
  if (depth == 16) png_set_swap(png);  // the host's byte order in, big-endian in the file
  std::vector<png_bytep> rows(pixels.rows);
  for (int y = 0; y < pixels.rows; ++y) rows[y] = const_cast<png_bytep>(pixels.ptr(y));
  png_write_image(png, rows.data());
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  std::fclose(file);
}

// The PNG reader (its own decoding of the common kinds, libpng for the others) against
// OpenCV's decoder, over every colour type, both depths and each row filter: smooth gradients
// with noise so that every filter meets every kind of neighbour, sizes from one pixel up.
TEST(ReadImage, DecodesEveryPngKindAndFilterAsOpenCvDoes) {
  util::ScopedTempDir tmp;
  cv::RNG rng(3);
  const int filters[] = {PNG_FILTER_NONE, PNG_FILTER_SUB, PNG_FILTER_UP, PNG_FILTER_AVG, PNG_FILTER_PAETH,
                         PNG_ALL_FILTERS};
  int checked = 0;
  for (const cv::Size size : {cv::Size(1, 1), cv::Size(2, 3), cv::Size(37, 23)}) {
    for (int channels = 1; channels <= 4; ++channels) {
      for (const int depth : {CV_8U, CV_16U}) {
        cv::Mat pixels(size, CV_MAKETYPE(depth, channels));
        const double top = depth == CV_8U ? 255 : 65535;
        for (int y = 0; y < size.height; ++y) {
          for (int x = 0; x < size.width * channels; ++x) {
            const double v = std::fmod(top * (0.3 + 0.02 * x + 0.03 * y) + rng.uniform(-0.1, 0.1) * top, top + 1);
            if (depth == CV_8U) pixels.ptr<std::uint8_t>(y)[x] = cv::saturate_cast<std::uint8_t>(std::abs(v));
            if (depth == CV_16U) pixels.ptr<std::uint16_t>(y)[x] = cv::saturate_cast<std::uint16_t>(std::abs(v));
          }
        }
        for (const int filter : filters) {
          for (const bool interlaced : {false, true}) {
            const fs::path path = tmp.path() / ("p" + std::to_string(checked++) + ".png");
            WritePngWithFilter(path, pixels, filter, interlaced, false);
            const cv::Mat expected = cv::imread(path.string(), cv::IMREAD_UNCHANGED);  // BGR(A)
            ASSERT_FALSE(expected.empty()) << path;
            cv::Mat expected_bgr = expected, expected_grey = expected;
            if (channels == 4) cv::cvtColor(expected, expected_bgr, cv::COLOR_BGRA2BGR);
            if (channels == 2) cv::extractChannel(expected, expected_bgr, 0);
            if (channels >= 3) cv::cvtColor(expected_bgr, expected_grey, cv::COLOR_BGR2GRAY);
            if (channels == 2) expected_grey = expected_bgr;
            const cv::Mat image = ReadImage(path), grey = ReadGreyImage(path);
            ASSERT_EQ(image.type(), expected_bgr.type()) << path;
            EXPECT_EQ(cv::norm(image, expected_bgr, cv::NORM_INF), 0) << path << " filter " << filter;
            ASSERT_EQ(grey.type(), expected_grey.type()) << path;
            EXPECT_EQ(cv::norm(grey, expected_grey, cv::NORM_INF), 0) << path << " filter " << filter;
          }
        }
      }
    }
  }
  // A palette image (expanded to RGB by libpng).
  cv::Mat indices(5, 9, CV_8UC1);
  rng.fill(indices, cv::RNG::UNIFORM, 0, 256);
  WritePngWithFilter(tmp.path() / "palette.png", indices, PNG_ALL_FILTERS, false, true);
  const cv::Mat image = ReadImage(tmp.path() / "palette.png");
  ASSERT_EQ(image.type(), CV_8UC3);
  EXPECT_EQ(image.at<cv::Vec3b>(0, 0), cv::Vec3b(7, 255 - indices.at<std::uint8_t>(0, 0), indices.at<std::uint8_t>(0, 0)));
}

TEST(ReadGreyImage, ReportsMissingEmptyAndTruncatedFiles) {
  util::ScopedTempDir tmp;
  EXPECT_THROW(ReadGreyImage(tmp.path() / "none.png"), InputError);
  std::ofstream(tmp.path() / "empty.png");
  EXPECT_THROW(ReadGreyImage(tmp.path() / "empty.png"), InputError);
  cv::Mat noise(200, 200, CV_8UC1);
  cv::randu(noise, 0, 255);
  std::vector<uchar> bytes;
  for (const char* ext : {".png", ".tif", ".pgm", ".jpg"}) {
    cv::imencode(ext, noise, bytes);
    const fs::path path = tmp.path() / (std::string("cut") + ext);
    std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()),
                                                static_cast<std::streamsize>(bytes.size() / 2));
    try {
      ReadGreyImage(path);
      ADD_FAILURE() << "no error for truncated " << ext;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(path.string()), std::string::npos) << e.what();
    }
  }
}

TEST(WritePfm, RoundTripsWithInfinityAndMiddleburyLayout) {
  util::ScopedTempDir tmp;
  cv::Mat m(2, 3, CV_32FC1);
  for (int i = 0; i < 6; ++i) m.at<float>(i / 3, i % 3) = 0.5f * i;
  m.at<float>(0, 0) = std::numeric_limits<float>::infinity();
  const fs::path path = tmp.path() / "d.pfm";
  WriteImageAtomic(path, m);
  std::ifstream in(path, std::ios::binary);
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header, "Pf");
  std::getline(in, header);
  EXPECT_EQ(header, "3 2");
  std::getline(in, header);
  EXPECT_LT(std::stod(header), 0.0);  // negative scale: little-endian
  float first_stored = 0;
  in.read(reinterpret_cast<char*>(&first_stored), sizeof(float));
  EXPECT_EQ(first_stored, m.at<float>(1, 0));  // rows bottom to top
  const cv::Mat back = ReadPfm(path);
  EXPECT_TRUE(std::isinf(back.at<float>(0, 0)));
  EXPECT_EQ(back.at<float>(1, 2), 2.5f);
}

// The project's own encoders (libpng, libtiff, PFM by hand) read back bit for bit by OpenCV's
// decoders, an independent reader: every depth and channel count the writers take, NaN and
// infinity in float arrays, colour in OpenCV's BGR order.
TEST(WriteImageAtomic, EveryFormatReadsBackExactlyThroughAnotherDecoder) {
  util::ScopedTempDir tmp;
  cv::RNG rng(4);
  auto random = [&](int type) {
    cv::Mat m(13, 17, type);
    if (CV_MAT_DEPTH(type) == CV_32F) {
      rng.fill(m, cv::RNG::UNIFORM, -1e3, 1e3);
      m.at<float>(2, 3) = std::numeric_limits<float>::quiet_NaN();
      m.at<float>(5, 7) = std::numeric_limits<float>::infinity();
    } else {
      rng.fill(m, cv::RNG::UNIFORM, 0, CV_MAT_DEPTH(type) == CV_8U ? 256 : 65536);
    }
    return m;
  };
  auto same = [](const cv::Mat& a, const cv::Mat& b) {  // bit for bit, NaN included
    return a.type() == b.type() && a.size() == b.size() &&
           std::equal(a.datastart, a.dataend, b.datastart, b.dataend);
  };
  const std::vector<std::pair<std::string, std::vector<int>>> cases = {
      {".png", {CV_8UC1, CV_16UC1, CV_8UC3, CV_16UC3, CV_8UC4}},
      {".tif", {CV_8UC1, CV_16UC1, CV_32FC1, CV_8UC3, CV_32FC3}},
      {".pfm", {CV_32FC1, CV_32FC3}}};
  for (const auto& [ext, types] : cases) {
    for (const int type : types) {
      const cv::Mat m = random(type);
      const fs::path path = tmp.path() / ("m" + std::to_string(type) + ext);
      WriteImageAtomic(path, m);
      const cv::Mat back = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
      ASSERT_EQ(back.type(), m.type()) << path;
      if (!same(back, m)) {
        cv::Mat a, b;
        back.reshape(1).convertTo(a, CV_64F);
        m.reshape(1).convertTo(b, CV_64F);
        int k = 0;
        while (k < static_cast<int>(a.total()) && (a.at<double>(k) == b.at<double>(k) ||
                                                   (std::isnan(a.at<double>(k)) && std::isnan(b.at<double>(k))))) {
          ++k;
        }
        ADD_FAILURE() << path << ": value " << k << " of " << a.total() << " reads " << a.at<double>(k)
                      << ", written " << b.at<double>(k);
      }
    }
  }
  // Label maps (their own encoder) read back the same, through OpenCV's decoder and ours:
  // regions and noise, and a single pixel.
  cv::Mat labels(40, 50, CV_8UC1, cv::Scalar(0));
  cv::rectangle(labels, cv::Rect(5, 5, 20, 10), cv::Scalar(3), cv::FILLED);
  cv::Mat noise(40, 50, CV_8UC1);
  cv::randu(noise, 0, 256);
  noise.rowRange(30, 40).copyTo(labels.rowRange(30, 40));
  for (const cv::Mat& m : {labels, cv::Mat(1, 1, CV_8UC1, cv::Scalar(9))}) {
    WriteLabelImageAtomic(tmp.path() / "labels.png", m);
    EXPECT_TRUE(same(cv::imread((tmp.path() / "labels.png").string(), cv::IMREAD_UNCHANGED), m));
    EXPECT_TRUE(same(ReadImage(tmp.path() / "labels.png"), m));
  }
  // A refused write leaves nothing, not even a temporary file.
  EXPECT_THROW(WriteImageAtomic(tmp.path() / "x.tif", cv::Mat(2, 2, CV_64FC1)), std::exception);
  EXPECT_FALSE(fs::exists(tmp.path() / "x.tif"));
  // libtiff's own reason reaches the error, also after OpenImageIO's TIFF reader (which sets
  // libtiff's global handlers for itself) has read a TIFF in this process.
  cv::Mat grey(3, 4, CV_8UC1, cv::Scalar(9));
  WriteImageAtomic(tmp.path() / "g.tif", grey);
  EXPECT_TRUE(same(ReadImage(tmp.path() / "g.tif"), grey));  // through OpenImageIO
  try {
    WriteImageAtomic(tmp.path() / "empty.tif", cv::Mat(0, 0, CV_32FC1));
    ADD_FAILURE() << "an empty TIFF was written";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("empty.tif: cannot write TIFF ("), std::string::npos) << what;
    EXPECT_EQ(what.find("cannot create the file"), std::string::npos) << what;  // libtiff's reason, not ours
  }
  EXPECT_FALSE(fs::exists(tmp.path() / "empty.tif"));
  for (const auto& entry : fs::directory_iterator(tmp.path())) {
    EXPECT_EQ(entry.path().filename().string().find("lunarnav-tmp"), std::string::npos) << entry.path();
  }
}

// A 12-bit camera's grey levels in 16-bit words: the depth travels in the PNG's sBIT chunk
// (written and read by the project), and defaults to the container.
TEST(ReadGreyImage, ReportsSignificantBits) {
  util::ScopedTempDir tmp;
  cv::Mat twelve(8, 9, CV_16UC1);
  cv::randu(twelve, 0, 4096);
  WriteImageAtomic(tmp.path() / "a.png", twelve, 12);
  EXPECT_EQ(PngSignificantBits(tmp.path() / "a.png"), 12);
  SignificantBits bits;
  const cv::Mat read = ReadGreyImage(tmp.path() / "a.png", &bits);
  EXPECT_EQ(bits.bits, 12);
  EXPECT_EQ(bits.source, "PNG sBIT");
  EXPECT_EQ(cv::countNonZero(read != twelve), 0);  // the chunk is valid: the pixels read back
  EXPECT_TRUE(PngStructureProblem(tmp.path() / "a.png").empty());
  WriteImageAtomic(tmp.path() / "b.png", twelve);
  EXPECT_EQ(PngSignificantBits(tmp.path() / "b.png"), 0);
  ReadGreyImage(tmp.path() / "b.png", &bits);
  EXPECT_EQ(bits.bits, 16);
  EXPECT_EQ(bits.source, "image type");
  cv::Mat eight(8, 9, CV_8UC1, cv::Scalar(7));
  WriteImageAtomic(tmp.path() / "c.png", eight, 12);  // ignored for 8-bit data
  ReadGreyImage(tmp.path() / "c.png", &bits);
  EXPECT_EQ(bits.bits, 8);
}

// A 110-byte TIFF whose header claims 100,000 x 100,000 pixels is refused from its header, with
// one short message (libtiff would repeat itself for every strip it cannot read).
TEST(ReadGreyImage, RefusesAHeaderClaimingMorePixelsThanTheLimit) {
  util::ScopedTempDir tmp;
  std::string tiff = std::string("II*\0", 4) + std::string("\x08\0\0\0", 4) + std::string("\x08\0", 2);
  auto entry = [&](std::uint16_t tag, std::uint16_t type, std::uint32_t value) {
    const std::uint32_t count = 1;
    tiff.append(reinterpret_cast<const char*>(&tag), 2);
    tiff.append(reinterpret_cast<const char*>(&type), 2);
    tiff.append(reinterpret_cast<const char*>(&count), 4);
    tiff.append(reinterpret_cast<const char*>(&value), 4);  // little-endian host: SHORTs fit the low half
  };
  entry(256, 4, 100000);  // width
  entry(257, 4, 100000);  // height
  entry(258, 3, 8);
  entry(259, 3, 1);
  entry(262, 3, 1);
  entry(273, 4, 8);
  entry(277, 3, 1);
  entry(279, 4, 10);
  tiff.append(4, '\0');
  const auto path = tmp.path() / "huge.tif";
  std::ofstream(path, std::ios::binary) << tiff;
  try {
    ReadGreyImage(path);
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("the header claims 100000 x 100000 pixels"), std::string::npos) << what;
    EXPECT_LT(what.size(), 300u);
  }
}

// A PNG whose header claims 4294967295 x 4294967295 pixels: the size check itself must not
// overflow (the product of two 32-bit sizes does not fit a long long); refused from its header.
TEST(ReadGreyImage, RefusesAPngHeaderClaimingTheLargestSize) {
  util::ScopedTempDir tmp;
  std::string png = std::string("\x89PNG\r\n\x1a\n", 8) + std::string("\0\0\0\x0dIHDR", 8) +
                    std::string(8, '\xff') + std::string("\x08\0\0\0\0", 5) + std::string(4, '\0');
  const auto path = tmp.path() / "huge.png";
  std::ofstream(path, std::ios::binary) << png;
  try {
    ReadGreyImage(path);
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("the header claims 4294967295 x 4294967295 pixels"), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace lunarnav::io
