// The grey-level depth of 16-bit images that do not declare it: a 12-bit camera's 0..4095 in
// 16-bit words without an sBIT chunk, as most machine-vision and planetary cameras write them,
// told from a 16-bit image that happens to be dark. docs/stereo-matcher.md, "Grey-level depth".
#pragma once

#include <string>

#include <opencv2/core.hpp>

#include "io/image_io.h"

namespace lunarnav::io {

/// The camera noise of an image, in its own grey levels: Immerkaer's estimator (Fast noise
/// variance estimation, CVIU 1996) made robust to texture: the image filtered with the mask
/// [1 -2 1; -2 4 -2; 1 -2 1], which cancels its locally planar and quadratic parts, then
/// sigma = median |response| / (0.6745 x 6) (the mask's response to white noise of sigma has a
/// standard deviation of 6 sigma) over the plainest quarter of the pixels (least gradient of the
/// image smoothed by a Gaussian of 2 px, where the noise has averaged out), where texture and
/// edges touch the response least. 0 for images smaller than 3 x 3.
double EstimateNoiseSigma(const cv::Mat& grey);

/// Noise above this, in grey levels of 8 bits at a candidate depth, is no camera's at that
/// depth (8-bit cameras' noise is a fraction of a level to about 2 levels).
inline constexpr double kMaxCameraNoiseGrey8 = 4.0;

/// The significant bits of a pair whose files declared `declared` (the deeper of the two, as
/// ReadGreyImage gives it). Only a 16-bit pair whose depth comes from the image type alone (no
/// sBIT, not a rescaled TIFF) is examined; any other declaration is returned as it is:
///   - b = the bits that the pair's largest value needs (at least 8): 4094 needs 12;
///   - the pair is taken as b-bit data when its noise (EstimateNoiseSigma, the smaller of the
///     two images': texture only raises the estimate) is a camera's at b bits, at most
///     kMaxCameraNoiseGrey8 grey levels of 8 bits (sigma / 2^(b - 8)); a dark 16-bit image,
///     whose values fit fewer bits but whose noise is a 16-bit camera's (tens of levels at b
///     bits), stays 16.
/// The source says which and why, with the numbers ("data: values up to 4094 need 12 bits,
/// noise 3.1 levels = 0.19 levels of 8 bits").
SignificantBits InferSignificantBits(const cv::Mat& left, const cv::Mat& right, const SignificantBits& declared);

}  // namespace lunarnav::io
