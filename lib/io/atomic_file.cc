#include "io/atomic_file.h"

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>
#include <system_error>

#include "util/errors.h"

namespace lunarnav::io {
namespace fs = std::filesystem;
namespace {
constexpr std::string_view kTempSuffix = ".lunarnav-tmp";
std::atomic<unsigned long> g_counter{0};
// A temporary file of another machine untouched for this long is a killed run's.
constexpr auto kStaleTempAge = std::chrono::hours(1);

// This machine's short host name, letters, digits and '-' only ("host" when unknown).
const std::string& HostTag() {
  static const std::string tag = [] {
    char name[256] = {};
    if (gethostname(name, sizeof name - 1) != 0 || name[0] == '\0') return std::string("host");
    std::string t;
    for (const char* c = name; *c != '\0' && *c != '.'; ++c) {
      t += std::isalnum(static_cast<unsigned char>(*c)) != 0 || *c == '-' ? *c : '-';
    }
    return t.empty() ? std::string("host") : t;
  }();
  return tag;
}

// Whether the temporary file `path` was left by a run that is over: on this machine, one whose
// process no longer exists; from another machine (shards of one batch on a cluster write into
// one directory) or of unknown origin, one untouched for kStaleTempAge.
bool IsStaleTempFile(const fs::path& path) {
  std::string name = path.filename().string();
  name.resize(name.size() - kTempSuffix.size());        // .<file>.<host>-<pid>.<n>
  const std::size_t counter_dot = name.rfind('.');
  const std::size_t owner_dot = counter_dot == std::string::npos || counter_dot == 0
                                    ? std::string::npos : name.rfind('.', counter_dot - 1);
  if (owner_dot != std::string::npos) {
    const std::string owner = name.substr(owner_dot + 1, counter_dot - owner_dot - 1);  // <host>-<pid>
    const std::size_t dash = owner.rfind('-');
    if (dash != std::string::npos && owner.substr(0, dash) == HostTag()) {
      try {
        const pid_t pid = static_cast<pid_t>(std::stol(owner.substr(dash + 1)));
        return pid > 0 && kill(pid, 0) != 0 && errno == ESRCH;
      } catch (const std::exception&) {
        // not a pid: judged by its age below
      }
    }
  }
  std::error_code ec;
  const auto written = fs::last_write_time(path, ec);
  return !ec && fs::file_time_type::clock::now() - written > kStaleTempAge;
}
}  // namespace

fs::path TempPathFor(const fs::path& path) {
  const std::string name = "." + path.filename().string() + "." + HostTag() + "-" + std::to_string(getpid()) + "." +
                           std::to_string(g_counter++) + std::string(kTempSuffix);
  return path.parent_path() / name;
}

bool IsTempFileName(const fs::path& path) {
  const std::string name = path.filename().string();
  return name.size() > kTempSuffix.size() && name.front() == '.' &&
         name.compare(name.size() - kTempSuffix.size(), kTempSuffix.size(), kTempSuffix) == 0;
}

void CommitTempFile(const fs::path& temp, const fs::path& path) {
  // Fault injection for the kill-and-resume tests (docs/reliability.md): with
  // LUNARNAV_TEST_EXIT_BEFORE_COMMIT=k the process ends at once, as if killed, just before its
  // k-th commit, leaving the temporary file behind.
  static const long exit_before = [] {
    const char* v = std::getenv("LUNARNAV_TEST_EXIT_BEFORE_COMMIT");
    return v != nullptr ? std::atol(v) : 0L;
  }();
  static std::atomic<long> commits{0};
  if (exit_before > 0 && ++commits == exit_before) std::_Exit(kTestKilledExitCode);
  std::error_code ec;
  fs::rename(temp, path, ec);
  if (ec) {
    const std::error_code rename_error = ec;  // kept: the clean-up below sets ec again
    fs::remove(temp, ec);
    // A directory where the output file goes is the given paths' fault, not an internal error:
    // that item fails (a batch goes on with the others; a lone output exits 3).
    std::error_code dir_ec;
    if (fs::is_directory(path, dir_ec)) {
      throw InputError(path.string() + ": is a directory; an output file of that name cannot be written");
    }
    throw std::runtime_error(path.string() + ": cannot rename temporary file: " + rename_error.message());
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

void CheckInputDirectory(const fs::path& dir, const std::string& hint) {
  std::error_code ec;
  if (fs::is_directory(dir, ec)) return;
  const bool exists = fs::exists(fs::symlink_status(dir, ec)) && fs::exists(dir, ec);
  throw InputError(dir.string() + (exists ? ": not a directory (a file)" : ": no such directory") +
                   (hint.empty() ? "" : " " + hint));
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
    if (entry.is_regular_file() && IsTempFileName(entry.path()) && IsStaleTempFile(entry.path())) {
      if (fs::remove(entry.path(), ec)) ++removed;
    }
  }
  return removed;
}

}  // namespace lunarnav::io
