#include "util/parse.h"

#include <charconv>
#include <cmath>
#include <stdexcept>
#include <system_error>

namespace lunarnav::util {

std::string Trim(const std::string& s) {
  const auto begin = s.find_first_not_of(" \t\r");
  if (begin == std::string::npos) return "";
  const auto end = s.find_last_not_of(" \t\r");
  return s.substr(begin, end - begin + 1);
}

int ParseInt(const std::string& text, const std::string& what) {
  const std::string t = Trim(text);
  int value = 0;
  const char* first = t.data();
  if (!t.empty() && t[0] == '+') ++first;
  const auto [ptr, ec] = std::from_chars(first, t.data() + t.size(), value);
  if (t.empty() || ec != std::errc() || ptr != t.data() + t.size()) {
    throw std::invalid_argument(what + ": '" + text + "' is not an integer");
  }
  return value;
}

double ParseDouble(const std::string& text, const std::string& what) {
  const std::string t = Trim(text);
  double value = 0;
  const char* first = t.data();
  if (!t.empty() && t[0] == '+') ++first;
  const auto [ptr, ec] = std::from_chars(first, t.data() + t.size(), value);
  if (t.empty() || ec != std::errc() || ptr != t.data() + t.size() || !std::isfinite(value)) {
    throw std::invalid_argument(what + ": '" + text + "' is not a finite number");
  }
  return value;
}

std::pair<int, int> ParseIntPair(const std::string& text, char separator, const std::string& what) {
  const auto pos = text.find(separator);
  if (pos == std::string::npos) {
    throw std::invalid_argument(what + ": expected A" + std::string(1, separator) + "B, got '" +
                                text + "'");
  }
  return {ParseInt(text.substr(0, pos), what), ParseInt(text.substr(pos + 1), what)};
}

std::pair<double, double> ParseDoublePair(const std::string& text, char separator,
                                          const std::string& what) {
  const auto pos = text.find(separator);
  if (pos == std::string::npos) {
    throw std::invalid_argument(what + ": expected A" + std::string(1, separator) + "B, got '" +
                                text + "'");
  }
  return {ParseDouble(text.substr(0, pos), what), ParseDouble(text.substr(pos + 1), what)};
}

void DropUtf8Bom(std::string* first_line) {
  if (first_line->compare(0, 3, "\xEF\xBB\xBF") == 0) first_line->erase(0, 3);
}

}  // namespace lunarnav::util
