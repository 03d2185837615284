// The one place where exceptions become exit codes.
#pragma once

#include <functional>

namespace lunarnav::util {

/// Runs a tool's body and maps what escapes it to an exit code, printing one
/// "error: ..." line on stderr:
///   InputError -> 3, std::invalid_argument -> 2, any other std::exception -> 1.
/// First tunes the allocator for the tools' large buffers (KeepFreedMemoryForReuse).
/// @param body  returns the tool's exit code when it finishes normally
///              (0, or 4 when a batch had failed items).
int RunMain(const std::function<int()>& body);

}  // namespace lunarnav::util
