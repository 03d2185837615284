// The grey-level depth of 16-bit pairs that declare none: the noise estimator against known
// noise, and the inference on synthetic camera data of known depth.
#include "io/grey_depth.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace lunarnav::io {
namespace {

// A textured scene (smooth value noise of about 2-pixel cells and bright blobs) in [0, 1],
// the same for every camera below.
cv::Mat Scene(int seed) {
  cv::RNG rng(seed);
  cv::Mat coarse(60, 80, CV_32F);
  rng.fill(coarse, cv::RNG::UNIFORM, 0.0, 1.0);
  cv::Mat scene;
  cv::resize(coarse, scene, cv::Size(320, 240), 0, 0, cv::INTER_CUBIC);
  cv::Mat fine(120, 160, CV_32F);
  rng.fill(fine, cv::RNG::UNIFORM, 0.0, 1.0);
  cv::Mat fine_up;
  cv::resize(fine, fine_up, cv::Size(320, 240), 0, 0, cv::INTER_LINEAR);
  scene = 0.7 * scene + 0.3 * fine_up;
  cv::min(cv::max(scene, 0.0), 1.0, scene);
  return scene;
}

// The scene seen by a camera: full scale `scale` (4095 for 12 bits), Gaussian noise of `sigma`
// levels, rounded and clipped to [0, top] in 16-bit words.
cv::Mat Camera(const cv::Mat& scene, double scale, double sigma, double top, int seed) {
  cv::Mat v = scene * scale, noise(scene.size(), CV_32F);
  cv::RNG(seed).fill(noise, cv::RNG::NORMAL, 0.0, sigma);
  v += noise;
  cv::min(cv::max(v, 0.0), top, v);
  cv::Mat out;
  v.convertTo(out, CV_16U);
  return out;
}

TEST(EstimateNoiseSigma, RecoversWhiteNoiseOnASmoothImage) {
  cv::Mat ramp(240, 320, CV_32F);
  for (int y = 0; y < ramp.rows; ++y) {
    for (int x = 0; x < ramp.cols; ++x) ramp.at<float>(y, x) = 1000 + 3.0f * x + 0.01f * y * y;  // planar + quadratic
  }
  for (const double sigma : {2.0, 10.0, 100.0}) {
    cv::Mat noise(ramp.size(), CV_32F);
    cv::RNG(5).fill(noise, cv::RNG::NORMAL, 0.0, sigma);
    cv::Mat image;
    cv::Mat(ramp + noise).convertTo(image, CV_16U);
    EXPECT_NEAR(EstimateNoiseSigma(image), sigma, 0.06 * sigma + 0.3) << sigma;  // rounding adds 0.29
  }
  EXPECT_EQ(EstimateNoiseSigma(cv::Mat(2, 2, CV_16U, cv::Scalar(7))), 0.0);
}

TEST(InferSignificantBits, TwelveBitCameraDataWithoutSbitIsTwelveBits) {
  const cv::Mat scene = Scene(1);
  const cv::Mat left = Camera(scene, 4095, 3.0, 4095, 1), right = Camera(scene, 4095, 3.0, 4095, 2);
  const SignificantBits bits = InferSignificantBits(left, right, {16, "image type"});
  EXPECT_EQ(bits.bits, 12) << bits.source;
  EXPECT_EQ(bits.source.rfind("data (no sBIT): values up to", 0), 0u) << bits.source;
  // Ten and fourteen bits likewise, from the values they reach.
  EXPECT_EQ(InferSignificantBits(Camera(scene, 1023, 0.8, 1023, 1), Camera(scene, 1023, 0.8, 1023, 2),
                                 {16, "image type"}).bits, 10);
  EXPECT_EQ(InferSignificantBits(Camera(scene, 16383, 12, 16383, 1), Camera(scene, 16383, 12, 16383, 2),
                                 {16, "image type"}).bits, 14);
}

TEST(InferSignificantBits, ADarkSixteenBitImageWithASixteenBitCamerasNoiseStaysSixteen) {
  // A 16-bit camera's exposure that reaches only 3000 of 65535: its values fit 12 bits, its
  // noise (120 levels: shot and read noise of a 16-bit sensor) is 7.5 levels of 8 bits at 12.
  const cv::Mat scene = Scene(2);
  const cv::Mat left = Camera(scene, 2700, 120, 65535, 1), right = Camera(scene, 2700, 120, 65535, 2);
  double top = 0;
  cv::minMaxLoc(left, nullptr, &top);
  ASSERT_LT(top, 4096);
  const SignificantBits bits = InferSignificantBits(left, right, {16, "image type"});
  EXPECT_EQ(bits.bits, 16) << bits.source;
  EXPECT_NE(bits.source.find("dark 16-bit image"), std::string::npos) << bits.source;
}

TEST(InferSignificantBits, DeclaredDepthsAndFullRangeDataAreKept) {
  const cv::Mat scene = Scene(3);
  const cv::Mat twelve = Camera(scene, 4095, 3.0, 4095, 1);
  // An sBIT, --bit-depth, a rescaled TIFF: what they say stands.
  for (const SignificantBits& declared :
       {SignificantBits{12, "PNG sBIT"}, SignificantBits{16, "image type (a 12-bit file, read rescaled)"}}) {
    const SignificantBits bits = InferSignificantBits(twelve, twelve, declared);
    EXPECT_EQ(bits.bits, declared.bits);
    EXPECT_EQ(bits.source, declared.source);
  }
  // 8-bit images are 8-bit.
  cv::Mat eight;
  scene.convertTo(eight, CV_8U, 255.0);
  EXPECT_EQ(InferSignificantBits(eight, eight, {8, "image type"}).bits, 8);
  // Data that reach the top bit are 16-bit.
  const cv::Mat full = Camera(scene, 65535, 40, 65535, 4);
  const SignificantBits bits = InferSignificantBits(full, full, {16, "image type"});
  EXPECT_EQ(bits.bits, 16);
  EXPECT_NE(bits.source.find("use all 16 bits"), std::string::npos) << bits.source;
}

}  // namespace
}  // namespace lunarnav::io
