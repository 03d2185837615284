// The planner's requests (Krotkov & Hebert sec. 3.3): for each image pair, the interval of
// forward distances I_Y = [Y_min, Y_max] within which it needs data. stereo-batch --requests.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace lunarnav::stereo {

/// The farthest a request may reach, metres (plan-windows' own limit,
/// mapping::kMaxRequestDistanceM): a request file beyond it is bad input.
inline constexpr double kMaxRequestY = 1000.0;

/// One request: pair `stem` needs points with Y in [y_min_m, y_max_m] (vehicle frame, metres).
struct WindowRequest {
  std::string stem;
  double y_min_m = 0, y_max_m = 0;
  long line = 0;  ///< Line of the file it came from (1-based), for error messages.
};

/// Reads a requests CSV (docs/formats.md, "Window requests"): a header `stem,y_min_m,y_max_m`,
/// then one line per pair; blank lines and lines starting with '#' are skipped, cells may be
/// padded with spaces.
/// @throws InputError naming the file and line: unreadable file, wrong header, wrong number of
///         cells, an empty stem, a value that is not a finite number, Y_min > Y_max, or a stem
///         requested twice.
std::vector<WindowRequest> ReadWindowRequests(const std::filesystem::path& path);

}  // namespace lunarnav::stereo
