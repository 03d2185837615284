// The quality preset's matcher (Aggregation::kSemiGlobal). Internal to the stereo module:
// callers use MatchStereoPair, which dispatches on NccOptions::aggregation.
#pragma once

#include <opencv2/core.hpp>

#include "stereo/ncc_options.h"

namespace lunarnav::stereo::internal {

/// Census cost, semi-global aggregation over the grid of partial subsampling, winner-take-all
/// with a parabolic sub-pixel vertex, then the filters in order: texture (min_sigma over the
/// census window), range edge, lobe-aware ambiguity, correlation C_min (normalized correlation
/// over the window at the chosen disparity, also the confidence map), left-right check,
/// median, speckles. Runs in the caller's TBB arena. Images are validated by the caller.
/// @param bit_depth  significant bits of the grey levels (scales min_sigma).
void MatchSemiGlobal(const NccOptions& options, const cv::Mat& left, const cv::Mat& right, int bit_depth,
                     NccResult* result);

}  // namespace lunarnav::stereo::internal
