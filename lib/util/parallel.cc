#include "util/parallel.h"

#include <algorithm>

#include <tbb/blocked_range.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

namespace lunarnav::util {

void ParallelForEachItem(std::size_t n, int num_threads, const std::function<void(std::size_t)>& fn) {
  tbb::task_arena arena(EffectiveThreadCount(num_threads));
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1),
                      [&](const tbb::blocked_range<std::size_t>& range) {
                        // Isolated: a thread waiting inside an item's own parallel work must not
                        // pick up another item meanwhile, which would reuse that thread's
                        // per-thread buffers (the matcher's workspace, the batch's result maps)
                        // while they are still in use.
                        for (std::size_t i = range.begin(); i != range.end(); ++i) {
                          tbb::this_task_arena::isolate([&] { fn(i); });
                        }
                      },
                      tbb::simple_partitioner());
  });
}

int EffectiveThreadCount(int num_threads) {
  // More threads than cores only share them, and TBB, asked for many more, warns on stderr
  // (past --quiet) or fails: every tool's -j stops at the cores.
  const int cores = std::max(1, tbb::info::default_concurrency());
  return num_threads > 0 ? std::min(num_threads, cores) : cores;
}

}  // namespace lunarnav::util
