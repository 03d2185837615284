#include "io/image_io.h"

#include <algorithm>
#include <csetjmp>
#include <cstdio>
#include <atomic>
#include <bit>
#include <cctype>
#include <cstdarg>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <memory>
#include <optional>
#include <stdexcept>
#include <vector>

#include <libdeflate.h>
#include <png.h>
#include <tiffio.h>
#include <opencv2/imgproc.hpp>

#include "io/atomic_file.h"
#include "io/oiio_module.h"
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

std::uint32_t BigEndian32(const unsigned char* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | p[3];
}

}  // namespace

namespace {

// The whole file, or nullopt when it cannot be opened or read.
std::optional<std::vector<unsigned char>> ReadFileBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) return std::nullopt;
  const std::streamoff size = in.tellg();
  if (size < 0) return std::nullopt;
  std::vector<unsigned char> bytes(static_cast<std::size_t>(size));
  in.seekg(0);
  if (!in.read(reinterpret_cast<char*>(bytes.data()), size)) return std::nullopt;
  return bytes;
}

// A PNG's chunks as found by the structure check: every chunk's type, data and length up to
// IEND (the CRCs checked).
struct PngChunk {
  std::string type;
  const unsigned char* data = nullptr;
  std::uint32_t length = 0;
};

// What is wrong with the chunk structure of a PNG held in `bytes` (bad signature, a chunk
// running past the end, a CRC mismatch, no IEND), or ""; the chunks into `chunks` if given.
std::string PngChunksProblem(const std::vector<unsigned char>& bytes, std::vector<PngChunk>* chunks) {
  static const unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  if (bytes.size() < 8 || !std::equal(kSignature, kSignature + 8, bytes.begin())) {
    return "not a PNG file (bad signature)";
  }
  std::size_t pos = 8;
  while (pos + 12 <= bytes.size()) {
    const std::uint32_t length = BigEndian32(&bytes[pos]);
    const std::string type(reinterpret_cast<const char*>(&bytes[pos + 4]), 4);
    if (length > bytes.size() - pos - 12) {
      return "truncated (chunk " + type + " at byte " + std::to_string(pos) + " runs past the end)";
    }
    const std::uint32_t crc = libdeflate_crc32(0, &bytes[pos + 4], length + 4);
    if (crc != BigEndian32(&bytes[pos + 8 + length])) {
      return "corrupt (CRC mismatch in chunk " + type + " at byte " + std::to_string(pos) + ")";
    }
    if (chunks != nullptr) chunks->push_back({type, &bytes[pos + 8], length});
    if (type == "IEND") return "";
    pos += 12 + length;
  }
  return "truncated (no IEND chunk)";
}

}  // namespace

std::string PngStructureProblem(const fs::path& path) {
  const auto bytes = ReadFileBytes(path);
  if (!bytes) return "cannot open";
  return PngChunksProblem(*bytes, nullptr);
}

bool HasImageExtension(const fs::path& path) {
  static const char* kExtensions[] = {".png", ".pgm", ".ppm", ".pnm", ".tif",
                                      ".tiff", ".jpg", ".jpeg"};
  const std::string ext = LowerExtension(path);
  return std::any_of(std::begin(kExtensions), std::end(kExtensions),
                     [&](const char* e) { return ext == e; });
}

