#include "io/geotiff_io.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "io/atomic_file.h"
#include "io/gdal_module.h"
#include "util/check.h"
#include "util/errors.h"

namespace lunarnav::io {
namespace fs = std::filesystem;

int GeoRaster::BandIndex(const std::string& description) const {
  for (std::size_t i = 0; i < bands.size(); ++i) {
    if (bands[i].description == description) return static_cast<int>(i);
  }
  return -1;
}

void WriteGeoTiffAtomic(const fs::path& path, const GeoRaster& raster) {
  LN_CHECK_ARG(!raster.bands.empty() && raster.Width() > 0 && raster.Height() > 0)
      << path.string() << ": an empty raster";
  LN_CHECK_ARG(std::isfinite(raster.cell_m) && raster.cell_m > 0) << path.string() << ": cell size must be > 0";
  const int depth = raster.bands.front().pixels.depth();
  LN_CHECK_ARG(depth == CV_32F || depth == CV_64F) << path.string() << ": bands must be float32 or float64";
  for (const RasterBand& b : raster.bands) {
    LN_CHECK_ARG(b.pixels.rows == raster.Height() && b.pixels.cols == raster.Width() && b.pixels.type() == CV_MAKETYPE(depth, 1))
        << path.string() << ": band '" << b.description << "' differs in size or type from the first";
  }
  internal::GdalModule& gdal = internal::Gdal();
  if (!path.parent_path().empty()) fs::create_directories(path.parent_path());
  const fs::path temp = TempPathFor(path);
  std::string error;
  if (!gdal.WriteGeoTiff(temp.string(), raster, &error)) {
    std::error_code ec;
    fs::remove(temp, ec);
    throw std::runtime_error(error);
  }
  CommitTempFile(temp, path);
}

GeoRaster ReadGeoTiff(const fs::path& path) {
  LN_CHECK_INPUT(fs::is_regular_file(path)) << path.string() << ": no such file";
  GeoRaster raster;
  std::string error;
  if (!internal::Gdal().ReadGeoTiff(path.string(), &raster, &error)) throw InputError(error);
  return raster;
}

}  // namespace lunarnav::io
