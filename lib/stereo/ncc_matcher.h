// The normalized-correlation stereo matcher of Krotkov & Hebert, "Mapping and Positioning
// for a Prototype Lunar Rover" (ICRA 1995), sections 3.2-3.4.
#pragma once

#include <string>

#include <opencv2/core.hpp>

#include "stereo/ncc_options.h"

namespace lunarnav::stereo {

/// Matches a rectified stereo pair (epipolar lines = image rows).
///
/// For each pixel (x, y) of the reference image on the subsampling grid inside the row band,
/// C(x, y, d) = (sum_W I_l I_r / n - sum_W I_l sum_W I_r / n^2) / (sigma_l sigma_r) is
/// evaluated for every integer d in [d_min, d_max] whose target window lies inside the image
/// (right reference: I_l at x + d; left reference: I_r at x - d), W being the window of
/// half-size (w_x, w_y) subsampled by (dx, dy). The best d is refined by parabolic
/// interpolation and accepted if it passes the filters of sec. 3.2 (sigma_min, C_min,
/// ambiguity M, median). Pixel (x, y) has its centre at integer coordinates.
///
/// @param options  matcher parameters (validated here; throws std::invalid_argument).
/// @param left, right  rectified images, CV_8UC1 or CV_16UC1, same size and type.
/// @return maps in the reference image's pixel grid and a summary.
/// @throws InputError when the images are empty or differ in size or type.
NccResult MatchStereoPair(const NccOptions& options, const cv::Mat& left, const cv::Mat& right);

/// As above, writing into `result`, whose maps are reused when they already have the right
/// size (saves mapping fresh memory for every pair of a long sequence).
void MatchStereoPair(const NccOptions& options, const cv::Mat& left, const cv::Mat& right,
                     NccResult* result);

/// The significant bits the grey-level thresholds are scaled for: options.bit_depth when set
/// (at most the image type's), else 8 for CV_8U and 16 for CV_16U images.
int EffectiveBitDepth(const NccOptions& options, const cv::Mat& image);

/// Name of the SIMD kernel this CPU uses: "avx512", "avx2" or "baseline" (the first the CPU
/// supports, unless the LUNARNAV_SIMD environment variable caps it).
std::string ActiveKernelName();

}  // namespace lunarnav::stereo
