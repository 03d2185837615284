// Reading grey images and writing images and float arrays atomically.
#pragma once

#include <filesystem>
#include <string>

#include <opencv2/core.hpp>

namespace lunarnav::io {

/// How many bits of an image's grey levels carry data, and where that came from: a 12-bit
/// camera's 0..4095 stored in 16-bit words has 12 ("PNG sBIT" when the file says so);
/// otherwise the container's 8 or 16 ("image type"). A TIFF of 12 bits per sample is read
/// rescaled to 0..65535, so it counts as 16. Data stored without either (0..4095 in a plain
/// 16-bit file) is told from its values and noise by io::InferSignificantBits.
struct SignificantBits {
  int bits = 8;
  std::string source = "image type";
};

/// The largest image (width x height, pixels) the readers accept: a file claiming more is
/// refused from its header, before anything is allocated (a damaged or hostile header would
/// otherwise ask for terabytes). Default kDefaultMaxImagePixels; the tools' --max-pixels.
inline constexpr long long kDefaultMaxImagePixels = 1LL << 28;  // 268 million, e.g. 16384 x 16384
void SetMaxImagePixels(long long pixels);
long long MaxImagePixels();

/// The sBIT chunk of a PNG file: the colour channels' largest significant bit count, or 0
/// when the file has none, an invalid one (as libpng judges it: the reader's own rule), or
/// cannot be read.
int PngSignificantBits(const std::filesystem::path& path);

/// Reads an 8- or 16-bit image (PNG, PGM/PPM, TIFF, JPEG, ...) as one grey channel.
/// Colour is converted with the Rec. 601 luma weights (as OpenCV's cvtColor does);
/// an alpha channel is ignored. Decoding is done by OpenImageIO, which reports
/// truncated and corrupt files instead of returning partial pixels.
/// @return CV_8UC1 or CV_16UC1.
/// @throws InputError naming the file and the reason (missing, unreadable, truncated,
///         float or 32-bit pixels, empty).
/// @param bits  when given, receives the image's significant bits.
cv::Mat ReadGreyImage(const std::filesystem::path& path, SignificantBits* bits = nullptr);

/// Reads an 8- or 16-bit image keeping its colour: one channel for grey (and grey + alpha),
/// three in OpenCV's BGR order for colour; an alpha channel is dropped. Same checks and
/// errors as ReadGreyImage.
/// @return CV_8UC1, CV_8UC3, CV_16UC1 or CV_16UC3.
cv::Mat ReadImage(const std::filesystem::path& path, SignificantBits* bits = nullptr);

/// What is wrong with the chunk structure of a PNG file (signature, chunk lengths, CRCs, the
/// closing IEND chunk), or "" when it is sound.
std::string PngStructureProblem(const std::filesystem::path& path);

/// True when the file extension is one ReadGreyImage is meant for
/// (.png .pgm .ppm .pnm .tif .tiff .jpg .jpeg, any case).
bool HasImageExtension(const std::filesystem::path& path);

/// Encodes `image` in the format given by the extension of `path` and writes it atomically.
/// Supported: .png (8/16-bit), .tif/.tiff (8/16-bit or float32), .pfm (float32, 1 or 3
/// channels, rows bottom to top with scale -1 as the Middlebury benchmark writes them).
/// `significant_bits` (1..15, 16-bit PNG only): recorded in an sBIT chunk, so that a 12-bit
/// camera's data stays known as such; 0 = none.
void WriteImageAtomic(const std::filesystem::path& path, const cv::Mat& image, int significant_bits = 0);

/// As WriteImageAtomic, for a map of a few labels (rejection reasons, truth labels): a PNG is
/// written without row filters and at zlib's fastest level, which on such maps is a third of
/// the time and a quarter smaller than the settings that suit photographs.
void WriteLabelImageAtomic(const std::filesystem::path& path, const cv::Mat& labels);

/// Reads a PFM file into CV_32FC1 or CV_32FC3 (top row first, as in memory).
/// @throws InputError when the file is missing or is not a PFM.
cv::Mat ReadPfm(const std::filesystem::path& path);

}  // namespace lunarnav::io
