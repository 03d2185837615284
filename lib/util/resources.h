// Process resource figures reported in summaries.
#pragma once

namespace lunarnav::util {

/// Peak resident set size of this process so far, in MiB (getrusage; 0 if unavailable).
double PeakResidentMemoryMiB();

}  // namespace lunarnav::util