namespace {

std::atomic<long long> max_image_pixels{kDefaultMaxImagePixels};

// What is wrong with the size the header of the PNG in `bytes` claims (0 pixels, or above the
// limit), or "".
std::string PngSizeProblem(const std::vector<unsigned char>& bytes) {
  if (bytes.size() < 24) return "";  // too short: the structure check says so
  const unsigned char* head = bytes.data();
  if (std::string(reinterpret_cast<const char*>(head + 12), 4) != "IHDR") return "";
  const long long width = BigEndian32(head + 16), height = BigEndian32(head + 20);
  if (width == 0 || height == 0) {
    return "invalid PNG header (" + std::to_string(width) + " x " + std::to_string(height) + " pixels)";
  }
  // width * height > limit, without the product (two 32-bit sizes overflow a long long).
  if (width > max_image_pixels.load() / height) {
    return "the header claims " + std::to_string(width) + " x " + std::to_string(height) +
           " pixels, more than the limit of " + std::to_string(max_image_pixels.load()) + " (--max-pixels)";
  }
  return "";
}

// libpng's errors and warnings, kept for the caller's message instead of printed on stderr.
struct PngMessages {
  std::jmp_buf jump;
  std::string error;
};
void PngError(png_structp png, png_const_charp message) {
  auto* m = static_cast<PngMessages*>(png_get_error_ptr(png));
  m->error = message;
  std::longjmp(m->jump, 1);
}
void PngWarning(png_structp, png_const_charp) {}

// The sBIT chunk's significant bits of the colour channels (the largest; alpha aside), 0
// without a valid one: as libpng reads it (the first sBIT before the image data, of the length
// the colour type gives, every value in 1..depth; otherwise ignored).
int SignificantBitsOf(const std::vector<PngChunk>& chunks, int colour_type, int depth) {
  const bool colour = (colour_type & PNG_COLOR_MASK_COLOR) != 0;
  const std::uint32_t length = (colour ? 3u : 1u) + ((colour_type & PNG_COLOR_MASK_ALPHA) != 0 ? 1u : 0u);
  for (const PngChunk& c : chunks) {
    if (c.type == "IDAT") break;
    if (c.type != "sBIT") continue;
    if (c.length != length) return 0;
    for (std::uint32_t i = 0; i < length; ++i) {
      if (c.data[i] == 0 || c.data[i] > depth) return 0;
    }
    return colour ? std::max({int{c.data[0]}, int{c.data[1]}, int{c.data[2]}}) : int{c.data[0]};
  }
  return 0;
}

// Reverses the PNG row filter of one row of `row_bytes` bytes: `in` after its filter byte
// `filter`, into `out`; `prior` the previous row unfiltered (null for the first row), bpp bytes
// a pixel. False on an unknown filter type.
bool UnfilterPngRow(int filter, const unsigned char* in, const unsigned char* prior, std::size_t row_bytes,
                    std::size_t bpp, unsigned char* out) {
  const std::size_t lead = std::min(bpp, row_bytes);  // the first pixel: no left neighbour
  switch (filter) {
    case 0: std::memcpy(out, in, row_bytes); return true;
    case 1:
      std::memcpy(out, in, lead);
      for (std::size_t i = bpp; i < row_bytes; ++i) out[i] = static_cast<unsigned char>(in[i] + out[i - bpp]);
      return true;
    case 2:
      if (prior == nullptr) {
        std::memcpy(out, in, row_bytes);
      } else {
        for (std::size_t i = 0; i < row_bytes; ++i) out[i] = static_cast<unsigned char>(in[i] + prior[i]);
      }
      return true;
    case 3:
      for (std::size_t i = 0; i < lead; ++i) out[i] = static_cast<unsigned char>(in[i] + (prior ? prior[i] >> 1 : 0));
      for (std::size_t i = bpp; i < row_bytes; ++i) {
        const int a = out[i - bpp], b = prior != nullptr ? prior[i] : 0;
        out[i] = static_cast<unsigned char>(in[i] + ((a + b) >> 1));
      }
      return true;
    case 4:
      // Paeth; on the first row (b = c = 0) it is the left neighbour, and on a row's first
      // pixel (a = c = 0) the one above.
      for (std::size_t i = 0; i < lead; ++i) out[i] = static_cast<unsigned char>(in[i] + (prior ? prior[i] : 0));
      for (std::size_t i = bpp; i < row_bytes; ++i) {
        const int a = out[i - bpp], b = prior != nullptr ? prior[i] : 0, c = prior != nullptr ? prior[i - bpp] : 0;
        const int pa = std::abs(b - c), pb = std::abs(a - c), pc = std::abs(a + b - 2 * c);
        const int predictor = pa <= pb && pa <= pc ? a : (pb <= pc ? b : c);
        out[i] = static_cast<unsigned char>(in[i] + predictor);
      }
      return true;
    default: return false;
  }
}

// The common PNGs (grey, grey + alpha, RGB, RGBA at 8 or 16 bits, not interlaced, no
// transparency chunk: what cameras and the project write) decoded with libdeflate, several
// times faster than libpng's zlib: the pixels in the file's channel order. Empty when the file
// is of another kind or anything in its data is unexpected (libpng then decodes it, or says
// what is wrong). `chunks` have passed the structure check.
cv::Mat DecodeCommonPng(const std::vector<PngChunk>& chunks) {
  if (chunks.empty() || chunks[0].type != "IHDR" || chunks[0].length != 13) return {};
  const unsigned char* h = chunks[0].data;
  const std::uint32_t width = BigEndian32(h), height = BigEndian32(h + 4);
  const int depth = h[8], colour_type = h[9];
  if (h[10] != 0 || h[11] != 0 || h[12] != 0 || (depth != 8 && depth != 16)) return {};  // methods, interlace
  int channels = 0;
  switch (colour_type) {
    case PNG_COLOR_TYPE_GRAY: channels = 1; break;
    case PNG_COLOR_TYPE_GRAY_ALPHA: channels = 2; break;
    case PNG_COLOR_TYPE_RGB: channels = 3; break;
    case PNG_COLOR_TYPE_RGB_ALPHA: channels = 4; break;
    default: return {};
  }
  if (width > 0x7fffffffu / (8u * channels) || height > 0x7fffffffu) return {};
  const std::size_t bpp = static_cast<std::size_t>(channels) * depth / 8;
  const std::size_t row_bytes = bpp * width;
  const std::size_t filtered_bytes = (row_bytes + 1) * height;
  // The whole image inflated at once is a second copy of it: beyond 256 MB, libpng's row by row
  // decoding keeps the peak at one.
  if (filtered_bytes > (std::size_t{256} << 20)) return {};
  // The image data: consecutive IDAT chunks; known chunks only (an unknown critical chunk is
  // libpng's to refuse); tRNS would add an alpha channel (libpng's expansion).
  std::size_t idat_bytes = 0;
  int idat_runs = 0;
  std::string previous;
  for (const PngChunk& c : chunks) {
    const bool critical = std::isupper(static_cast<unsigned char>(c.type[0])) != 0;
    if (c.type == "tRNS" || (critical && c.type != "IHDR" && c.type != "PLTE" && c.type != "IDAT" && c.type != "IEND")) {
      return {};
    }
    if (c.type == "IDAT") {
      idat_runs += previous != "IDAT";
      idat_bytes += c.length;
    }
    previous = c.type;
  }
  if (idat_runs != 1) return {};
  std::vector<unsigned char> compressed;
  compressed.reserve(idat_bytes);
  for (const PngChunk& c : chunks) {
    if (c.type == "IDAT") compressed.insert(compressed.end(), c.data, c.data + c.length);
  }
  std::vector<unsigned char> filtered(filtered_bytes);
  std::unique_ptr<libdeflate_decompressor, void (*)(libdeflate_decompressor*)> decompressor(
      libdeflate_alloc_decompressor(), &libdeflate_free_decompressor);
  if (decompressor == nullptr) return {};
  std::size_t got = 0;
  const libdeflate_result result = libdeflate_zlib_decompress(decompressor.get(), compressed.data(), compressed.size(),
                                                              filtered.data(), filtered.size(), &got);
  if (result != LIBDEFLATE_SUCCESS || got != filtered_bytes) return {};
  cv::Mat raw(static_cast<int>(height), static_cast<int>(width), CV_MAKETYPE(depth == 16 ? CV_16U : CV_8U, channels));
  // 8 bits: unfiltered straight into the image; 16 bits: in place (the filters work on the
  // file's big-endian bytes), then swapped.
  const unsigned char* prior = nullptr;
  for (std::size_t y = 0; y < height; ++y) {
    unsigned char* in = filtered.data() + y * (row_bytes + 1);
    unsigned char* out = depth == 8 ? raw.ptr(static_cast<int>(y)) : in + 1;
    if (!UnfilterPngRow(in[0], in + 1, prior, row_bytes, bpp, out)) return {};
    prior = out;
  }
  if (depth == 16) {
    for (std::size_t y = 0; y < height; ++y) {
      const unsigned char* from = filtered.data() + y * (row_bytes + 1) + 1;
      auto* to = reinterpret_cast<std::uint16_t*>(raw.ptr(static_cast<int>(y)));
      for (std::size_t i = 0; i < row_bytes / 2; ++i) {
        to[i] = static_cast<std::uint16_t>((from[2 * i] << 8) | from[2 * i + 1]);  // big-endian samples
      }
    }
  }
  return raw;
}

// A PNG (the file's bytes, its chunks checked) decoded without OpenImageIO: the common kinds by
// DecodeCommonPng, the others by libpng with its messages in the error line: the pixels in the
// file's channel order, 8 or 16 bits (palettes and grey below 8 bits expanded).
cv::Mat ReadPng(const fs::path& path, const std::vector<unsigned char>& bytes, const std::vector<PngChunk>& chunks,
                int* significant_bits) {
  cv::Mat raw = DecodeCommonPng(chunks);
  if (!raw.empty()) {
    *significant_bits = SignificantBitsOf(chunks, chunks[0].data[9], chunks[0].data[8]);
    return raw;
  }
  PngMessages messages;
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &messages, &PngError, &PngWarning);
  png_infop info = png != nullptr ? png_create_info_struct(png) : nullptr;
  std::vector<png_bytep> rows;
  struct Source {
    const std::vector<unsigned char>* bytes;
    std::size_t pos = 0;
  } source{&bytes};
  volatile bool ok = false;  // read after a longjmp from libpng's error handler
  if (png != nullptr && info != nullptr && setjmp(messages.jump) == 0) {
    png_set_read_fn(png, &source, [](png_structp p, png_bytep data, png_size_t length) {
      auto* s = static_cast<Source*>(png_get_io_ptr(p));
      if (length > s->bytes->size() - s->pos) png_error(p, "read past the end of the file");
      std::memcpy(data, s->bytes->data() + s->pos, length);
      s->pos += length;
    });
    png_set_user_limits(png, 0x7fffffff, 0x7fffffff);  // sizes are checked before (--max-pixels)
    png_read_info(png, info);
    // sBIT: the colour channels' largest significant bit count (alpha aside); 0 without one.
    png_color_8p sbit = nullptr;
    *significant_bits = 0;
    if (png_get_sBIT(png, info, &sbit) != 0 && sbit != nullptr) {
      const int colour = png_get_color_type(png, info);
      *significant_bits = (colour & PNG_COLOR_MASK_COLOR) != 0
                              ? std::max({int{sbit->red}, int{sbit->green}, int{sbit->blue}})
                              : int{sbit->gray};
    }
    png_set_expand(png);  // palette to RGB, grey below 8 bits to 8, tRNS to alpha
    if (png_get_bit_depth(png, info) == 16) png_set_swap(png);  // to the host's byte order
    png_read_update_info(png, info);
    const int channels = png_get_channels(png, info);
    const int depth = png_get_bit_depth(png, info) == 16 ? CV_16U : CV_8U;
    raw.create(static_cast<int>(png_get_image_height(png, info)), static_cast<int>(png_get_image_width(png, info)),
               CV_MAKETYPE(depth, channels));
    rows.resize(raw.rows);
    for (int y = 0; y < raw.rows; ++y) rows[y] = raw.ptr(y);
    png_read_image(png, rows.data());
    png_read_end(png, nullptr);
    ok = true;
  }
  png_destroy_read_struct(png != nullptr ? &png : nullptr, info != nullptr ? &info : nullptr, nullptr);
  LN_CHECK_INPUT(ok) << path.string() << ": truncated or corrupt image ("
                     << (messages.error.empty() ? std::string("cannot decode") : messages.error) << ")";
  return raw;
}

