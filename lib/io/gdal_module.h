// GDAL behind a loadable module, as OpenImageIO is (io/oiio_module.h): linked into a tool, GDAL
// and the ~90 libraries it brings would load at every start; the tools load it only when they
// read or write a map. Internal to io/.
#pragma once

#include <string>

#include "io/geotiff_io.h"

namespace lunarnav::io::internal {

/// What the module does. No exception crosses its boundary: errors come back as the whole
/// message (the file named), and the callers throw.
class GdalModule {
 public:
  virtual ~GdalModule() = default;
  /// Writes `raster` (checked by the caller) to `path` as WriteGeoTiffAtomic describes, not
  /// atomically (the caller writes a temporary name). False with `error` on failure.
  virtual bool WriteGeoTiff(const std::string& path, const GeoRaster& raster, std::string* error) = 0;
  /// Reads a GeoTIFF with ReadGeoTiff's checks. False with `error` (the file named) when the
  /// file is not one, declares more than the limits or than it holds, or cannot be read.
  virtual bool ReadGeoTiff(const std::string& path, GeoRaster* raster, std::string* error) = 0;
};

/// The module, loaded on first use (thread-safe): $LUNARNAV_GDAL_MODULE, else
/// liblunarnav_gdal.so beside the running program, else in the build's bin directory.
/// @throws std::runtime_error when it cannot be found or loaded.
GdalModule& Gdal();

}  // namespace lunarnav::io::internal

/// The module's entry point (extern "C", looked up by name).
extern "C" lunarnav::io::internal::GdalModule* lunarnav_gdal_module();
