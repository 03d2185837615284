#include "util/run_main.h"

#include <exception>
#include <new>
#include <stdexcept>

#include "util/errors.h"
#include "util/log.h"
#include "util/resources.h"

namespace lunarnav::util {

int RunMain(const std::function<int()>& body) {
  KeepFreedMemoryForReuse();
  try {
    return body();
  } catch (const InputError& e) {
    LogLine(LogLevel::kError, e.what());
    return kExitBadInput;
  } catch (const std::invalid_argument& e) {
    LogLine(LogLevel::kError, e.what());
    return kExitUsage;
  } catch (const std::bad_alloc&) {
    LogLine(LogLevel::kError, "out of memory");
    return kExitInternal;
  } catch (const std::exception& e) {
    LogLine(LogLevel::kError, std::string("internal: ") + e.what());
    return kExitInternal;
  }
}

}  // namespace lunarnav::util
