// The OpenImageIO module (liblunarnav_oiio.so): everything the project does with OpenImageIO.
#include "io/oiio_module.h"

#include <algorithm>
#include <cstdio>
#include <limits>

#include <OpenImageIO/imageio.h>

namespace lunarnav::io::internal {
namespace {

std::string OneLine(std::string message, const char* fallback) {
  if (message.empty()) message = fallback;
  std::replace(message.begin(), message.end(), '\n', ' ');
  return message;
}

// True (with the message) when the header claims more pixels than the limit.
bool TooLarge(const OIIO::ImageSpec& spec, long long max_pixels, std::string* error) {
  const long long pixels = static_cast<long long>(spec.width) * spec.height;
  if (pixels <= max_pixels) return false;
  *error = "size: the header claims " + std::to_string(spec.width) + " x " + std::to_string(spec.height) +
           " pixels, more than the limit of " + std::to_string(max_pixels) + " (--max-pixels)";
  return true;
}

class OiioModuleImpl final : public OiioModule {
 public:
  // OpenEXR's own thread pool decodes a file's blocks on helper threads: the tools read many
  // files at once on their -j threads already, and the hand-offs only cost CPU time.
  OiioModuleImpl() { OIIO::attribute("exr_threads", -1); }

  bool ReadInteger(const std::string& path, long long max_pixels, cv::Mat* pixels, int* bits_per_sample,
                   std::string* error) override {
    // The stored colour values, not multiplied by alpha (OIIO's default for PNG and TIFF).
    OIIO::ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    auto in = OIIO::ImageInput::open(path, &config);
    if (in == nullptr) {
      *error = "unreadable: " + OneLine(OIIO::geterror(), "cannot decode");
      return false;
    }
    const OIIO::ImageSpec& spec = in->spec();
    if (!(spec.width > 0 && spec.height > 0 && spec.depth == 1)) {
      *error = "not2d: not a 2-D image";
      return false;
    }
    if (TooLarge(spec, max_pixels, error)) return false;
    const auto base = spec.format.basetype;
    const bool is8 = base == OIIO::TypeDesc::UINT8 || base == OIIO::TypeDesc::INT8;
    const bool is16 = base == OIIO::TypeDesc::UINT16 || base == OIIO::TypeDesc::INT16;
    if (!is8 && !is16) {
      *error = std::string("type: pixel type ") + spec.format.c_str() +
               " is not supported (8- or 16-bit integer images only)";
      return false;
    }
    const int channels = spec.nchannels;
    if (channels < 1 || channels > 4) {
      *error = "channels: " + std::to_string(channels) + " channels are not supported";
      return false;
    }
    pixels->create(spec.height, spec.width, CV_MAKETYPE(is8 ? CV_8U : CV_16U, channels));
    // A truncated JPEG decodes with grey filler and only a pending error message.
    const bool ok = in->read_image(0, 0, 0, channels, is8 ? OIIO::TypeDesc::UINT8 : OIIO::TypeDesc::UINT16,
                                   pixels->data) &&
                    !in->has_error();
    if (!ok) {
      *error = "corrupt: " + OneLine(in->geterror(), "cannot decode");
      return false;
    }
    *bits_per_sample = spec.get_int_attribute("oiio:BitsPerSample", 0);
    in->close();
    return true;
  }

  bool WriteExr(const std::string& path, const cv::Mat& image, const std::vector<std::string>& names,
                const std::map<std::string, std::string>& attributes, bool half, std::string* error) override {
    OIIO::ImageSpec spec(image.cols, image.rows, image.channels(), half ? OIIO::TypeDesc::HALF : OIIO::TypeDesc::FLOAT);
    spec.channelnames = names;
    // ZIP at zlib's fastest level: a quarter of the default level's time for 3 % more bytes
    // (a pair's XYZ: 35 ms -> see docs/performance.md, "Where stereo-batch's time goes").
    spec.attribute("compression", "zip:1");
    // OpenImageIO stamps files with the time of writing unless told otherwise; an empty stamp
    // keeps the bytes a function of the data, so reruns and shards give identical files.
    spec.attribute("DateTime", "");
    for (const auto& [key, value] : attributes) spec.attribute(key, value);
    // The temporary name has no .exr extension: ask for the plugin by its format name.
    auto out = OIIO::ImageOutput::create("openexr");
    if (out == nullptr) {
      *error = "OpenImageIO has no OpenEXR writer";
      return false;
    }
    const cv::Mat contiguous = image.isContinuous() ? image : image.clone();
    const bool ok = out->open(path, spec) && out->write_image(OIIO::TypeDesc::FLOAT, contiguous.ptr<float>()) &&
                    out->close();
    if (!ok) *error = OneLine(out->geterror(), "write failed");
    return ok;
  }

  bool ReadFloat(const std::string& path, long long max_pixels, cv::Mat* pixels, std::vector<std::string>* names,
                 std::map<std::string, std::string>* attributes, std::string* error) override {
    auto in = OIIO::ImageInput::open(path);
    if (in == nullptr) {
      *error = "unreadable: " + OneLine(OIIO::geterror(), "cannot decode");
      return false;
    }
    const OIIO::ImageSpec& spec = in->spec();
    if (!(spec.width > 0 && spec.height > 0 && spec.depth == 1 && spec.nchannels >= 1 && spec.nchannels <= 4)) {
      *error = "not2d: not a 2-D image of 1 to 4 channels";
      return false;
    }
    if (TooLarge(spec, max_pixels, error)) return false;
    pixels->create(spec.height, spec.width, CV_32FC(spec.nchannels));
    // The rows the writer stamped as holding finite values (lunarnav:finite_rows): only those
    // are decoded, the others are NaN. Anything else about the stamp: the whole image.
    int first = 0, last = spec.height - 1;
    const std::string stamp = spec.get_string_attribute("lunarnav:finite_rows");
    if (!stamp.empty() && spec.tile_width == 0) {
      int a = 0, b = 0;
      char tail = 0;
      if (std::sscanf(stamp.c_str(), "%d %d%c", &a, &b, &tail) == 2 && a >= 0 && b >= a - 1 && b < spec.height) {
        first = a;
        last = b;
        pixels->setTo(cv::Scalar::all(std::numeric_limits<float>::quiet_NaN()));
      }
    }
    const bool ok = last < first ||
                    (in->read_scanlines(0, 0, spec.y + first, spec.y + last + 1, 0, 0, spec.nchannels,
                                        OIIO::TypeDesc::FLOAT, pixels->ptr<float>(first)) &&
                     !in->has_error());
    if (!ok) {
      *error = "corrupt: " + OneLine(in->geterror(), "cannot decode");
      return false;
    }
    *names = spec.channelnames;
    for (const OIIO::ParamValue& p : spec.extra_attribs) {
      if (p.type() == OIIO::TypeDesc::STRING) (*attributes)[p.name().string()] = p.get_string();
    }
    in->close();
    return true;
  }
};

}  // namespace
}  // namespace lunarnav::io::internal

extern "C" __attribute__((visibility("default"))) lunarnav::io::internal::OiioModule* lunarnav_oiio_module() {
  static lunarnav::io::internal::OiioModuleImpl module;
  return &module;
}
