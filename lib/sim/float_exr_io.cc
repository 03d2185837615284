#include "sim/float_exr_io.h"

#include <system_error>

#include <OpenImageIO/imageio.h>

#include "io/atomic_file.h"
#include "util/check.h"
#include "util/errors.h"

namespace lunarnav::sim {
namespace fs = std::filesystem;

void WriteFloatExrAtomic(const fs::path& path, const cv::Mat& image, const std::vector<std::string>& channel_names) {
  LN_CHECK(image.depth() == CV_32F && (image.channels() == 1 || image.channels() == 3))
      << "float EXR: expected CV_32FC1 or CV_32FC3";
  LN_CHECK(static_cast<int>(channel_names.size()) == image.channels()) << "float EXR: one name per channel";
  if (!path.parent_path().empty()) fs::create_directories(path.parent_path());
  const fs::path temp = io::TempPathFor(path);
  const cv::Mat data = image.isContinuous() ? image : image.clone();
  {
    auto out = OIIO::ImageOutput::create("openexr");
    if (!out) throw std::runtime_error(path.string() + ": OpenImageIO has no EXR writer");
    OIIO::ImageSpec spec(image.cols, image.rows, image.channels(), OIIO::TypeDesc::FLOAT);
    spec.channelnames = channel_names;
    spec.attribute("compression", "zip");
    spec.attribute("DateTime", "");  // no time stamp: the same data gives the same bytes
    if (!out->open(temp.string(), spec) || !out->write_image(OIIO::TypeDesc::FLOAT, data.data) || !out->close()) {
      std::error_code ec;
      fs::remove(temp, ec);
      throw std::runtime_error(path.string() + ": cannot write EXR (" + out->geterror() + ")");
    }
  }
  io::CommitTempFile(temp, path);
}

cv::Mat ReadFloatExr(const fs::path& path) {
  auto in = OIIO::ImageInput::open(path.string());
  LN_CHECK_INPUT(in != nullptr) << path.string() << ": cannot read EXR (" << OIIO::geterror() << ")";
  const OIIO::ImageSpec& spec = in->spec();
  LN_CHECK_INPUT(spec.nchannels == 1 || spec.nchannels == 3)
      << path.string() << ": expected 1 or 3 channels, got " << spec.nchannels;
  cv::Mat image(spec.height, spec.width, CV_32FC(spec.nchannels));
  LN_CHECK_INPUT(in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, image.data))
      << path.string() << ": " << in->geterror();
  in->close();
  return image;
}

}  // namespace lunarnav::sim
