// A bound on how deeply a structured text (YAML, JSON, XML) nests, checked before a parser
// that recurses once per level (OpenCV's FileStorage) sees the text: a 100 KB calibration file
// nested 50,000 deep overflows the stack of such a parser (a signal death, not bad input).
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

namespace lunarnav::io {

/// The deepest nesting a calibration or configuration file may have: far above any real one
/// (an OpenCV, ROS or Kalibr calibration nests 3-4 deep), far below a parser's stack.
inline constexpr int kMaxNestingDepth = 64;

/// The first line (1-based) at which `text` nests deeper than `max_depth`, else nullopt.
/// XML (the text starts with '<'): open elements (not `<?...?>`, `<!...>` or `<.../>`).
/// YAML and JSON: flow collections ('[', '{') outside quoted scalars and comments, plus the
/// block levels (each deeper indentation, and each "- " entry opening a line's content).
/// Counts at least what a parser descends, so that a text it accepts is never deeper.
std::optional<long> FirstLineDeeperThan(std::string_view text, int max_depth);

/// Throws InputError "FILE: line L: nested deeper than N levels" when FirstLineDeeperThan finds one.
void CheckNestingDepth(std::string_view text, const std::string& file, int max_depth = kMaxNestingDepth);

/// The largest calibration or configuration file read whole (bytes): 16 MiB, a thousand
/// times a real one.
inline constexpr std::uintmax_t kMaxConfigBytes = std::uintmax_t{16} << 20;

/// Reads a calibration or configuration file whole, after checking its size against
/// `max_bytes` (before reading) and then, with `check_nesting`, its nesting
/// (CheckNestingDepth; off for texts given to parsers that bound their depth themselves).
/// @throws InputError naming the file: missing, unreadable, too large or nested too deep.
std::string ReadConfigText(const std::filesystem::path& path, std::uintmax_t max_bytes = kMaxConfigBytes,
                           bool check_nesting = true);

}  // namespace lunarnav::io
