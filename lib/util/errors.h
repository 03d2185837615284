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
  using std::runtime_error::runtime_error;
};

}  // namespace lunarnav
