#include "io/atomic_file.h"

#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>
#include <system_error>

namespace lunarnav::io {
namespace fs = std::filesystem;
namespace {
constexpr std::string_view kTempSuffix = ".lunarnav-tmp";
std::atomic<unsigned long> g_counter{0};
}  // namespace

fs::path TempPathFor(const fs::path& path) {
  const std::string name = "." + path.filename().string() + "." + std::to_string(getpid()) + "." +
                           std::to_string(g_counter++) + std::string(kTempSuffix);
  return path.parent_path() / name;
}

bool IsTempFileName(const fs::path& path) {
  const std::string name = path.filename().string();
  return name.size() > kTempSuffix.size() && name.front() == '.' &&
         name.compare(name.size() - kTempSuffix.size(), kTempSuffix.size(), kTempSuffix) == 0;
}

void CommitTempFile(const fs::path& temp, const fs::path& path) {
  std::error_code ec;
  fs::rename(temp, path, ec);
  if (ec) {
    fs::remove(temp, ec);
    throw std::runtime_error(path.string() + ": cannot rename temporary file: " + ec.message());
  }
}

void WriteFileAtomic(const fs::path& path, std::string_view bytes) {
  if (!path.parent_path().empty()) fs::create_directories(path.parent_path());
  const fs::path temp = TempPathFor(path);
  {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    if (!out) throw std::runtime_error(temp.string() + ": cannot open for writing");
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.flush();
    if (!out) {
      std::error_code ec;
      fs::remove(temp, ec);
      throw std::runtime_error(path.string() + ": write failed (disk full?)");
    }
  }
  CommitTempFile(temp, path);
}

int RemoveStaleTempFiles(const fs::path& dir) {
  int removed = 0;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return 0;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    if (entry.is_regular_file() && IsTempFileName(entry.path())) {
      if (fs::remove(entry.path(), ec)) ++removed;
    }
  }
  return removed;
}

}  // namespace lunarnav::io
