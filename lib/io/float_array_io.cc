#include "io/float_array_io.h"

#include <algorithm>
#include <stdexcept>
#include <system_error>


#include "io/atomic_file.h"
#include "io/image_io.h"
#include "io/oiio_module.h"
#include "util/check.h"

namespace lunarnav::io {
namespace fs = std::filesystem;


void WriteExrAtomic(const fs::path& path, const cv::Mat& image, const std::vector<std::string>& channel_names,
                    const std::map<std::string, std::string>& attributes) {
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

  if (!path.parent_path().empty()) fs::create_directories(path.parent_path());
  const fs::path temp = TempPathFor(path);
  std::string error;
  if (!internal::Oiio().WriteExr(temp.string(), image, names, attributes, &error)) {
    std::error_code ec;
    fs::remove(temp, ec);
    throw std::runtime_error(path.string() + ": cannot write EXR (" + error + ")");
  }
  CommitTempFile(temp, path);
}

void PreloadExrReader() { internal::Oiio(); }

ExrImage ReadExr(const fs::path& path) {
  std::error_code ec;
  LN_CHECK_INPUT(fs::is_regular_file(path, ec)) << path.string() << ": no such file";
  ExrImage result;
  std::string error;
  if (!internal::Oiio().ReadFloat(path.string(), MaxImagePixels(), &result.pixels, &result.channel_names,
                                  &result.attributes, &error)) {
    internal::ThrowModuleReadError(path, error);
  }
  return result;
}

}  // namespace lunarnav::io
