// Minimal thread-safe logging to stderr. Data never goes to stderr; logs never go to files.
#pragma once

#include <sstream>
#include <string>

namespace lunarnav::util {

enum class LogLevel { kError = 0, kWarning = 1, kInfo = 2, kDebug = 3 };

/// Sets the most verbose level that is printed (default kInfo; --quiet sets kWarning).
void SetLogLevel(LogLevel level);
LogLevel GetLogLevel();

/// Writes one whole line to stderr under a lock, clearing a progress bar first.
/// Errors are prefixed with "error: " and warnings with "warning: ".
/// A message as one bounded line: control characters (a NUL or a newline from a file's
/// contents) written as \xHH, and at most `max_bytes` bytes, the rest counted, not printed.
std::string BoundedMessage(const std::string& message, std::size_t max_bytes = 2000);

void LogLine(LogLevel level, const std::string& line);

namespace internal {
class LogMessage {
 public:
  explicit LogMessage(LogLevel level) : level_(level) {}
  LogMessage(const LogMessage&) = delete;
  LogMessage& operator=(const LogMessage&) = delete;
  ~LogMessage() { LogLine(level_, stream_.str()); }
  template <typename T>
  LogMessage& operator<<(const T& value) {
    stream_ << value;
    return *this;
  }

 private:
  LogLevel level_;
  std::ostringstream stream_;
};
}  // namespace internal

}  // namespace lunarnav::util

#define LN_LOG(LEVEL)                                                                    \
  if (::lunarnav::util::LogLevel::k##LEVEL > ::lunarnav::util::GetLogLevel()) {          \
  } else                                                                                 \
    ::lunarnav::util::internal::LogMessage(::lunarnav::util::LogLevel::k##LEVEL)
