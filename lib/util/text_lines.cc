#include "util/text_lines.h"

#include "util/check.h"
#include "util/parse.h"

namespace lunarnav::util {

TextLines::TextLines(const std::filesystem::path& path) : path_(path), in_(path, std::ios::binary) {
  LN_CHECK_INPUT(in_.good() && !std::filesystem::is_directory(path)) << path.string() << ": cannot open";
}

bool TextLines::Next(std::string* line) {
  std::string raw;
  while (std::getline(in_, raw)) {
    if (++number_ == 1) DropUtf8Bom(&raw);
    *line = Trim(raw);
    if (line->empty() || (*line)[0] == '#') continue;
    return true;
  }
  return false;
}

}  // namespace lunarnav::util
