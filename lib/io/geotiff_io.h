// Multi-band float rasters on a local metric grid as GeoTIFF files, through GDAL.
//
// The grid's frame is the world frame of the tools (x east, y north, metres; docs/frames.md):
// row 0 is the northern edge (GeoTIFF rows run north to south), so the geotransform is
// (x_west_m, cell_m, 0, y_north_m, 0, -cell_m). The coordinate system is a local engineering
// one (an ENGCRS "lunarnav local", metre units), not a map projection. Invalid cells hold the
// band's no-data value (NaN unless set otherwise).
#pragma once

#include <filesystem>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace lunarnav::io {

/// One band: its pixels (CV_32FC1 or CV_64FC1, rows north to south), its description (the
/// layer name GDAL and QGIS show) and string metadata items (e.g. "units").
struct RasterBand {
  cv::Mat pixels;
  std::string description;
  std::map<std::string, std::string> metadata;
  double nodata = std::numeric_limits<double>::quiet_NaN();  ///< No-data value written for the band.
};

/// A georeferenced stack of equal-size bands.
struct GeoRaster {
  double x_west_m = 0;   ///< x of the western edge of column 0, metres.
  double y_north_m = 0;  ///< y of the northern edge of row 0, metres.
  double cell_m = 1;     ///< Square cell size, metres, > 0.
  std::vector<RasterBand> bands;
  std::map<std::string, std::string> metadata;  ///< Dataset metadata items.

  int Width() const { return bands.empty() ? 0 : bands.front().pixels.cols; }
  int Height() const { return bands.empty() ? 0 : bands.front().pixels.rows; }
  /// Index of the band described `description`, or -1.
  int BandIndex(const std::string& description) const;
  /// World x, y of the centre of cell (col, row).
  double CellCentreX(int col) const { return x_west_m + (col + 0.5) * cell_m; }
  double CellCentreY(int row) const { return y_north_m - (row + 0.5) * cell_m; }
};

/// Writes `raster` as a tiled, DEFLATE-compressed GeoTIFF (Float32 or Float64 by the first
/// band's depth; every band the same size and depth) with the geotransform, the local
/// coordinate system, each band's description, metadata and no-data value. The file is
/// written under a hidden temporary name and renamed.
/// @throws std::invalid_argument for an empty raster or mismatched bands; std::runtime_error
///         when GDAL cannot write the file.
void WriteGeoTiffAtomic(const std::filesystem::path& path, const GeoRaster& raster);

/// Reads a GeoTIFF (or any raster GDAL reads) whose geotransform is north-up with square cells.
/// Bands keep their type when Float64, else become CV_32F.
/// @throws InputError naming the file when it is missing, unreadable, rotated or not square.
GeoRaster ReadGeoTiff(const std::filesystem::path& path);

}  // namespace lunarnav::io
