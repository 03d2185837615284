// Test helpers: temporary directories and the paths CMake passes to tests.
#pragma once

#include <filesystem>
#include <string>

namespace lunarnav::util {

/// A fresh directory under the system temp dir, removed with its contents on destruction.
class ScopedTempDir {
 public:
  ScopedTempDir();
  ~ScopedTempDir();
  ScopedTempDir(const ScopedTempDir&) = delete;
  ScopedTempDir& operator=(const ScopedTempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

/// testdata/<relative>, from the LUNARNAV_TESTDATA environment variable set by CTest.
std::filesystem::path TestDataPath(const std::string& relative);

/// The built tool `name`, from the LUNARNAV_BIN environment variable set by CTest.
std::filesystem::path ToolPath(const std::string& name);

}  // namespace lunarnav::util
