// Finds and loads liblunarnav_oiio.so (io/oiio_module.h).
#include <dlfcn.h>

#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include "io/oiio_module.h"
#include "util/errors.h"

namespace lunarnav::io::internal {
namespace fs = std::filesystem;

void ThrowModuleReadError(const fs::path& path, const std::string& error) {
  const auto colon = error.find(": ");
  const std::string kind = error.substr(0, colon);
  const std::string reason = colon == std::string::npos ? error : error.substr(colon + 2);
  if (kind == "unreadable") throw InputError(path.string() + ": unreadable image (" + reason + ")");
  if (kind == "corrupt") throw InputError(path.string() + ": truncated or corrupt image (" + reason + ")");
  throw InputError(path.string() + ": " + reason);
}

OiioModule& Oiio() {
  static OiioModule* module = nullptr;
  static std::once_flag once;
  static std::string failure;
  std::call_once(once, [] {
    std::vector<fs::path> candidates;
    if (const char* env = std::getenv("LUNARNAV_OIIO_MODULE"); env != nullptr && *env != '\0') {
      candidates.emplace_back(env);
    }
    std::error_code ec;
    const fs::path self = fs::read_symlink("/proc/self/exe", ec);
    if (!ec) candidates.push_back(self.parent_path() / "liblunarnav_oiio.so");
#ifdef LUNARNAV_MODULE_DIR
    candidates.push_back(fs::path(LUNARNAV_MODULE_DIR) / "liblunarnav_oiio.so");
#endif
    std::string tried;
    for (const fs::path& path : candidates) {
      if (!fs::is_regular_file(path, ec)) {
        tried += (tried.empty() ? "" : ", ") + path.string();
        continue;
      }
      void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
      if (handle == nullptr) {
        failure = path.string() + ": " + dlerror();
        return;
      }
      auto* entry = reinterpret_cast<OiioModule* (*)()>(dlsym(handle, "lunarnav_oiio_module"));
      if (entry == nullptr) {
        failure = path.string() + ": no entry point lunarnav_oiio_module";
        return;
      }
      module = entry();
      return;
    }
    failure = "liblunarnav_oiio.so not found (looked at " + tried + "; set LUNARNAV_OIIO_MODULE)";
  });
  if (module == nullptr) throw std::runtime_error("cannot load the OpenImageIO module: " + failure);
  return *module;
}

}  // namespace lunarnav::io::internal
