#include "io/image_io.h"

#include <algorithm>
#include <cctype>
#include <memory>
#include <vector>

#include <OpenImageIO/imageio.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "io/atomic_file.h"
#include "util/check.h"

namespace lunarnav::io {
namespace fs = std::filesystem;

namespace {
std::string LowerExtension(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

std::string OiioError(const OIIO::ImageInput* in) {
  std::string message = in != nullptr ? in->geterror() : OIIO::geterror();
  if (message.empty()) message = "cannot decode";
  std::replace(message.begin(), message.end(), '\n', ' ');
  return message;
}
}  // namespace

bool HasImageExtension(const fs::path& path) {
  static const char* kExtensions[] = {".png", ".pgm", ".ppm", ".pnm", ".tif",
                                      ".tiff", ".jpg", ".jpeg"};
  const std::string ext = LowerExtension(path);
  return std::any_of(std::begin(kExtensions), std::end(kExtensions),
                     [&](const char* e) { return ext == e; });
}

cv::Mat ReadGreyImage(const fs::path& path) {
  std::error_code ec;
  LN_CHECK_INPUT(fs::is_regular_file(path, ec)) << path.string() << ": no such file";
  LN_CHECK_INPUT(fs::file_size(path, ec) > 0) << path.string() << ": empty file";
  auto in = OIIO::ImageInput::open(path.string());
  LN_CHECK_INPUT(in != nullptr) << path.string() << ": unreadable image (" << OiioError(nullptr) << ")";
  const OIIO::ImageSpec& spec = in->spec();
  LN_CHECK_INPUT(spec.width > 0 && spec.height > 0 && spec.depth == 1)
      << path.string() << ": not a 2-D image";
  const auto base = spec.format.basetype;
  const bool is8 = base == OIIO::TypeDesc::UINT8 || base == OIIO::TypeDesc::INT8;
  const bool is16 = base == OIIO::TypeDesc::UINT16 || base == OIIO::TypeDesc::INT16;
  LN_CHECK_INPUT(is8 || is16) << path.string() << ": pixel type " << spec.format.c_str()
                              << " is not supported (8- or 16-bit integer images only)";
  const int channels = spec.nchannels;
  LN_CHECK_INPUT(channels >= 1 && channels <= 4)
      << path.string() << ": " << channels << " channels are not supported";
  const int cv_depth = is8 ? CV_8U : CV_16U;
  cv::Mat raw(spec.height, spec.width, CV_MAKETYPE(cv_depth, channels));
  const OIIO::TypeDesc read_type = is8 ? OIIO::TypeDesc::UINT8 : OIIO::TypeDesc::UINT16;
  const bool ok = in->read_image(0, 0, 0, channels, read_type, raw.data);
  LN_CHECK_INPUT(ok) << path.string() << ": truncated or corrupt image (" << OiioError(in.get())
                     << ")";
  in->close();

  if (channels == 1) return raw;
  cv::Mat grey;
  if (channels == 2) {  // grey + alpha
    cv::extractChannel(raw, grey, 0);
  } else if (channels == 3) {
    cv::cvtColor(raw, grey, cv::COLOR_RGB2GRAY);
  } else {
    cv::cvtColor(raw, grey, cv::COLOR_RGBA2GRAY);
  }
  return grey;
}

void WriteImageAtomic(const fs::path& path, const cv::Mat& image) {
  const std::string ext = LowerExtension(path);
  LN_CHECK(ext == ".png" || ext == ".tif" || ext == ".tiff" || ext == ".pfm")
      << "unsupported output format " << ext;
  std::vector<uchar> bytes;
  std::vector<int> params;
  if (ext == ".png") params = {cv::IMWRITE_PNG_COMPRESSION, 3};
  if (!cv::imencode(ext, image, bytes, params)) {
    throw std::runtime_error(path.string() + ": cannot encode image");
  }
  WriteFileAtomic(path, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

cv::Mat ReadPfm(const fs::path& path) {
  std::error_code ec;
  LN_CHECK_INPUT(fs::is_regular_file(path, ec)) << path.string() << ": no such file";
  LN_CHECK_INPUT(LowerExtension(path) == ".pfm") << path.string() << ": not a .pfm file";
  cv::Mat m = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
  LN_CHECK_INPUT(!m.empty() && m.depth() == CV_32F) << path.string() << ": unreadable PFM";
  return m;
}

}  // namespace lunarnav::io
