#include "io/float_array_io.h"

#include <algorithm>
#include <stdexcept>
#include <system_error>

#include <OpenImageIO/imageio.h>

#include "io/atomic_file.h"
#include "util/check.h"

namespace lunarnav::io {
namespace fs = std::filesystem;

namespace {

std::string OneLine(std::string message, const char* fallback) {
  if (message.empty()) message = fallback;
  std::replace(message.begin(), message.end(), '\n', ' ');
  return message;
}

}  // namespace

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

  OIIO::ImageSpec spec(image.cols, image.rows, channels, OIIO::TypeDesc::FLOAT);
  spec.channelnames = names;
  spec.attribute("compression", "zip");
  // OpenImageIO stamps files with the time of writing unless told otherwise; an empty stamp
  // keeps the bytes a function of the data, so reruns and shards give identical files.
  spec.attribute("DateTime", "");
  for (const auto& [key, value] : attributes) spec.attribute(key, value);

  if (!path.parent_path().empty()) fs::create_directories(path.parent_path());
  const fs::path temp = TempPathFor(path);
  // The temporary name has no .exr extension: ask for the plugin by its format name.
  auto out = OIIO::ImageOutput::create("openexr");
  if (out == nullptr) throw std::runtime_error(path.string() + ": OpenImageIO has no OpenEXR writer");
  const cv::Mat contiguous = image.isContinuous() ? image : image.clone();
  const bool ok = out->open(temp.string(), spec) &&
                  out->write_image(OIIO::TypeDesc::FLOAT, contiguous.ptr<float>()) && out->close();
  if (!ok) {
    const std::string reason = OneLine(out->geterror(), "write failed");
    out.reset();
    std::error_code ec;
    fs::remove(temp, ec);
    throw std::runtime_error(path.string() + ": cannot write EXR (" + reason + ")");
  }
  CommitTempFile(temp, path);
}

ExrImage ReadExr(const fs::path& path) {
  std::error_code ec;
  LN_CHECK_INPUT(fs::is_regular_file(path, ec)) << path.string() << ": no such file";
  auto in = OIIO::ImageInput::open(path.string());
  LN_CHECK_INPUT(in != nullptr) << path.string() << ": unreadable image ("
                                << OneLine(OIIO::geterror(), "cannot decode") << ")";
  const OIIO::ImageSpec& spec = in->spec();
  LN_CHECK_INPUT(spec.width > 0 && spec.height > 0 && spec.depth == 1 && spec.nchannels >= 1 &&
                 spec.nchannels <= 4)
      << path.string() << ": not a 2-D image of 1 to 4 channels";
  ExrImage result;
  result.pixels.create(spec.height, spec.width, CV_32FC(spec.nchannels));
  const bool ok = in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, result.pixels.data) &&
                  !in->has_error();
  LN_CHECK_INPUT(ok) << path.string() << ": truncated or corrupt image ("
                     << OneLine(in->geterror(), "cannot decode") << ")";
  result.channel_names = spec.channelnames;
  for (const OIIO::ParamValue& p : spec.extra_attribs) {
    if (p.type() == OIIO::TypeDesc::STRING) result.attributes[p.name().string()] = p.get_string();
  }
  in->close();
  return result;
}

}  // namespace lunarnav::io