// The decoded pixels with every channel of the file, in the file's (RGB) order.
cv::Mat ReadAllChannels(const fs::path& path, SignificantBits* bits) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) {
    std::error_code link_ec;
    if (fs::is_symlink(path, link_ec)) {
      // Looping (ELOOP) or dangling: say which.
      throw InputError(path.string() + ": unusable symbolic link (" +
                       (ec ? ec.message() : std::string("it points to no regular file")) + ")");
    }
    throw InputError(path.string() + ": no such file");
  }
  LN_CHECK_INPUT(fs::file_size(path, ec) > 0) << path.string() << ": empty file";
  const bool png = LowerExtension(path) == ".png";
  cv::Mat raw;
  int stored_bits = 0, png_sbit = 0;
  if (png) {
    // The claimed size first (before anything is decoded or allocated for the pixels), then the
    // chunks: libpng prints its own stderr line on a damaged file, so the damage is found first.
    const auto bytes = ReadFileBytes(path);
    LN_CHECK_INPUT(bytes.has_value()) << path.string() << ": cannot open";
    const std::string size_problem = PngSizeProblem(*bytes);
    LN_CHECK_INPUT(size_problem.empty()) << path.string() << ": " << size_problem;
    std::vector<PngChunk> chunks;
    const std::string problem = PngChunksProblem(*bytes, &chunks);
    LN_CHECK_INPUT(problem.empty()) << path.string() << ": " << problem;
    raw = ReadPng(path, *bytes, chunks, &png_sbit);
  } else {
    std::string error;
    if (!internal::Oiio().ReadInteger(path.string(), MaxImagePixels(), &raw, &stored_bits, &error)) {
      internal::ThrowModuleReadError(path, error);
    }
  }
  if (bits != nullptr) {
    *bits = {raw.depth() == CV_8U ? 8 : 16, "image type"};
    // A TIFF of 12 (or 10, ...) bits per sample is read rescaled to the full 16 bits, so its
    // values do span the container: nothing to correct.
    if (stored_bits >= 1 && stored_bits < bits->bits) {
      bits->source = "image type (a " + std::to_string(stored_bits) + "-bit file, read rescaled)";
    }
    if (png) {
      if (png_sbit >= 1 && png_sbit < bits->bits) *bits = {png_sbit, "PNG sBIT"};
    }
  }
  return raw;
}

}  // namespace

