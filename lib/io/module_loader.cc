// Finds and loads the project's modules: liblunarnav_oiio.so (io/oiio_module.h) and
// liblunarnav_gdal.so (io/gdal_module.h).
#include <dlfcn.h>

#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include "io/gdal_module.h"
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

namespace {

// Finds and loads one of the project's modules and returns its entry point: $env_var, else
// `library` beside the running program, else in the build's bin directory. Null, with
// `failure`, when none loads.
void* LoadModuleEntry(const std::string& library, const char* env_var, const char* entry, std::string* failure) {
  std::vector<fs::path> candidates;
  if (const char* env = std::getenv(env_var); env != nullptr && *env != '\0') candidates.emplace_back(env);
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) candidates.push_back(self.parent_path() / library);
#ifdef LUNARNAV_MODULE_DIR
  candidates.push_back(fs::path(LUNARNAV_MODULE_DIR) / library);
#endif
  std::string tried;
  for (const fs::path& path : candidates) {
    if (!fs::is_regular_file(path, ec)) {
      tried += (tried.empty() ? "" : ", ") + path.string();
      continue;
    }
    void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (handle == nullptr) {
      *failure = path.string() + ": " + dlerror();
      return nullptr;
    }
    void* symbol = dlsym(handle, entry);
    if (symbol == nullptr) *failure = path.string() + ": no entry point " + entry;
    return symbol;
  }
  *failure = library + " not found (looked at " + tried + "; set " + env_var + ")";
  return nullptr;
}

}  // namespace

// The module whose entry point returns a Module*, loaded once (thread-safe).
template <typename Module>
Module& LoadModule(const char* library, const char* env_var, const char* entry, const char* what) {
  static Module* module = nullptr;
  static std::once_flag once;
  static std::string failure;
  std::call_once(once, [&] {
    void* symbol = LoadModuleEntry(library, env_var, entry, &failure);
    if (symbol != nullptr) module = reinterpret_cast<Module* (*)()>(symbol)();
  });
  if (module == nullptr) throw std::runtime_error(std::string("cannot load the ") + what + " module: " + failure);
  return *module;
}

OiioModule& Oiio() {
  return LoadModule<OiioModule>("liblunarnav_oiio.so", "LUNARNAV_OIIO_MODULE", "lunarnav_oiio_module", "OpenImageIO");
}

GdalModule& Gdal() {
  return LoadModule<GdalModule>("liblunarnav_gdal.so", "LUNARNAV_GDAL_MODULE", "lunarnav_gdal_module", "GDAL");
}

}  // namespace lunarnav::io::internal
