// A picture of a matched pair for people: the disparity colour-mapped with a legend, every
// rejected pixel marked by its reason (stereo-batch --preview).
#pragma once

#include <opencv2/core.hpp>

#include "stereo/ncc_options.h"

namespace lunarnav::stereo {

/// The colour (BGR) that marks pixels rejected for `reason` in previews (kAccepted: none).
cv::Vec3b RejectionColour(Rejection reason);

/// The colour of disparity d on the preview's scale [d_min, d_max] (OpenCV's Turbo map;
/// values outside are clamped).
cv::Vec3b DisparityColour(double d, double d_min, double d_max);

/// The preview of `result`: the reference image's size on top, accepted pixels in their
/// disparity's colour, rejected ones in their reason's colour over the dimmed grey image (not
/// evaluated: the grey image itself); with partial subsampling each grid pixel fills its
/// dx x dy cell. Below, a legend: the colour bar from d_min to d_max with its values, and
/// the reasons present with their share of the evaluated pixels.
/// @param reference  the reference image, CV_8UC1 or CV_16UC1 (bit_depth significant bits).
/// @return CV_8UC3 (BGR), width = the image's, height = the image's + the legend's.
cv::Mat DisparityPreview(const NccResult& result, const cv::Mat& reference, int bit_depth, int step_x, int step_y,
                         double d_min, double d_max);

}  // namespace lunarnav::stereo
