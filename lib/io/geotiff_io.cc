#include "io/geotiff_io.h"

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <memory>
#include <mutex>

#include <cpl_conv.h>
#include <cpl_error.h>
#include <gdal_priv.h>

#include "io/atomic_file.h"
#include "util/check.h"
#include "util/errors.h"

namespace lunarnav::io {
namespace fs = std::filesystem;

namespace {

// A local engineering coordinate system: x east, y north, metres (no map projection).
constexpr const char* kLocalCrsWkt =
    "LOCAL_CS[\"lunarnav local frame (x east, y north, z up; metres)\","
    "LOCAL_DATUM[\"lunarnav world frame\",0],UNIT[\"metre\",1],"
    "AXIS[\"Easting\",EAST],AXIS[\"Northing\",NORTH]]";

void RegisterGdal() {
  static std::once_flag once;
  std::call_once(once, [] {
    GDALRegister_GTiff();
    CPLSetErrorHandler(CPLQuietErrorHandler);  // messages reach the user through exceptions
  });
}

std::string LastGdalError() {
  const char* message = CPLGetLastErrorMsg();
  return message != nullptr && *message != '\0' ? message : "unknown GDAL error";
}

struct DatasetCloser {
  void operator()(GDALDataset* d) const { GDALClose(d); }
};
using DatasetPtr = std::unique_ptr<GDALDataset, DatasetCloser>;

// A GDAL object's default-domain metadata as a map.
std::map<std::string, std::string> MetadataOf(GDALMajorObject* object) {
  std::map<std::string, std::string> out;
  char** md = object->GetMetadata();
  for (int i = 0; md != nullptr && md[i] != nullptr; ++i) {
    char* key = nullptr;
    const char* value = CPLParseNameValue(md[i], &key);
    if (key != nullptr && value != nullptr) out[key] = value;
    CPLFree(key);
  }
  return out;
}

}  // namespace

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
  RegisterGdal();
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  LN_CHECK(driver != nullptr) << "GDAL has no GTiff driver";
  if (!path.parent_path().empty()) fs::create_directories(path.parent_path());
  const fs::path temp = TempPathFor(path);
  char** create_options = nullptr;
  create_options = CSLSetNameValue(create_options, "TILED", "YES");
  create_options = CSLSetNameValue(create_options, "COMPRESS", "DEFLATE");
  create_options = CSLSetNameValue(create_options, "PREDICTOR", "3");  // floating-point predictor
  create_options = CSLSetNameValue(create_options, "INTERLEAVE", "BAND");
  const GDALDataType type = depth == CV_64F ? GDT_Float64 : GDT_Float32;
  {
    DatasetPtr ds(driver->Create(temp.c_str(), raster.Width(), raster.Height(),
                                 static_cast<int>(raster.bands.size()), type, create_options));
    CSLDestroy(create_options);
    if (ds == nullptr) throw std::runtime_error(path.string() + ": cannot create GeoTIFF (" + LastGdalError() + ")");
    double transform[6] = {raster.x_west_m, raster.cell_m, 0.0, raster.y_north_m, 0.0, -raster.cell_m};
    ds->SetGeoTransform(transform);
    ds->SetProjection(kLocalCrsWkt);
    for (const auto& [key, value] : raster.metadata) ds->SetMetadataItem(key.c_str(), value.c_str());
    for (std::size_t i = 0; i < raster.bands.size(); ++i) {
      const RasterBand& b = raster.bands[i];
      GDALRasterBand* band = ds->GetRasterBand(static_cast<int>(i) + 1);
      band->SetDescription(b.description.c_str());
      band->SetNoDataValue(b.nodata);
      for (const auto& [key, value] : b.metadata) band->SetMetadataItem(key.c_str(), value.c_str());
      const cv::Mat pixels = b.pixels.isContinuous() ? b.pixels : b.pixels.clone();
      const CPLErr err = band->RasterIO(GF_Write, 0, 0, raster.Width(), raster.Height(),
                                        const_cast<void*>(static_cast<const void*>(pixels.data)), raster.Width(),
                                        raster.Height(), type, 0, 0);
      if (err != CE_None) {
        ds.reset();
        fs::remove(temp);
        throw std::runtime_error(path.string() + ": cannot write band " + std::to_string(i + 1) + " (" +
                                 LastGdalError() + ")");
      }
    }
  }  // closed: everything flushed
  CommitTempFile(temp, path);
}

namespace {
// What ReadGeoTiff accepts (docs/reliability.md): the largest map terrain-map makes by default
// is 2^22 cells in up to 48 bands of 8 bytes (its state).
constexpr std::int64_t kMaxRasterCells = std::int64_t{1} << 25;
constexpr int kMaxRasterBands = 64;
constexpr std::int64_t kMaxRasterBytes = std::int64_t{2} << 30;
constexpr double kMaxRasterOriginM = 1e7;
constexpr double kMinRasterCellM = 1e-3, kMaxRasterCellM = 1e4;
}  // namespace

