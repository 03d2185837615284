#include "util/testing.h"

#include <unistd.h>

#include <cstdlib>
#include <random>
#include <stdexcept>

namespace lunarnav::util {
namespace fs = std::filesystem;

ScopedTempDir::ScopedTempDir() {
  std::random_device rd;
  for (int attempt = 0; attempt < 100; ++attempt) {
    const fs::path candidate =
        fs::temp_directory_path() / ("lunarnav-test-" + std::to_string(getpid()) + "-" +
                                     std::to_string(rd() % 1000000));
    if (fs::create_directory(candidate)) {
      path_ = candidate;
      return;
    }
  }
  throw std::runtime_error("cannot create a temporary directory");
}

ScopedTempDir::~ScopedTempDir() {
  std::error_code ec;
  fs::remove_all(path_, ec);
}

namespace {
fs::path FromEnv(const char* variable) {
  const char* value = std::getenv(variable);
  if (value == nullptr) {
    throw std::runtime_error(std::string(variable) + " is not set (run the tests through ctest)");
  }
  return value;
}
}  // namespace

fs::path TestDataPath(const std::string& relative) { return FromEnv("LUNARNAV_TESTDATA") / relative; }

fs::path ToolPath(const std::string& name) { return FromEnv("LUNARNAV_BIN") / name; }

}  // namespace lunarnav::util
