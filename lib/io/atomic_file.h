// Atomic output files: write to a hidden temporary file in the same directory, then rename.
//
// A run that is killed leaves either the complete file or no file under the final name
// (a leftover hidden ".*.lunarnav-tmp" file at most, which RemoveStaleTempFiles deletes).
#pragma once

#include <cstdio>
#include <filesystem>
#include <string>
#include <string_view>

namespace lunarnav::io {

/// Writes `bytes` to `path` atomically; creates the parent directories.
/// Throws std::runtime_error (exit 1) when the file system refuses.
void WriteFileAtomic(const std::filesystem::path& path, std::string_view bytes);

/// The hidden temporary name used while `path` is being written (unique per host, process and
/// call): `.<name>.<host>-<pid>.<n>.lunarnav-tmp`.
std::filesystem::path TempPathFor(const std::filesystem::path& path);

/// The exit code of a process ended by LUNARNAV_TEST_EXIT_BEFORE_COMMIT (see CommitTempFile).
inline constexpr int kTestKilledExitCode = 86;

/// Renames a finished temporary file onto its final name (atomic on POSIX file systems).
/// Every output file of every tool is committed here. For tests: with the environment variable
/// LUNARNAV_TEST_EXIT_BEFORE_COMMIT=k the process ends (kTestKilledExitCode, no clean-up, as if
/// killed) just before its k-th commit.
void CommitTempFile(const std::filesystem::path& temp, const std::filesystem::path& path);

/// A file written piece by piece under a temporary name and renamed by Commit(); destroyed
/// without Commit() (an exception on the way), it leaves nothing behind.
class AtomicOutputFile {
 public:
  /// Opens the temporary file; creates the parent directories.
  explicit AtomicOutputFile(const std::filesystem::path& path);
  ~AtomicOutputFile();
  AtomicOutputFile(const AtomicOutputFile&) = delete;
  AtomicOutputFile& operator=(const AtomicOutputFile&) = delete;
  void Write(std::string_view bytes);
  /// Flushes, closes and renames onto the final name.
  void Commit();

 private:
  std::filesystem::path path_, temp_;
  std::FILE* file_ = nullptr;
};

/// Creates `dir` (and its parents) for a tool's outputs. Throws std::invalid_argument (exit 2)
/// "<dir>: cannot create the output directory (<reason>)" when that is impossible, e.g. a
/// file of that name exists or permission is denied.
void CreateOutputDirectory(const std::filesystem::path& dir);

/// Checks that an input directory is one: throws InputError (exit 3) "<dir>: no such
/// directory" or "<dir>: not a directory (a file)", with `hint` appended when given.
void CheckInputDirectory(const std::filesystem::path& dir, const std::string& hint = "");

/// Deletes leftover temporary files of killed runs in `dir` (not recursive), and never those
/// being written: a temporary file is named after its host and process
/// (`.<name>.<host>-<pid>.<n>.lunarnav-tmp`), and is deleted when that process no longer runs
/// on this host, or, made on another host (shards of a batch on a cluster share the
/// directory), when untouched for an hour. Returns how many were deleted.
int RemoveStaleTempFiles(const std::filesystem::path& dir);

/// True for the names TempPathFor produces.
bool IsTempFileName(const std::filesystem::path& path);

}  // namespace lunarnav::io