int PngSignificantBits(const fs::path& path) {
  // The reader's own rule (SignificantBitsOf), on a file whose chunks are whole.
  const auto bytes = ReadFileBytes(path);
  std::vector<PngChunk> chunks;
  if (!bytes || !PngChunksProblem(*bytes, &chunks).empty() || chunks.empty() || chunks[0].type != "IHDR" ||
      chunks[0].length != 13) {
    return 0;
  }
  return SignificantBitsOf(chunks, chunks[0].data[9], chunks[0].data[8]);
}

void SetMaxImagePixels(long long pixels) {
  LN_CHECK_ARG(pixels >= 1) << "max-pixels: must be >= 1, got " << pixels;
  max_image_pixels.store(pixels);
}
long long MaxImagePixels() { return max_image_pixels.load(); }

cv::Mat ReadImage(const fs::path& path, SignificantBits* bits) {
  const cv::Mat raw = ReadAllChannels(path, bits);
  cv::Mat image;
  switch (raw.channels()) {
    case 1: return raw;
    case 2: cv::extractChannel(raw, image, 0); break;  // grey + alpha
    case 3: cv::cvtColor(raw, image, cv::COLOR_RGB2BGR); break;
    default: cv::cvtColor(raw, image, cv::COLOR_RGBA2BGR); break;
  }
  return image;
}

