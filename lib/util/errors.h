// Error types and exit codes shared by every lunarnav tool.
#pragma once

#include <stdexcept>
#include <string>

namespace lunarnav {

/// Exit codes of every lunarnav tool (documented in docs/tools.md).
enum ExitCode : int {
  kExitOk = 0,           ///< Everything succeeded.
  kExitInternal = 1,     ///< A bug or an unexpected system failure.
  kExitUsage = 2,        ///< Bad command line or configuration.
  kExitBadInput = 3,     ///< An input file is unreadable, malformed or unusable.
  kExitBatchPartial = 4  ///< A batch finished, but some of its items failed.
};

/// Thrown by the library when input data (a file, an image, a row) is bad.
/// The message names the file (and line or pair where known) and the reason;
/// `util::RunMain` turns it into exit code 3.
class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& message);
  explicit InputError(const char* message) : InputError(std::string(message)) {}
};

/// `message` with its control bytes (a NUL, a newline, an escape from a file's name or
/// content) written as \xNN: what() is a C string, so a NUL would cut the message there,
/// and the error line is one line.
std::string EscapeControlBytes(const std::string& message);

inline InputError::InputError(const std::string& message) : std::runtime_error(EscapeControlBytes(message)) {}

inline std::string EscapeControlBytes(const std::string& message) {
  std::string out;
  out.reserve(message.size());
  for (const char ch : message) {
    const auto c = static_cast<unsigned char>(ch);
    if (c < 0x20 || c == 0x7F) {
      static const char kHex[] = "0123456789ABCDEF";
      out += "\\x";
      out += kHex[c >> 4];
      out += kHex[c & 15];
    } else {
      out += ch;
    }
  }
  return out;
}

}  // namespace lunarnav
