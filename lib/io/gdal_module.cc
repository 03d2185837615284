// The GDAL module (liblunarnav_gdal.so): everything the project does with GDAL.
#include "io/gdal_module.h"

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>

#include <cpl_conv.h>
#include <cpl_error.h>
#include <gdal_priv.h>

namespace lunarnav::io::internal {
namespace {

// A local engineering coordinate system: x east, y north, metres (no map projection).
constexpr const char* kLocalCrsWkt =
    "LOCAL_CS[\"lunarnav local frame (x east, y north, z up; metres)\","
    "LOCAL_DATUM[\"lunarnav world frame\",0],UNIT[\"metre\",1],"
    "AXIS[\"Easting\",EAST],AXIS[\"Northing\",NORTH]]";

// What ReadGeoTiff accepts (docs/reliability.md): the largest map terrain-map makes by default
// is 2^22 cells in up to 48 bands of 8 bytes (its state).
constexpr std::int64_t kMaxRasterCells = std::int64_t{1} << 25;
constexpr int kMaxRasterBands = 64;
constexpr std::int64_t kMaxRasterBytes = std::int64_t{2} << 30;
constexpr double kMaxRasterOriginM = 1e7;
constexpr double kMinRasterCellM = 1e-3, kMaxRasterCellM = 1e4;

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

// Sets *error to the streamed message and returns false.
class Fail {
 public:
  explicit Fail(std::string* error) : error_(error) {}
  template <typename T>
  Fail& operator<<(const T& value) {
    stream_ << value;
    return *this;
  }
  operator bool() {  // NOLINT: the idiom `return Fail(error) << ...;`
    *error_ = stream_.str();
    return false;
  }

 private:
  std::string* error_;
  std::ostringstream stream_;
};

class GdalModuleImpl final : public GdalModule {
 public:
  GdalModuleImpl() {
    GDALRegister_GTiff();
    CPLSetErrorHandler(CPLQuietErrorHandler);  // messages reach the user through the callers
  }

  bool WriteGeoTiff(const std::string& path, const GeoRaster& raster, std::string* error) override {
    GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
    if (driver == nullptr) return Fail(error) << path << ": GDAL has no GTiff driver";
    const int depth = raster.bands.front().pixels.depth();
    char** create_options = nullptr;
    create_options = CSLSetNameValue(create_options, "TILED", "YES");
    create_options = CSLSetNameValue(create_options, "COMPRESS", "DEFLATE");
    create_options = CSLSetNameValue(create_options, "PREDICTOR", "3");  // floating-point predictor
    // DEFLATE at its fastest level: a third of the writing time off for files 3-4 % larger.
    create_options = CSLSetNameValue(create_options, "ZLEVEL", "1");
    create_options = CSLSetNameValue(create_options, "INTERLEAVE", "BAND");
    const GDALDataType type = depth == CV_64F ? GDT_Float64 : GDT_Float32;
    DatasetPtr ds(driver->Create(path.c_str(), raster.Width(), raster.Height(), static_cast<int>(raster.bands.size()),
                                 type, create_options));
    CSLDestroy(create_options);
    if (ds == nullptr) return Fail(error) << path << ": cannot create GeoTIFF (" << LastGdalError() << ")";
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
      if (err != CE_None) return Fail(error) << path << ": cannot write band " << i + 1 << " (" << LastGdalError() << ")";
    }
    ds.reset();  // closed: everything flushed
    return true;
  }

  bool ReadGeoTiff(const std::string& path, GeoRaster* out, std::string* error) override {
    // Only GDAL's GeoTIFF driver: a VRT (a text file naming other files) or any other format
    // GDAL would open is not what the tools write, and may declare what it does not hold.
    const char* const drivers[] = {"GTiff", nullptr};
    DatasetPtr ds(static_cast<GDALDataset*>(
        GDALOpenEx(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, drivers, nullptr, nullptr)));
    if (ds == nullptr) return Fail(error) << path << ": not a readable GeoTIFF (" << LastGdalError() << ")";
    double t[6];
    if (ds->GetGeoTransform(t) != CE_None) return Fail(error) << path << ": no geotransform";
    if (!(std::isfinite(t[0]) && std::isfinite(t[3]) && std::abs(t[0]) <= kMaxRasterOriginM &&
          std::abs(t[3]) <= kMaxRasterOriginM)) {
      return Fail(error) << path << ": its origin (" << t[0] << ", " << t[3] << ") is not within "
                         << kMaxRasterOriginM << " m of the world origin";
    }
    if (!(t[2] == 0 && t[4] == 0 && std::isfinite(t[1]) && t[1] >= kMinRasterCellM && t[1] <= kMaxRasterCellM &&
          std::abs(t[5] + t[1]) <= 1e-9 * t[1])) {
      return Fail(error) << path << ": expected a north-up grid of square cells of " << kMinRasterCellM << " to "
                         << kMaxRasterCellM << " m (geotransform " << t[1] << ", " << t[2] << ", " << t[4] << ", "
                         << t[5] << ")";
    }
    // What it declares, before anything is allocated: a size within the limits, and every
    // block of every band present in the file (a sparse file of a few kilobytes can declare
    // 10^10 cells).
    const std::int64_t declared_w = ds->GetRasterXSize(), declared_h = ds->GetRasterYSize();
    const int declared_bands = ds->GetRasterCount();
    if (!(declared_w >= 1 && declared_h >= 1 && declared_w * declared_h <= kMaxRasterCells && declared_bands >= 1 &&
          declared_bands <= kMaxRasterBands && declared_w * declared_h * declared_bands * 8 <= kMaxRasterBytes)) {
      return Fail(error) << path << ": declares " << declared_w << " x " << declared_h << " cells in "
                         << declared_bands << " bands; a map holds at most " << kMaxRasterCells << " cells and "
                         << kMaxRasterBands << " bands (" << (kMaxRasterBytes >> 20) << " MiB)";
    }
    for (int i = 1; i <= declared_bands; ++i) {
      GDALRasterBand* band = ds->GetRasterBand(i);
      int bw = 0, bh = 0;
      band->GetBlockSize(&bw, &bh);
      if (bw < 1 || bh < 1) return Fail(error) << path << ": band " << i << " has no block size";
      const std::int64_t nx = (declared_w + bw - 1) / bw, ny = (declared_h + bh - 1) / bh;
      for (std::int64_t by = 0; by < ny; ++by) {
        for (std::int64_t bx = 0; bx < nx; ++bx) {
          const std::string key = "BLOCK_OFFSET_" + std::to_string(bx) + "_" + std::to_string(by);
          const char* offset = band->GetMetadataItem(key.c_str(), "TIFF");
          if (offset == nullptr || std::strtoll(offset, nullptr, 10) <= 0) {
            return Fail(error) << path << ": band " << i << " lacks block (" << bx << ", " << by
                               << "): a sparse file that declares more than it holds";
          }
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
      const CPLErr err =
          band->RasterIO(GF_Read, 0, 0, w, h, b.pixels.data, w, h, f64 ? GDT_Float64 : GDT_Float32, 0, 0);
      if (err != CE_None) return Fail(error) << path << ": cannot read band " << i << " (" << LastGdalError() << ")";
      r.bands.push_back(std::move(b));
    }
    if (r.bands.empty()) return Fail(error) << path << ": no bands";
    *out = std::move(r);
    return true;
  }
};

}  // namespace
}  // namespace lunarnav::io::internal

extern "C" __attribute__((visibility("default"))) lunarnav::io::internal::GdalModule* lunarnav_gdal_module() {
  static lunarnav::io::internal::GdalModuleImpl module;
  return &module;
}
