// Test helper: runs a built tool and captures its exit code and stderr.
#pragma once

#include <sys/wait.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "util/testing.h"

namespace lunarnav::testing {

struct ToolRun {
  int exit_code = -1;
  std::string stderr_text;
  /// Number of lines of stderr starting with "error:".
  int ErrorLines() const {
    std::istringstream in(stderr_text);
    int count = 0;
    for (std::string line; std::getline(in, line);) count += line.rfind("error:", 0) == 0;
    return count;
  }
};

inline std::string ShellQuote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

/// Runs `tool args...` (stdout discarded, stderr captured into a file of `scratch`).
inline ToolRun RunTool(const std::string& tool, const std::vector<std::string>& args,
                       const std::filesystem::path& scratch) {
  const std::filesystem::path err = scratch / ("stderr-" + tool + ".txt");
  std::string command = ShellQuote(util::ToolPath(tool).string());
  for (const std::string& a : args) command += " " + ShellQuote(a);
  command += " >/dev/null 2>" + ShellQuote(err.string());
  const int status = std::system(command.c_str());
  ToolRun run;
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream in(err);
  std::stringstream text;
  text << in.rdbuf();
  run.stderr_text = text.str();
  return run;
}

/// The whole content of a file (empty if it cannot be read).
inline std::string ReadFileBytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// Every file under `dir` but summary.json (timings, revision), by relative path, sorted: the
/// outputs that must be identical from run to run.
inline std::vector<std::string> DataFiles(const std::filesystem::path& dir) {
  std::vector<std::string> files;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(dir)) {
    if (entry.is_regular_file() && entry.path().filename() != "summary.json") {
      files.push_back(std::filesystem::relative(entry.path(), dir).string());
    }
  }
  std::sort(files.begin(), files.end());
  return files;
}

}  // namespace lunarnav::testing
