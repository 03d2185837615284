// Listing of stereo image-pair directories (INPUT_DIR/left, INPUT_DIR/right with the same
// file stems), shared by every tool that runs over a pair sequence.
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace lunarnav::io {

/// One pair found in INPUT_DIR (left/<stem>.<ext>, right/<stem>.<ext>); a path is empty when
/// that side is missing, and `problem` says what is wrong with the pair as listed.
struct PairFiles {
  std::string stem;
  std::filesystem::path left, right;
  std::string problem;  ///< Empty when both images exist once each.
};

/// The folders of INPUT_DIR's left and right images: left/ and right/; else KITTI's layouts,
/// its grey pair before its colour pair: image_0/ and image_1/ (odometry), image_00/data/ and
/// image_01/data/ (raw), image_2/ and image_3/, image_02/data/ and image_03/data/.
/// @throws InputError when INPUT_DIR or both folders of every layout are missing, or one of a
///         layout's two is.
std::pair<std::filesystem::path, std::filesystem::path> PairFolders(const std::filesystem::path& input_dir);

/// Lists the pairs of INPUT_DIR (PairFolders) in name order (byte-wise order of the stems).
/// Files whose extension is not an image's, and hidden files, are ignored.
/// @throws InputError as PairFolders.
std::vector<PairFiles> ListStereoPairs(const std::filesystem::path& input_dir);

/// The stems of a listing, in its order.
std::vector<std::string> PairStems(const std::vector<PairFiles>& listing);

/// The items of shard K of N: indices i with i % N == K, in order.
/// @throws std::invalid_argument unless 0 <= K < N.
template <typename T>
std::vector<const T*> SelectShard(const std::vector<T>& items, int shard_index, int shard_count);

/// "summary.json", or "summary.shard-K-of-N.json" when N > 1.
std::string SummaryFileName(int shard_index, int shard_count);

// ---------------------------------------------------------------------------------------------

void CheckShard(int shard_index, int shard_count);

template <typename T>
std::vector<const T*> SelectShard(const std::vector<T>& items, int shard_index, int shard_count) {
  CheckShard(shard_index, shard_count);
  std::vector<const T*> shard;
  for (std::size_t i = static_cast<std::size_t>(shard_index); i < items.size();
       i += static_cast<std::size_t>(shard_count)) {
    shard.push_back(&items[i]);
  }
  return shard;
}

}  // namespace lunarnav::io
