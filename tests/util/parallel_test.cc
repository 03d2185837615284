// util::ParallelForEachItem and EffectiveThreadCount: every item once, on at most the cores.
#include "util/parallel.h"

#include <gtest/gtest.h>

#include <atomic>
#include <climits>
#include <thread>
#include <vector>

#include <tbb/info.h>

namespace lunarnav::util {
namespace {

TEST(EffectiveThreadCount, ZeroAndCountsAboveTheCoresMeanTheCores) {
  const int cores = tbb::info::default_concurrency();
  EXPECT_EQ(EffectiveThreadCount(0), cores);
  EXPECT_EQ(EffectiveThreadCount(1), 1);
  EXPECT_EQ(EffectiveThreadCount(cores + 1), cores);
  EXPECT_EQ(EffectiveThreadCount(INT_MAX), cores);
}

TEST(ParallelForEachItem, RunsEveryItemOnceWhateverTheThreadCount) {
  for (const int threads : {0, 1, 2, 1000, INT_MAX}) {
    std::vector<std::atomic<int>> calls(100);
    ParallelForEachItem(calls.size(), threads, [&](std::size_t i) { ++calls[i]; });
    for (std::size_t i = 0; i < calls.size(); ++i) EXPECT_EQ(calls[i].load(), 1) << threads << " threads, item " << i;
  }
}

}  // namespace
}  // namespace lunarnav::util