cv::Mat ReadGreyImage(const fs::path& path, SignificantBits* bits) {
  // From the file's channels directly (RGB2GRAY weighs the channels as BGR2GRAY does after
  // ReadImage's reordering: the same grey levels, one conversion fewer).
  const cv::Mat raw = ReadAllChannels(path, bits);
  cv::Mat grey;
  switch (raw.channels()) {
    case 1: return raw;
    case 2: cv::extractChannel(raw, grey, 0); break;  // grey + alpha
    case 3: cv::cvtColor(raw, grey, cv::COLOR_RGB2GRAY); break;
    default: cv::cvtColor(raw, grey, cv::COLOR_RGBA2GRAY); break;
  }
  return grey;
}

namespace {

// The encoders of WriteImageAtomic: libpng and libtiff directly, and PFM by hand, so that a
// tool that writes images does not load OpenCV's image codecs (with GDAL and some 110 shared
// libraries behind them, loaded at every start of every tool).

// PNG through libpng, OpenCV's BGR(A) to the file's RGB(A); sBIT when asked. Photographs:
// zlib level 3 with libpng's adaptive row filters; labels: level 1, no filter.
std::string EncodePng(const cv::Mat& image, int significant_bits, bool labels) {
  LN_CHECK(image.depth() == CV_8U || image.depth() == CV_16U) << "PNG: 8- or 16-bit images only";
  LN_CHECK(image.channels() >= 1 && image.channels() <= 4) << "PNG: 1 to 4 channels";
  std::string bytes;
  PngMessages messages;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &messages, &PngError, &PngWarning);
  png_infop info = png != nullptr ? png_create_info_struct(png) : nullptr;
  std::vector<png_bytep> rows(image.rows);
  for (int y = 0; y < image.rows; ++y) rows[y] = const_cast<png_bytep>(image.ptr(y));
  volatile bool ok = false;  // read after a longjmp from libpng's error handler
  if (png != nullptr && info != nullptr && setjmp(messages.jump) == 0) {
    png_set_write_fn(
        png, &bytes,
        [](png_structp p, png_bytep data, png_size_t length) {
          static_cast<std::string*>(png_get_io_ptr(p))->append(reinterpret_cast<const char*>(data), length);
        },
        nullptr);
    static const int kColourTypes[] = {PNG_COLOR_TYPE_GRAY, PNG_COLOR_TYPE_GRAY_ALPHA, PNG_COLOR_TYPE_RGB,
                                       PNG_COLOR_TYPE_RGB_ALPHA};
    const int bit_depth = image.depth() == CV_16U ? 16 : 8;
    png_set_IHDR(png, info, static_cast<png_uint_32>(image.cols), static_cast<png_uint_32>(image.rows), bit_depth,
                 kColourTypes[image.channels() - 1], PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    png_set_compression_level(png, labels ? 1 : 3);
    if (labels) png_set_filter(png, 0, PNG_FILTER_NONE);
    if (bit_depth == 16 && significant_bits >= 1 && significant_bits < 16) {
      png_color_8 sbit{};
      sbit.red = sbit.green = sbit.blue = sbit.gray = sbit.alpha = static_cast<png_byte>(significant_bits);
      png_set_sBIT(png, info, &sbit);
    }
    png_write_info(png, info);
    if (image.channels() >= 3) png_set_bgr(png);
    if (bit_depth == 16 && std::endian::native == std::endian::little) png_set_swap(png);
    png_write_image(png, rows.data());
    png_write_end(png, nullptr);
    ok = true;
  }
  png_destroy_write_struct(png != nullptr ? &png : nullptr, info != nullptr ? &info : nullptr);
  if (!ok) throw std::runtime_error("cannot encode PNG (" + messages.error + ")");
  return bytes;
}

// An 8-bit single-channel label map as a PNG: rows without filters, compressed by libdeflate at
// level 1 (a third of the time zlib's level 1 takes through libpng on a KITTI-sized map; label
// maps are long runs, which both compress alike). Any PNG decoder reads it.
std::string EncodeLabelPng(const cv::Mat& labels) {
  LN_CHECK(labels.type() == CV_8UC1);
  const std::size_t width = static_cast<std::size_t>(labels.cols), height = static_cast<std::size_t>(labels.rows);
  std::vector<unsigned char> filtered((width + 1) * height);
  for (std::size_t y = 0; y < height; ++y) {
    filtered[y * (width + 1)] = 0;  // filter type None
    std::memcpy(&filtered[y * (width + 1) + 1], labels.ptr(static_cast<int>(y)), width);
  }
  std::unique_ptr<libdeflate_compressor, void (*)(libdeflate_compressor*)> compressor(libdeflate_alloc_compressor(1),
                                                                                     &libdeflate_free_compressor);
  if (compressor == nullptr) throw std::bad_alloc();
  std::vector<unsigned char> compressed(libdeflate_zlib_compress_bound(compressor.get(), filtered.size()));
  const std::size_t compressed_bytes = libdeflate_zlib_compress(compressor.get(), filtered.data(), filtered.size(),
                                                                compressed.data(), compressed.size());
  LN_CHECK(compressed_bytes > 0) << "PNG: compression failed";
  std::string bytes("\x89PNG\r\n\x1a\n", 8);
  auto put32 = [](std::string* out, std::uint32_t v) {
    const char b[4] = {static_cast<char>(v >> 24), static_cast<char>(v >> 16), static_cast<char>(v >> 8),
                       static_cast<char>(v)};
    out->append(b, 4);
  };
  auto chunk = [&](const char* type, const unsigned char* data, std::size_t length) {
    LN_CHECK(length <= 0x7fffffffu) << "PNG: a chunk over 2 GiB";
    put32(&bytes, static_cast<std::uint32_t>(length));
    const std::size_t start = bytes.size();
    bytes.append(type, 4);
    bytes.append(reinterpret_cast<const char*>(data), length);
    put32(&bytes, libdeflate_crc32(0, bytes.data() + start, length + 4));
  };
  unsigned char header[13] = {};
  for (int i = 0; i < 4; ++i) {
    header[i] = static_cast<unsigned char>(width >> (24 - 8 * i));
    header[4 + i] = static_cast<unsigned char>(height >> (24 - 8 * i));
  }
  header[8] = 8;  // bit depth; colour type 0 (grey), compression 0, filter 0, no interlacing
  chunk("IHDR", header, sizeof header);
  chunk("IDAT", compressed.data(), compressed_bytes);
  chunk("IEND", header, 0);  // no data
  return bytes;
}

// PFM as the Middlebury benchmark writes it: rows bottom to top, little-endian (scale -1),
// three channels in RGB order; written row by row (no copy of the whole array).
void WritePfmAtomic(const fs::path& path, const cv::Mat& image) {
  LN_CHECK(image.type() == CV_32FC1 || image.type() == CV_32FC3) << "PFM: float32, 1 or 3 channels";
  static_assert(std::endian::native == std::endian::little, "PFM files are written little-endian");
  cv::Mat rgb;  // a new array: converting into one that shares the image's pixels would alter them
  if (image.channels() == 3) {
    cv::cvtColor(image, rgb, cv::COLOR_BGR2RGB);
  } else {
    rgb = image;
  }
  AtomicOutputFile out(path);
  out.Write((image.channels() == 3 ? "PF\n" : "Pf\n") + std::to_string(image.cols) + " " + std::to_string(image.rows) +
            "\n-1\n");
  const std::size_t row_bytes = static_cast<std::size_t>(image.cols) * image.elemSize();
  for (int y = image.rows - 1; y >= 0; --y) out.Write({reinterpret_cast<const char*>(rgb.ptr(y)), row_bytes});
  out.Commit();
}

// libtiff's messages for one file, kept for the error line instead of printed on stderr:
// handlers of the file's own (TIFFOpenExt's options), not the library's global ones, which
// OpenImageIO's TIFF reader, loaded in the same process, sets for itself.
struct TiffMessages {
  std::string error;
};
int TiffError(TIFF*, void* user_data, const char* module, const char* format, va_list args) {
  char message[512];
  std::vsnprintf(message, sizeof message, format, args);
  auto* m = static_cast<TiffMessages*>(user_data);
  if (m->error.empty()) m->error = (module != nullptr ? std::string(module) + ": " : std::string()) + message;
  return 1;  // handled: the global handler is not called
}
int TiffWarning(TIFF*, void*, const char*, const char*, va_list) { return 1; }

// TIFF through libtiff, as OpenCV wrote it: float32 uncompressed, 8/16-bit LZW; one or three
// (RGB) channels.
void WriteTiffAtomic(const fs::path& path, const cv::Mat& image) {
  const int depth = image.depth();
  LN_CHECK(depth == CV_8U || depth == CV_16U || depth == CV_32F) << "TIFF: 8-, 16-bit or float32 images only";
  LN_CHECK(image.channels() == 1 || image.channels() == 3) << "TIFF: 1 or 3 channels";
  cv::Mat pixels;  // a new array: converting into one that shares the image's pixels would alter them
  if (image.channels() == 3) {
    cv::cvtColor(image, pixels, cv::COLOR_BGR2RGB);
  } else {
    pixels = image;
  }
  if (!path.parent_path().empty()) fs::create_directories(path.parent_path());
  const fs::path temp = TempPathFor(path);
  TiffMessages messages;
  std::unique_ptr<TIFFOpenOptions, void (*)(TIFFOpenOptions*)> options(TIFFOpenOptionsAlloc(), &TIFFOpenOptionsFree);
  if (options == nullptr) throw std::bad_alloc();
  TIFFOpenOptionsSetErrorHandlerExtR(options.get(), &TiffError, &messages);
  TIFFOpenOptionsSetWarningHandlerExtR(options.get(), &TiffWarning, nullptr);
  TIFF* tiff = TIFFOpenExt(temp.c_str(), "w", options.get());
  bool ok = tiff != nullptr;
  if (ok) {
    TIFFSetField(tiff, TIFFTAG_IMAGEWIDTH, static_cast<std::uint32_t>(pixels.cols));
    TIFFSetField(tiff, TIFFTAG_IMAGELENGTH, static_cast<std::uint32_t>(pixels.rows));
    TIFFSetField(tiff, TIFFTAG_BITSPERSAMPLE, static_cast<std::uint16_t>(8 * pixels.elemSize1()));
    TIFFSetField(tiff, TIFFTAG_SAMPLESPERPIXEL, static_cast<std::uint16_t>(pixels.channels()));
    TIFFSetField(tiff, TIFFTAG_SAMPLEFORMAT, depth == CV_32F ? SAMPLEFORMAT_IEEEFP : SAMPLEFORMAT_UINT);
    TIFFSetField(tiff, TIFFTAG_PHOTOMETRIC, pixels.channels() == 3 ? PHOTOMETRIC_RGB : PHOTOMETRIC_MINISBLACK);
    TIFFSetField(tiff, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
    TIFFSetField(tiff, TIFFTAG_COMPRESSION, depth == CV_32F ? COMPRESSION_NONE : COMPRESSION_LZW);
    TIFFSetField(tiff, TIFFTAG_ROWSPERSTRIP, TIFFDefaultStripSize(tiff, 0));
    for (int y = 0; ok && y < pixels.rows; ++y) {
      ok = TIFFWriteScanline(tiff, const_cast<uchar*>(pixels.ptr(y)), static_cast<std::uint32_t>(y), 0) == 1;
    }
    TIFFClose(tiff);  // writes the directory
    ok = ok && messages.error.empty();
  }
  if (!ok) {
    std::error_code ec;
    fs::remove(temp, ec);
    throw std::runtime_error(path.string() + ": cannot write TIFF (" +
                             (messages.error.empty() ? std::string("cannot create the file") : messages.error) + ")");
  }
  CommitTempFile(temp, path);
}

}  // namespace

void WriteImageAtomic(const fs::path& path, const cv::Mat& image, int significant_bits) {
  const std::string ext = LowerExtension(path);
  LN_CHECK(ext == ".png" || ext == ".tif" || ext == ".tiff" || ext == ".pfm")
      << "unsupported output format " << ext;
  if (ext == ".tif" || ext == ".tiff") {
    WriteTiffAtomic(path, image);
    return;
  }
  if (ext == ".pfm") {
    WritePfmAtomic(path, image);
    return;
  }
  WriteFileAtomic(path, EncodePng(image, significant_bits, /*labels=*/false));
}

void WriteLabelImageAtomic(const fs::path& path, const cv::Mat& labels) {
  if (LowerExtension(path) != ".png") {
    WriteImageAtomic(path, labels);
    return;
  }
  WriteFileAtomic(path, labels.type() == CV_8UC1 ? EncodeLabelPng(labels) : EncodePng(labels, 0, /*labels=*/true));
}

cv::Mat ReadPfm(const fs::path& path) {
  std::error_code ec;
  LN_CHECK_INPUT(fs::is_regular_file(path, ec)) << path.string() << ": no such file";
  LN_CHECK_INPUT(LowerExtension(path) == ".pfm") << path.string() << ": not a .pfm file";
  // Read by hand: the header's scale gives the byte order (negative = little-endian) and its
  // magnitude is only a scale hint (Middlebury writes 1/255), never applied to the values.
  std::ifstream in(path, std::ios::binary);
  std::string magic;
  long width = 0, height = 0;
  double scale = 0;
  in >> magic >> width >> height >> scale;
  LN_CHECK_INPUT(in && (magic == "Pf" || magic == "PF")) << path.string() << ": not a PFM file (bad header)";
  LN_CHECK_INPUT(width > 0 && height > 0 && width <= (1L << 20) && height <= (1L << 20) && scale != 0)
      << path.string() << ": impossible PFM header (" << width << " x " << height << ", scale " << scale << ")";
  LN_CHECK_INPUT(width * height <= MaxImagePixels())
      << path.string() << ": the header claims " << width << " x " << height << " pixels, more than the limit of "
      << MaxImagePixels() << " (--max-pixels)";
  in.get();  // the single whitespace byte before the data
  const int channels = magic == "PF" ? 3 : 1;
  cv::Mat m(static_cast<int>(height), static_cast<int>(width), CV_32FC(channels));
  const std::size_t row_bytes = static_cast<std::size_t>(width) * channels * sizeof(float);
  for (long r = height - 1; r >= 0; --r) {  // bottom row first
    in.read(reinterpret_cast<char*>(m.ptr(static_cast<int>(r))), static_cast<std::streamsize>(row_bytes));
    LN_CHECK_INPUT(in.gcount() == static_cast<std::streamsize>(row_bytes))
        << path.string() << ": truncated PFM (" << width << " x " << height << " expected)";
  }
  const bool little_endian_file = scale < 0;
  const bool little_endian_host = std::endian::native == std::endian::little;
  if (little_endian_file != little_endian_host) {
    auto* bytes = m.ptr<unsigned char>();
    for (std::size_t k = 0; k < m.total() * channels; ++k) std::reverse(bytes + 4 * k, bytes + 4 * k + 4);
  }
  if (channels == 3) cv::cvtColor(m, m, cv::COLOR_RGB2BGR);  // OpenCV's channel order, as imread gives
  return m;
}

}  // namespace lunarnav::io
