// Item-parallel loops for batch tools (one image pair, one log per task).
#pragma once

#include <cstddef>
#include <functional>

namespace lunarnav::util {

/// Calls fn(i) for i in [0, n) on EffectiveThreadCount(num_threads) threads, one item per
/// task so that slow items do not hold up a whole block. Each call runs isolated: a thread
/// waiting inside fn(i)'s own parallel work never starts another item meanwhile (so per-thread
/// buffers an item holds are not reused under it). Returns when every call has returned; the
/// first exception thrown by fn is rethrown here.
void ParallelForEachItem(std::size_t n, int num_threads, const std::function<void(std::size_t)>& fn);

/// The number of threads `num_threads` means: 0 = all cores; more than the cores = the cores
/// (every tool's -j: a count above the machine's only shares its cores, and an absurd one
/// made the thread library fail). ParallelForEachItem and the matcher's arena use it.
int EffectiveThreadCount(int num_threads);

}  // namespace lunarnav::util
