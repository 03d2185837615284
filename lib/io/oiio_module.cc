// The OpenImageIO module (liblunarnav_oiio.so): everything the project does with OpenImageIO.
#include "io/oiio_module.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <limits>

#include <OpenEXR/openexr.h>
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

// The rows a file's lunarnav:finite_rows stamp names ([*first, *last]; false: no usable stamp).
bool StampedRows(const std::string& stamp, int height, int* first, int* last) {
  int a = 0, b = 0;
  char tail = 0;
  if (stamp.empty() || std::sscanf(stamp.c_str(), "%d %d%c", &a, &b, &tail) != 2 || !(a >= 0 && b >= a - 1 && b < height)) {
    return false;
  }
  *first = a;
  *last = b;
  return true;
}

// Closes a core API context however the read ends.
struct ExrContext {
  exr_context_t context = nullptr;
  exr_decode_pipeline_t decoder = EXR_DECODE_PIPELINE_INITIALIZER;
  bool decoding = false;
  ~ExrContext() {
    if (decoding) exr_decoding_destroy(context, &decoder);
    if (context != nullptr) exr_finish(&context);
  }
};

void Quiet(exr_const_context_t, exr_result_t, const char*) {}

// A file as the project's own writer makes it (WriteExrAtomic: one scanline part, channels Y or
// R, G, B[, A], 32- or 16-bit floats, full resolution), read through OpenEXR's core API, which
// unpacks a block's values into interleaved floats in one pass (OpenImageIO goes through
// OpenEXR's frame buffers, a byte-order read a value: twice the time of the whole read on a
// rig's XYZ arrays). The same pixels and channel names as the OpenImageIO path (tests/io and the
// maps of both real drives, byte for byte), the header's string attributes (OpenImageIO adds a
// few of its own, such as "compression"); false for any other file, or any trouble: the caller
// then reads it through OpenImageIO, which also words the errors.
bool ReadOwnExr(const std::string& path, long long max_pixels, cv::Mat* pixels, std::vector<std::string>* names,
                std::map<std::string, std::string>* attributes) {
  ExrContext exr;
  exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
  init.error_handler_fn = &Quiet;
  if (exr_start_read(&exr.context, path.c_str(), &init) != EXR_ERR_SUCCESS) return false;
  int parts = 0;
  exr_storage_t storage = EXR_STORAGE_LAST_TYPE;
  exr_attr_box2i_t window;
  const exr_attr_chlist_t* channels = nullptr;
  int lines = 0;
  if (exr_get_count(exr.context, &parts) != EXR_ERR_SUCCESS || parts != 1 ||
      exr_get_storage(exr.context, 0, &storage) != EXR_ERR_SUCCESS || storage != EXR_STORAGE_SCANLINE ||
      exr_get_data_window(exr.context, 0, &window) != EXR_ERR_SUCCESS ||
      exr_get_channels(exr.context, 0, &channels) != EXR_ERR_SUCCESS || channels == nullptr ||
      exr_get_scanlines_per_chunk(exr.context, 0, &lines) != EXR_ERR_SUCCESS || lines < 1) {
    return false;
  }
  const long long width = static_cast<long long>(window.max.x) - window.min.x + 1;
  const long long height = static_cast<long long>(window.max.y) - window.min.y + 1;
  if (width < 1 || height < 1 || width * height > max_pixels) return false;
  // The channels, in the order OpenImageIO gives them: Y, or R, G, B[, A] (the file stores them
  // by name).
  const int n = channels->num_channels;
  const std::vector<std::string> order = n == 1 ? std::vector<std::string>{"Y"}
                                         : n == 3 ? std::vector<std::string>{"R", "G", "B"}
                                         : n == 4 ? std::vector<std::string>{"R", "G", "B", "A"}
                                                  : std::vector<std::string>{};
  if (order.empty()) return false;
  for (int c = 0; c < n; ++c) {
    const exr_attr_chlist_entry_t& e = channels->entries[c];
    if (std::find(order.begin(), order.end(), std::string(e.name.str, static_cast<std::size_t>(e.name.length))) ==
            order.end() ||
        (e.pixel_type != EXR_PIXEL_FLOAT && e.pixel_type != EXR_PIXEL_HALF) || e.x_sampling != 1 ||
        e.y_sampling != 1) {
      return false;
    }
  }
  // The string attributes, and the rows the writer stamped as holding finite values.
  std::map<std::string, std::string> strings;
  int count = 0;
  if (exr_get_attribute_count(exr.context, 0, &count) != EXR_ERR_SUCCESS) return false;
  for (int k = 0; k < count; ++k) {
    const exr_attribute_t* a = nullptr;
    if (exr_get_attribute_by_index(exr.context, 0, EXR_ATTR_LIST_FILE_ORDER, k, &a) != EXR_ERR_SUCCESS) return false;
    if (a != nullptr && a->type == EXR_ATTR_STRING && a->string != nullptr) {
      strings[a->name] = std::string(a->string->str, static_cast<std::size_t>(a->string->length));
    }
  }
  const int rows = static_cast<int>(height), cols = static_cast<int>(width);
  int first = 0, last = rows - 1;
  const auto stamp = strings.find("lunarnav:finite_rows");
  const bool stamped = stamp != strings.end() && StampedRows(stamp->second, rows, &first, &last);
  pixels->create(rows, cols, CV_32FC(n));
  if (stamped) pixels->setTo(cv::Scalar::all(std::numeric_limits<float>::quiet_NaN()));
  // Block by block into a block's buffer, its rows within [first, last] copied out.
  const std::size_t row_bytes = static_cast<std::size_t>(cols) * n * sizeof(float);
  std::vector<float> block(static_cast<std::size_t>(lines) * cols * n);
  for (int y = first - first % lines; y <= last; y += lines) {
    exr_chunk_info_t chunk;
    if (exr_read_scanline_chunk_info(exr.context, 0, window.min.y + y, &chunk) != EXR_ERR_SUCCESS ||
        chunk.height < 1 || chunk.height > lines || chunk.start_y - window.min.y != y) {
      return false;
    }
    const exr_result_t started = exr.decoding ? exr_decoding_update(exr.context, 0, &chunk, &exr.decoder)
                                              : exr_decoding_initialize(exr.context, 0, &chunk, &exr.decoder);
    if (started != EXR_ERR_SUCCESS) return false;
    const bool first_block = !exr.decoding;
    exr.decoding = true;
    for (int c = 0; c < exr.decoder.channel_count; ++c) {
      exr_coding_channel_info_t& ch = exr.decoder.channels[c];
      const auto at = std::find(order.begin(), order.end(), std::string(ch.channel_name));
      if (at == order.end() || ch.height != chunk.height || ch.width != cols) return false;
      ch.decode_to_ptr = reinterpret_cast<std::uint8_t*>(block.data() + (at - order.begin()));
      ch.user_pixel_stride = static_cast<std::int32_t>(n * sizeof(float));
      ch.user_line_stride = static_cast<std::int32_t>(row_bytes);
      ch.user_data_type = EXR_PIXEL_FLOAT;
      ch.user_bytes_per_element = sizeof(float);
    }
    if (first_block && exr_decoding_choose_default_routines(exr.context, 0, &exr.decoder) != EXR_ERR_SUCCESS) {
      return false;
    }
    if (exr_decoding_run(exr.context, 0, &exr.decoder) != EXR_ERR_SUCCESS) return false;
    for (int r = std::max(y, first); r < std::min(y + chunk.height, last + 1); ++r) {
      std::memcpy(pixels->ptr<float>(r), block.data() + static_cast<std::size_t>(r - y) * cols * n, row_bytes);
    }
  }
  *names = order;
  *attributes = std::move(strings);
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
    if (ReadOwnExr(path, max_pixels, pixels, names, attributes)) return true;
    names->clear();
    attributes->clear();
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
    if (spec.tile_width == 0 &&
        StampedRows(spec.get_string_attribute("lunarnav:finite_rows"), spec.height, &first, &last)) {
      pixels->setTo(cv::Scalar::all(std::numeric_limits<float>::quiet_NaN()));
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
