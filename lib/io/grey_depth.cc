#include "io/grey_depth.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "util/format.h"

namespace lunarnav::io {

double EstimateNoiseSigma(const cv::Mat& grey) {
  CV_Assert(grey.channels() == 1);
  if (grey.rows < 3 || grey.cols < 3) return 0.0;
  cv::Mat f;
  grey.convertTo(f, CV_32F);
  const cv::Mat mask = (cv::Mat_<float>(3, 3) << 1, -2, 1, -2, 4, -2, 1, -2, 1);
  cv::Mat response;
  cv::filter2D(f, response, CV_32F, mask);
  // The image's activity at the scale of its structure (the gradient of the image smoothed
  // over a few pixels, where the noise has mostly averaged out): the quarter of the pixels
  // where it is least are the plainest, and their responses the least touched by texture.
  cv::Mat smooth, gx, gy;
  cv::GaussianBlur(f, smooth, cv::Size(0, 0), 2.0);
  cv::Sobel(smooth, gx, CV_32F, 1, 0);
  cv::Sobel(smooth, gy, CV_32F, 0, 1);
  const cv::Mat activity = gx.mul(gx) + gy.mul(gy);
  std::vector<float> levels;
  levels.reserve(static_cast<std::size_t>(grey.rows - 2) * (grey.cols - 2));
  for (int y = 1; y + 1 < grey.rows; ++y) {  // the border's responses use replicated pixels
    const float* a = activity.ptr<float>(y);
    for (int x = 1; x + 1 < grey.cols; ++x) levels.push_back(a[x]);
  }
  auto quarter = levels.begin() + static_cast<std::ptrdiff_t>(levels.size() / 4);
  std::nth_element(levels.begin(), quarter, levels.end());
  const float plain = *quarter;
  std::vector<float> magnitudes;
  magnitudes.reserve(levels.size() / 4 + 1);
  for (int y = 1; y + 1 < grey.rows; ++y) {
    const float* a = activity.ptr<float>(y);
    const float* r = response.ptr<float>(y);
    for (int x = 1; x + 1 < grey.cols; ++x) {
      if (a[x] <= plain) magnitudes.push_back(std::abs(r[x]));
    }
  }
  auto middle = magnitudes.begin() + static_cast<std::ptrdiff_t>(magnitudes.size() / 2);
  std::nth_element(magnitudes.begin(), middle, magnitudes.end());
  return *middle / (0.6745 * 6.0);
}

namespace {

// One grey channel (colour by the Rec. 601 luma weights, as the matcher reads it).
cv::Mat Grey(const cv::Mat& image) {
  if (image.channels() == 1) return image;
  cv::Mat grey;
  cv::cvtColor(image, grey, image.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
  return grey;
}

}  // namespace

SignificantBits InferSignificantBits(const cv::Mat& left, const cv::Mat& right, const SignificantBits& declared) {
  if (declared.bits != 16 || declared.source != "image type" || left.depth() != CV_16U || right.depth() != CV_16U) {
    return declared;
  }
  double max_left = 0, max_right = 0;
  cv::minMaxLoc(left.reshape(1), nullptr, &max_left);
  cv::minMaxLoc(right.reshape(1), nullptr, &max_right);
  const auto largest = static_cast<unsigned>(std::max(max_left, max_right));
  const int needed = std::max(8, static_cast<int>(std::bit_width(largest)));
  if (needed >= 16) return {16, util::Format("image type (values up to %u use all 16 bits)", largest)};
  const double noise = std::min(EstimateNoiseSigma(Grey(left)), EstimateNoiseSigma(Grey(right)));
  const double noise_grey8 = noise / std::ldexp(1.0, needed - 8);
  if (noise_grey8 > kMaxCameraNoiseGrey8) {
    return {16, util::Format(
                  "image type (values up to %u would fit %d bits, but their noise, %.1f levels = %.1f levels of 8 "
                  "bits at %d bits, is more than a camera's at that depth: a dark 16-bit image)",
                  largest, needed, noise, noise_grey8, needed)};
  }
  return {needed, util::Format("data (no sBIT): values up to %u need %d bits, noise %.1f levels = %.2f levels of 8 bits",
                               largest, needed, noise, noise_grey8)};
}

}  // namespace lunarnav::io
