#include "calib/key_value_text.h"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <locale>
#include <sstream>

#include "util/check.h"
#include "util/errors.h"
#include "util/parse.h"

namespace lunarnav::calib {
namespace fs = std::filesystem;

// Lines "key<separator>value"; blank lines skipped.
std::map<std::string, TextEntry> ReadKeyValues(const fs::path& path, char separator) {
  std::error_code ec;
  LN_CHECK_INPUT(fs::is_regular_file(path, ec)) << path.string() << ": no such file";
  std::ifstream in(path);
  LN_CHECK_INPUT(in.good()) << path.string() << ": cannot read";
  std::map<std::string, TextEntry> entries;
  std::string text;
  for (int line = 1; std::getline(in, text); ++line) {
    if (line == 1) util::DropUtf8Bom(&text);
    if (!text.empty() && text.back() == '\r') text.pop_back();
    if (text.find_first_not_of(" \t") == std::string::npos) continue;
    const std::size_t at = text.find(separator);
    LN_CHECK_INPUT(at != std::string::npos)
        << path.string() << ":" << line << ": expected 'key" << separator << "value'";
    std::string key = text.substr(0, at);
    key.erase(0, key.find_first_not_of(" \t"));
    key.erase(key.find_last_not_of(" \t") + 1);
    entries[key] = {text.substr(at + 1), line};
  }
  return entries;
}

const TextEntry& TextField(const std::map<std::string, TextEntry>& entries, const std::string& key,
                           const fs::path& path) {
  const auto it = entries.find(key);
  LN_CHECK_INPUT(it != entries.end()) << path.string() << ": missing field '" << key << "'";
  return it->second;
}

// The numbers of a value, separators [ ] ; , and blanks ignored.
std::vector<double> TextNumbers(const TextEntry& entry, const std::string& key, const fs::path& path, int count) {
  std::string cleaned = entry.value;
  for (char& ch : cleaned) {
    if (ch == '[' || ch == ']' || ch == ';' || ch == ',') ch = ' ';
  }
  std::istringstream in(cleaned);
  in.imbue(std::locale::classic());
  std::vector<double> values;
  std::string token;
  while (in >> token) {
    char* end = nullptr;
    const double v = std::strtod(token.c_str(), &end);
    LN_CHECK_INPUT(end != token.c_str() && *end == '\0' && std::isfinite(v))
        << path.string() << ":" << entry.line << ": " << key << ": '" << token << "' is not a number";
    values.push_back(v);
  }
  LN_CHECK_INPUT(static_cast<int>(values.size()) == count)
      << path.string() << ":" << entry.line << ": " << key << ": expected " << count << " numbers, got "
      << values.size();
  return values;
}

}  // namespace lunarnav::calib
