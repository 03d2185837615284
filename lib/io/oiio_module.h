// OpenImageIO (and OpenEXR's core API, for the project's own EXR arrays) behind a loadable
// module. Linking OpenImageIO into a tool costs about 0.2 s at every start (it brings some 250
// shared libraries); the tools load it only when they read or write a format that needs it
// (TIFF, JPEG, EXR, ...), never for PNG. Internal to io/.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace lunarnav::io::internal {

/// What the module does. Errors come back as text (no exception crosses the module's
/// boundary); the callers name the file and throw.
class OiioModule {
 public:
  virtual ~OiioModule() = default;
  /// Reads an 8- or 16-bit integer image with all its channels in the file's order (alpha
  /// not premultiplied). On failure returns false with `error` = "<kind>: <reason>", kind one
  /// of unreadable, not2d, type, channels, corrupt.
  /// Images of more than `max_pixels` pixels are refused from their header ("size: ...").
  virtual bool ReadInteger(const std::string& path, long long max_pixels, cv::Mat* pixels, int* bits_per_sample,
                           std::string* error) = 0;
  /// Writes a float map as a ZIP-compressed scanline OpenEXR file (no time stamp), its channels
  /// stored as 32-bit floats or, with `half`, 16-bit ones.
  virtual bool WriteExr(const std::string& path, const cv::Mat& image, const std::vector<std::string>& names,
                        const std::map<std::string, std::string>& attributes, bool half, std::string* error) = 0;
  /// Reads a float image (EXR and the like) with its channel names and string attributes; the
  /// project's own EXR arrays through OpenEXR's core API (the same pixels and names, the
  /// header's string attributes), anything else through OpenImageIO. On failure `error` as for
  /// ReadInteger.
  virtual bool ReadFloat(const std::string& path, long long max_pixels, cv::Mat* pixels, std::vector<std::string>* names,
                         std::map<std::string, std::string>* attributes, std::string* error) = 0;
};

/// Throws the InputError of a read error "<kind>: <reason>" from the module, naming `path`.
[[noreturn]] void ThrowModuleReadError(const std::filesystem::path& path, const std::string& error);

/// The module, loaded on first use (thread-safe): $LUNARNAV_OIIO_MODULE, else
/// liblunarnav_oiio.so beside the running program, else in the build's bin directory.
/// @throws std::runtime_error when it cannot be found or loaded.
OiioModule& Oiio();

}  // namespace lunarnav::io::internal

/// The module's entry point (extern "C", looked up by name).
extern "C" lunarnav::io::internal::OiioModule* lunarnav_oiio_module();
