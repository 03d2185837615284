// Float EXR images for the simulator's ground truth (truth/xyz/<stem>.exr).
//
// A local helper of the sim module: once io has a generic float-array writer, these two
// functions should be replaced by it.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace lunarnav::sim {

/// Writes a CV_32FC1 or CV_32FC3 image as a float32 OpenEXR file (ZIP compression, one
/// scanline per block, channels named `channel_names` in order), atomically (temporary file
/// + rename). NaN samples are kept.
void WriteFloatExrAtomic(const std::filesystem::path& path, const cv::Mat& image,
                         const std::vector<std::string>& channel_names);

/// Reads a float EXR written by WriteFloatExrAtomic into CV_32FC(channels), channels in file
/// order. @throws InputError naming the file when it cannot be read.
cv::Mat ReadFloatExr(const std::filesystem::path& path);

}  // namespace lunarnav::sim
