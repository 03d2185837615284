// Reading grey images and writing images and float arrays atomically.
#pragma once

#include <filesystem>
#include <string>

#include <opencv2/core.hpp>

namespace lunarnav::io {

/// Reads an 8- or 16-bit image (PNG, PGM/PPM, TIFF, JPEG, ...) as one grey channel.
/// Colour is converted with the Rec. 601 luma weights (as OpenCV's cvtColor does);
/// an alpha channel is ignored. Decoding is done by OpenImageIO, which reports
/// truncated and corrupt files instead of returning partial pixels.
/// @return CV_8UC1 or CV_16UC1.
/// @throws InputError naming the file and the reason (missing, unreadable, truncated,
///         float or 32-bit pixels, empty).
cv::Mat ReadGreyImage(const std::filesystem::path& path);

/// Reads an 8- or 16-bit image keeping its colour: one channel for grey (and grey + alpha),
/// three in OpenCV's BGR order for colour; an alpha channel is dropped. Same checks and
/// errors as ReadGreyImage.
/// @return CV_8UC1, CV_8UC3, CV_16UC1 or CV_16UC3.
cv::Mat ReadImage(const std::filesystem::path& path);

/// What is wrong with the chunk structure of a PNG file (signature, chunk lengths, CRCs, the
/// closing IEND chunk), or "" when it is sound.
std::string PngStructureProblem(const std::filesystem::path& path);

/// True when the file extension is one ReadGreyImage is meant for
/// (.png .pgm .ppm .pnm .tif .tiff .jpg .jpeg, any case).
bool HasImageExtension(const std::filesystem::path& path);

/// Encodes `image` in the format given by the extension of `path` and writes it atomically.
/// Supported: .png (8/16-bit), .tif/.tiff (8/16-bit or float32), .pfm (float32, 1 or 3
/// channels, rows bottom to top with scale -1 as the Middlebury benchmark writes them).
void WriteImageAtomic(const std::filesystem::path& path, const cv::Mat& image);

/// Reads a PFM file into CV_32FC1 or CV_32FC3 (top row first, as in memory).
/// @throws InputError when the file is missing or is not a PFM.
cv::Mat ReadPfm(const std::filesystem::path& path);

}  // namespace lunarnav::io
