#include "io/float_array_io.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <stdexcept>
#include <system_error>

#include "io/atomic_file.h"
#include "io/image_io.h"
#include "io/oiio_module.h"
#include "util/check.h"

namespace lunarnav::io {
namespace fs = std::filesystem;


void WriteExrAtomic(const fs::path& path, const cv::Mat& image, const std::vector<std::string>& channel_names,
                    const std::map<std::string, std::string>& attributes, ExrStorage storage) {
  LN_CHECK_ARG(!image.empty() && image.depth() == CV_32F && image.channels() >= 1 && image.channels() <= 4)
      << path.string() << ": EXR output needs a non-empty float32 map of 1 to 4 channels";
  const int channels = image.channels();
  std::vector<std::string> names = channel_names;
  if (names.empty()) {
    static const char* kDefault[4] = {"R", "G", "B", "A"};
    names = channels == 1 ? std::vector<std::string>{"Y"}
                          : std::vector<std::string>(kDefault, kDefault + channels);
  }
  LN_CHECK_ARG(static_cast<int>(names.size()) == channels)
      << path.string() << ": " << names.size() << " channel names for " << channels << " channels";

  // The rows that hold a finite value: readers decode only those (ReadExr), the rest is NaN.
  int first = image.rows, last = -1;
  for (int y = 0; y < image.rows; ++y) {
    const float* row = image.ptr<float>(y);
    const int n = image.cols * channels;
    if (std::any_of(row, row + n, [](float v) { return std::isfinite(v); })) {
      first = std::min(first, y);
      last = y;
    }
  }
  std::map<std::string, std::string> stamped = attributes;
  stamped[kFiniteRowsAttribute] = last < 0 ? "0 -1" : std::to_string(first) + " " + std::to_string(last);

  if (!path.parent_path().empty()) fs::create_directories(path.parent_path());
  const fs::path temp = TempPathFor(path);
  std::string error;
  if (!internal::Oiio().WriteExr(temp.string(), image, names, stamped, storage == ExrStorage::kFloat16, &error)) {
    std::error_code ec;
    fs::remove(temp, ec);
    throw std::runtime_error(path.string() + ": cannot write EXR (" + error + ")");
  }
  CommitTempFile(temp, path);
}

void PreloadExrReader() { internal::Oiio(); }

namespace {

// What is wrong with an OpenEXR file's header, or "": each attribute (name, type, a 32-bit
// size, the value) must fit in the file. OpenEXR 3.1 allocates an attribute's claimed size
// before reading it, so a few hundred bytes claiming 2 GB of string cost 2 GB (found by
// fuzzing); this walk reads only the names and sizes.
std::string ExrHeaderProblem(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::error_code ec;
  const auto file_size = static_cast<std::int64_t>(fs::file_size(path, ec));
  if (!in || ec) return "cannot read";
  unsigned char head[8];
  if (!in.read(reinterpret_cast<char*>(head), 8)) return "shorter than its 8-byte header";
  // OpenEXR's magic number: another format under an .exr name (a PNG) is not read as one.
  if (!(head[0] == 0x76 && head[1] == 0x2f && head[2] == 0x31 && head[3] == 0x01)) {
    const bool png = head[0] == 0x89 && head[1] == 'P' && head[2] == 'N' && head[3] == 'G';
    const bool tiff = (head[0] == 'I' && head[1] == 'I') || (head[0] == 'M' && head[1] == 'M');
    return std::string("not an OpenEXR file: no OpenEXR magic number") + (png ? ", a PNG's" : tiff ? ", a TIFF's" : "");
  }
  const bool multipart = (head[5] & 0x10) != 0;
  auto read_string = [&](std::string* s) {
    s->clear();
    for (char c; in.get(c);) {
      if (c == '\0') return true;
      if (s->size() >= 255) return false;
      s->push_back(c);
    }
    return false;
  };
  for (int part = 0; part < 1 << 16; ++part) {
    bool any = false;
    for (int attribute = 0; attribute < 1 << 16; ++attribute) {
      std::string name, type;
      if (!read_string(&name)) return "header cut short";
      if (name.empty()) break;  // the end of this header
      any = true;
      unsigned char size_bytes[4];
      if (!read_string(&type) || !in.read(reinterpret_cast<char*>(size_bytes), 4)) return "header cut short";
      const std::int32_t size = static_cast<std::int32_t>(size_bytes[0] | size_bytes[1] << 8 | size_bytes[2] << 16 |
                                                          static_cast<std::uint32_t>(size_bytes[3]) << 24);
      const std::int64_t left = file_size - static_cast<std::int64_t>(in.tellg());
      if (size < 0 || size > left) {
        return "header attribute '" + name + "' claims " + std::to_string(size) + " bytes, the file has " +
               std::to_string(std::max<std::int64_t>(left, 0)) + " left";
      }
      in.seekg(size, std::ios::cur);
    }
    if (!multipart || !any) break;  // one header, or the empty header closing a multi-part list
  }
  return "";
}

}  // namespace

ExrImage ReadExr(const fs::path& path) {
  std::error_code ec;
  LN_CHECK_INPUT(fs::is_regular_file(path, ec)) << path.string() << ": no such file";
  const std::string problem = ExrHeaderProblem(path);
  LN_CHECK_INPUT(problem.empty()) << path.string() << ": "
                                  << (problem.rfind("not an", 0) == 0 ? problem : "corrupt OpenEXR file (" + problem + ")");
  ExrImage result;
  std::string error;
  if (!internal::Oiio().ReadFloat(path.string(), MaxImagePixels(), &result.pixels, &result.channel_names,
                                  &result.attributes, &error)) {
    internal::ThrowModuleReadError(path, error);
  }
  return result;
}

}  // namespace lunarnav::io
