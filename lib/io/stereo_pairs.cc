#include "io/stereo_pairs.h"

#include <map>

#include "io/atomic_file.h"
#include "io/image_io.h"
#include "util/check.h"
#include "util/errors.h"

namespace lunarnav::io {
namespace fs = std::filesystem;

namespace {

// stem -> the image files with that stem in one directory.
std::map<std::string, std::vector<fs::path>> ImagesByStem(const fs::path& dir) {
  std::map<std::string, std::vector<fs::path>> by_stem;
  std::error_code ec;
  for (auto it = fs::directory_iterator(dir, ec); !ec && it != fs::directory_iterator(); it.increment(ec)) {
    const fs::path& path = it->path();
    const std::string name = path.filename().string();
    if (name.empty() || name[0] == '.' || !HasImageExtension(path)) continue;
    // An entry's own trouble (a link looping or pointing nowhere) is that pair's problem,
    // reported when it is read; it must not stop the listing of the others.
    std::error_code entry_ec;
    if (!it->is_regular_file(entry_ec) && !it->is_symlink(entry_ec)) continue;
    by_stem[path.stem().string()].push_back(path);
  }
  LN_CHECK_INPUT(!ec) << dir.string() << ": cannot list (" << ec.message() << ")";
  return by_stem;
}

}  // namespace

std::pair<fs::path, fs::path> PairFolders(const fs::path& input_dir) {
  std::error_code ec;
  CheckInputDirectory(input_dir);
  // left/ and right/; else KITTI's layouts, the grey pair first: odometry's image_0/ and
  // image_1/, raw's image_00/data/ and image_01/data/, then the colour pairs.
  static const char* const kLayouts[][2] = {{"left", "right"},           {"image_0", "image_1"},
                                            {"image_00/data", "image_01/data"}, {"image_2", "image_3"},
                                            {"image_02/data", "image_03/data"}};
  for (const auto& layout : kLayouts) {
    if (fs::is_directory(input_dir / layout[0], ec) || fs::is_directory(input_dir / layout[1], ec)) {
      const fs::path left = input_dir / layout[0], right = input_dir / layout[1];
      LN_CHECK_INPUT(fs::is_directory(left, ec))
          << input_dir.string() << ": no " << layout[0] << "/ beside " << layout[1] << "/";
      LN_CHECK_INPUT(fs::is_directory(right, ec))
          << input_dir.string() << ": no " << layout[1] << "/ beside " << layout[0] << "/";
      return {left, right};
    }
  }
  throw InputError(input_dir.string() + ": no left/ directory (expected left/ and right/ image folders, or KITTI's "
                   "image_0/ and image_1/, image_00/data/ and image_01/data/)");
}

std::vector<PairFiles> ListStereoPairs(const fs::path& input_dir) {
  const auto [left_dir, right_dir] = PairFolders(input_dir);
  const auto lefts = ImagesByStem(left_dir);
  const auto rights = ImagesByStem(right_dir);
  std::map<std::string, PairFiles> pairs;
  auto add = [&](const std::map<std::string, std::vector<fs::path>>& side, bool is_left) {
    for (const auto& [stem, files] : side) {
      PairFiles& pair = pairs[stem];
      pair.stem = stem;
      (is_left ? pair.left : pair.right) = files.front();
      if (files.size() > 1 && pair.problem.empty()) {
        pair.problem = files[1].string() + ": several images with stem '" + stem + "' (" +
                       files[0].filename().string() + ", " + files[1].filename().string() + ")";
      }
    }
  };
  add(lefts, true);
  add(rights, false);
  std::vector<PairFiles> listing;
  for (auto& [stem, pair] : pairs) {
    if (pair.problem.empty() && pair.left.empty()) {
      pair.problem = (left_dir / (stem + ".*")).string() + ": missing (right image " +
                     pair.right.filename().string() + " has no partner)";
    }
    if (pair.problem.empty() && pair.right.empty()) {
      pair.problem = (right_dir / (stem + ".*")).string() + ": missing (left image " +
                     pair.left.filename().string() + " has no partner)";
    }
    listing.push_back(std::move(pair));
  }
  return listing;
}

std::vector<std::string> PairStems(const std::vector<PairFiles>& listing) {
  std::vector<std::string> stems;
  stems.reserve(listing.size());
  for (const PairFiles& p : listing) stems.push_back(p.stem);
  return stems;
}

void CheckShard(int shard_index, int shard_count) {
  LN_CHECK_ARG(shard_count >= 1 && shard_index >= 0 && shard_index < shard_count)
      << "shard: need 0 <= K < N, got " << shard_index << "/" << shard_count;
}

std::string SummaryFileName(int shard_index, int shard_count) {
  if (shard_count == 1) return "summary.json";
  return "summary.shard-" + std::to_string(shard_index) + "-of-" + std::to_string(shard_count) +
         ".json";
}

}  // namespace lunarnav::io
