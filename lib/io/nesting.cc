#include "io/nesting.h"

#include <fstream>
#include <iterator>
#include <vector>

#include "util/check.h"

namespace lunarnav::io {
namespace {

bool IsSpace(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }

std::optional<long> XmlDeeperThan(std::string_view text, int max_depth) {
  long line = 1;
  int depth = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '\n') ++line;
    if (text[i] != '<' || i + 1 >= text.size()) continue;
    const char next = text[i + 1];
    // Where the markup ends: a comment at "-->", a CDATA section at "]]>", a tag at '>'.
    const bool comment = text.substr(i, 4) == "<!--", cdata = text.substr(i, 9) == "<![CDATA[";
    const std::string_view end = comment ? "-->" : cdata ? "]]>" : ">";
    const std::size_t found = text.find(end, i + 1);
    if (found == std::string_view::npos) break;  // unterminated: the parser's error
    const std::size_t close = found + end.size() - 1;
    if (next == '/') {
      if (depth > 0) --depth;
    } else if (next != '?' && next != '!' && text[close - 1] != '/') {
      if (++depth > max_depth) return line;
    }
    for (std::size_t k = i + 1; k < close; ++k) line += text[k] == '\n';
    i = close;
  }
  return std::nullopt;
}

std::optional<long> YamlDeeperThan(std::string_view text, int max_depth) {
  std::vector<std::size_t> indents;  // the block levels open at the current line
  int flow = 0;                      // open '[' and '{'
  char quote = 0;                    // inside a quoted scalar ('"' or '\'') across lines
  long line = 0;
  std::size_t begin = 0;
  while (begin < text.size()) {
    std::size_t end = text.find('\n', begin);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view row = text.substr(begin, end - begin);
    begin = end + 1;
    ++line;
    std::size_t i = 0;
    int dashes = 0;
    if (flow == 0 && quote == 0) {  // block context: indentation and "- " entries
      while (i < row.size() && (row[i] == ' ' || row[i] == '\t')) ++i;
      if (i == row.size() || row[i] == '#' || row[i] == '%' || row[i] == '\r' || row.substr(i, 3) == "---" ||
          row.substr(i, 3) == "...") {
        continue;
      }
      while (!indents.empty() && indents.back() >= i) indents.pop_back();
      indents.push_back(i);
      while (i + 1 < row.size() && row[i] == '-' && IsSpace(row[i + 1])) {  // "- - x": nested entries
        ++dashes;
        i += 2;
        while (i < row.size() && row[i] == ' ') ++i;
      }
    }
    const int block = static_cast<int>(indents.size()) + dashes;
    if (block + flow > max_depth) return line;
    for (; i < row.size(); ++i) {
      const char c = row[i];
      if (quote != 0) {
        if (quote == '"' && c == '\\') {
          ++i;  // an escaped character
        } else if (c == quote) {
          if (quote == '\'' && i + 1 < row.size() && row[i + 1] == '\'') {
            ++i;  // '' inside a single-quoted scalar
          } else {
            quote = 0;
          }
        }
        continue;
      }
      const bool token_start = i == 0 || IsSpace(row[i - 1]) || row[i - 1] == '[' || row[i - 1] == '{' ||
                               row[i - 1] == ',' || row[i - 1] == ':';
      if ((c == '"' || c == '\'') && token_start) {
        quote = c;
      } else if (c == '#' && (i == 0 || IsSpace(row[i - 1]))) {
        break;  // a comment to the end of the line
      } else if (c == '[' || c == '{') {
        if (block + ++flow > max_depth) return line;
      } else if ((c == ']' || c == '}') && flow > 0) {
        --flow;
      }
    }
  }
  return std::nullopt;
}

}  // namespace

std::optional<long> FirstLineDeeperThan(std::string_view text, int max_depth) {
  std::size_t first = 0;
  if (text.substr(0, 3) == "\xEF\xBB\xBF") first = 3;  // a UTF-8 byte-order mark
  while (first < text.size() && IsSpace(text[first])) ++first;
  if (first < text.size() && text[first] == '<') return XmlDeeperThan(text, max_depth);
  return YamlDeeperThan(text, max_depth);
}

void CheckNestingDepth(std::string_view text, const std::string& file, int max_depth) {
  if (const auto line = FirstLineDeeperThan(text, max_depth)) {
    throw InputError(file + ": line " + std::to_string(*line) + ": nested deeper than " +
                     std::to_string(max_depth) + " levels");
  }
}

std::string ReadConfigText(const std::filesystem::path& path, std::uintmax_t max_bytes, bool check_nesting) {
  std::error_code ec;
  LN_CHECK_INPUT(std::filesystem::is_regular_file(path, ec)) << path.string() << ": no such file";
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  LN_CHECK_INPUT(!ec) << path.string() << ": cannot read its size (" << ec.message() << ")";
  LN_CHECK_INPUT(size <= max_bytes) << path.string() << ": " << size << " bytes, more than a configuration file's "
                                    << max_bytes << " (docs/reliability.md)";
  std::ifstream in(path, std::ios::binary);
  LN_CHECK_INPUT(in.good()) << path.string() << ": cannot open";
  std::string text(static_cast<std::size_t>(size), '\0');
  in.read(text.data(), static_cast<std::streamsize>(size));
  LN_CHECK_INPUT(in.gcount() == static_cast<std::streamsize>(size)) << path.string() << ": read failed";
  if (check_nesting) CheckNestingDepth(text, path.string());
  return text;
}

}  // namespace lunarnav::io
