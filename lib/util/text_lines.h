// The one way the tools read a text file's lines (CSV trajectories, poses, frame times,
// requests, position tracks): as spreadsheets and other systems write them.
#pragma once

#include <filesystem>
#include <fstream>
#include <string>

namespace lunarnav::util {

/// A text file's content lines: a UTF-8 byte-order mark before the first line dropped, each
/// line's carriage return (CRLF files) and surrounding blanks and tabs dropped, blank lines and
/// '#' comment lines skipped (a trailing blank line of a CRLF file included).
class TextLines {
 public:
  /// @throws InputError naming the file when it cannot be opened.
  explicit TextLines(const std::filesystem::path& path);

  /// The next content line, trimmed; false at the end of the file.
  bool Next(std::string* line);
  /// The 1-based number of the line Next returned last.
  long number() const { return number_; }
  /// "FILE:LINE" of that line, for messages.
  std::string Where() const { return path_.string() + ":" + std::to_string(number_); }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
  std::ifstream in_;
  long number_ = 0;
};

}  // namespace lunarnav::util
