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

AtomicOutputFile::AtomicOutputFile(const fs::path& path) : path_(path), temp_(TempPathFor(path)) {
  if (!path.parent_path().empty()) fs::create_directories(path.parent_path());
  file_ = std::fopen(temp_.c_str(), "wb");
  if (file_ == nullptr) throw std::runtime_error(temp_.string() + ": cannot open for writing");
}

AtomicOutputFile::~AtomicOutputFile() {
  if (file_ != nullptr) {
    std::fclose(file_);
    std::error_code ec;
    fs::remove(temp_, ec);
  }
}

void AtomicOutputFile::Write(std::string_view bytes) {
  if (std::fwrite(bytes.data(), 1, bytes.size(), file_) != bytes.size()) {
    throw std::runtime_error(path_.string() + ": write failed (disk full?)");
  }
}

void AtomicOutputFile::Commit() {
  const bool ok = std::fflush(file_) == 0;
  const bool closed = std::fclose(file_) == 0;
  file_ = nullptr;
  if (!ok || !closed) {
    std::error_code ec;
    fs::remove(temp_, ec);
    throw std::runtime_error(path_.string() + ": write failed (disk full?)");
  }
  CommitTempFile(temp_, path_);
}

void CreateOutputDirectory(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir)) {
    throw std::invalid_argument(dir.string() + ": cannot create the output directory (" +
                                (ec ? ec.message() : std::string("not a directory")) + ")");
  }
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
