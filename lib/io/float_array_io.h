// Float arrays as OpenEXR images: 1- to 4-channel float32 maps (XYZ, predicted errors), NaN
// preserved, written atomically.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace lunarnav::io {

/// An EXR image read back: the pixels and what the file says about them.
struct ExrImage {
  cv::Mat pixels;                                ///< CV_32FC(n), top row first.
  std::vector<std::string> channel_names;        ///< As stored, e.g. {"R", "G", "B"}.
  std::map<std::string, std::string> attributes;  ///< String header attributes (metadata).
};

/// The header attribute WriteExrAtomic stamps every file with: "FIRST LAST", the rows that
/// hold a finite value ("0 -1": none); every other row is all NaN. ReadExr decodes only those
/// rows (a rig's default search fills a fifth of a KITTI pair's rows: its XYZ read five times
/// faster). A file that stamps too few rows is read with NaN in the rows it leaves out.
inline constexpr const char* kFiniteRowsAttribute = "lunarnav:finite_rows";

/// How WriteExrAtomic stores the channels: 32-bit floats (lossless), or 16-bit ones (11
/// significant bits, values to 65504, larger ones +inf: for quantities such as a predicted
/// error, where three digits say all there is; a third of the bytes, a third of the time).
enum class ExrStorage { kFloat32, kFloat16 };

/// Writes a float32 map as a scanline OpenEXR file (by default 32-bit float channels, ZIP
/// compression, lossless; NaN and infinities are kept as they are), stamped with kFiniteRowsAttribute (over
/// any value `attributes` gives it). The file is written under a hidden temporary name and
/// renamed, so `path` holds the complete file or nothing.
/// @param image  CV_32FC1 .. CV_32FC4, top row first; channel k of the Mat is channel k of
///        the file.
/// @param channel_names  one name per channel; empty = "Y" for one channel, "R","G","B"[,"A"]
///        otherwise (the names common viewers and readers, OpenCV's included, understand).
/// @param attributes  string metadata stored in the header (e.g. {"lunarnav:units", "m"}).
/// @throws std::invalid_argument for an unsupported Mat or a name count mismatch;
///         std::runtime_error when the file cannot be written.
void WriteExrAtomic(const std::filesystem::path& path, const cv::Mat& image,
                    const std::vector<std::string>& channel_names = {},
                    const std::map<std::string, std::string>& attributes = {},
                    ExrStorage storage = ExrStorage::kFloat32);

/// Loads the EXR reader (OpenImageIO, loaded on first use: about 0.2 s, once per process) now,
/// so that timings of the reads that follow measure reading only.
/// @throws std::runtime_error when it cannot be loaded.
void PreloadExrReader();

/// Reads an OpenEXR file as float32: the project's own arrays (one scanline part, channels Y or
/// R, G, B[, A], 32- or 16-bit floats) through OpenEXR's core API, which unpacks a block in one
/// pass (half the time of OpenImageIO's frame buffers, the same pixels), anything else through
/// OpenImageIO; a file stamped with
/// kFiniteRowsAttribute (a valid range of its rows) has only those rows decoded, the others NaN.
/// @throws InputError naming the file when it is missing, unreadable, not 2-D or not OpenEXR
///         (another format under an .exr name, told by its magic number).
ExrImage ReadExr(const std::filesystem::path& path);

}  // namespace lunarnav::io