GeoRaster ReadGeoTiff(const fs::path& path) {
  RegisterGdal();
  LN_CHECK_INPUT(fs::is_regular_file(path)) << path.string() << ": no such file";
  // Only GDAL's GeoTIFF driver: a VRT (a text file naming other files) or any other format
  // GDAL would open is not what the tools write, and may declare what it does not hold.
  const char* const drivers[] = {"GTiff", nullptr};
  DatasetPtr ds(static_cast<GDALDataset*>(
      GDALOpenEx(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, drivers, nullptr, nullptr)));
  LN_CHECK_INPUT(ds != nullptr) << path.string() << ": not a readable GeoTIFF (" << LastGdalError() << ")";
  double t[6];
  LN_CHECK_INPUT(ds->GetGeoTransform(t) == CE_None) << path.string() << ": no geotransform";
  LN_CHECK_INPUT(std::isfinite(t[0]) && std::isfinite(t[3]) && std::abs(t[0]) <= kMaxRasterOriginM &&
                 std::abs(t[3]) <= kMaxRasterOriginM)
      << path.string() << ": its origin (" << t[0] << ", " << t[3] << ") is not within " << kMaxRasterOriginM
      << " m of the world origin";
  LN_CHECK_INPUT(t[2] == 0 && t[4] == 0 && std::isfinite(t[1]) && t[1] >= kMinRasterCellM && t[1] <= kMaxRasterCellM &&
                 std::abs(t[5] + t[1]) <= 1e-9 * t[1])
      << path.string() << ": expected a north-up grid of square cells of " << kMinRasterCellM << " to "
      << kMaxRasterCellM << " m (geotransform " << t[1] << ", " << t[2] << ", " << t[4] << ", " << t[5] << ")";
  // What it declares, before anything is allocated: a size within the limits, and every block
  // of every band present in the file (a sparse file of a few kilobytes can declare 10^10 cells).
  const std::int64_t declared_w = ds->GetRasterXSize(), declared_h = ds->GetRasterYSize();
  const int declared_bands = ds->GetRasterCount();
  LN_CHECK_INPUT(declared_w >= 1 && declared_h >= 1 && declared_w * declared_h <= kMaxRasterCells &&
                 declared_bands >= 1 && declared_bands <= kMaxRasterBands &&
                 declared_w * declared_h * declared_bands * 8 <= kMaxRasterBytes)
      << path.string() << ": declares " << declared_w << " x " << declared_h << " cells in " << declared_bands
      << " bands; a map holds at most " << kMaxRasterCells << " cells and " << kMaxRasterBands << " bands ("
      << (kMaxRasterBytes >> 20) << " MiB)";
  for (int i = 1; i <= declared_bands; ++i) {
    GDALRasterBand* band = ds->GetRasterBand(i);
    int bw = 0, bh = 0;
    band->GetBlockSize(&bw, &bh);
    LN_CHECK_INPUT(bw >= 1 && bh >= 1) << path.string() << ": band " << i << " has no block size";
    const std::int64_t nx = (declared_w + bw - 1) / bw, ny = (declared_h + bh - 1) / bh;
    for (std::int64_t by = 0; by < ny; ++by) {
      for (std::int64_t bx = 0; bx < nx; ++bx) {
        const std::string key = "BLOCK_OFFSET_" + std::to_string(bx) + "_" + std::to_string(by);
        const char* offset = band->GetMetadataItem(key.c_str(), "TIFF");
        LN_CHECK_INPUT(offset != nullptr && std::strtoll(offset, nullptr, 10) > 0)
            << path.string() << ": band " << i << " lacks block (" << bx << ", " << by
            << "): a sparse file that declares more than it holds";
      }
    }
  }
  GeoRaster r;
  r.x_west_m = t[0];
  r.y_north_m = t[3];
  r.cell_m = t[1];
  r.metadata = MetadataOf(ds.get());
  const int w = ds->GetRasterXSize(), h = ds->GetRasterYSize();
  for (int i = 1; i <= ds->GetRasterCount(); ++i) {
    GDALRasterBand* band = ds->GetRasterBand(i);
    RasterBand b;
    b.description = band->GetDescription();
    int has_nodata = 0;
    const double nodata = band->GetNoDataValue(&has_nodata);
    if (has_nodata) b.nodata = nodata;
    b.metadata = MetadataOf(band);
    const bool f64 = band->GetRasterDataType() == GDT_Float64;
    b.pixels.create(h, w, f64 ? CV_64FC1 : CV_32FC1);
    const CPLErr err = band->RasterIO(GF_Read, 0, 0, w, h, b.pixels.data, w, h, f64 ? GDT_Float64 : GDT_Float32, 0, 0);
    LN_CHECK_INPUT(err == CE_None) << path.string() << ": cannot read band " << i << " (" << LastGdalError() << ")";
    r.bands.push_back(std::move(b));
  }
  LN_CHECK_INPUT(!r.bands.empty()) << path.string() << ": no bands";
  return r;
}

}  // namespace lunarnav::io
