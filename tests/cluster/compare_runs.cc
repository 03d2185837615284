// compare_runs A B: exits 0 when two batch output directories agree (every file byte for
// byte, JSON files timings aside; testing::CompareOutputDirs), else prints the differences
// and exits 1. The cluster test compares the Slurm run with the one-machine run with it.
#include <iostream>

#include "../integration/compare_outputs.h"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: compare_runs DIR_A DIR_B\n";
    return 2;
  }
  const auto differences = lunarnav::testing::CompareOutputDirs(argv[1], argv[2]);
  for (const auto& d : differences) std::cerr << "compare_runs: " << d << "\n";
  const std::size_t files = lunarnav::testing::OutputFiles(argv[1]).size();
  if (differences.empty()) std::cerr << "compare_runs: " << files << " files agree\n";
  return differences.empty() ? 0 : 1;
}
