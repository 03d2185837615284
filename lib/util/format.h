// printf-style formatting into a std::string of whatever length the values need: output rows
// built with it are never cut by a fixed buffer (a heading of 1e300 prints all its digits).
#pragma once

#include <string>

namespace lunarnav::util {

/// The text snprintf would write for `format` and the arguments, whole.
std::string Format(const char* format, ...) __attribute__((format(printf, 1, 2)));

}  // namespace lunarnav::util
