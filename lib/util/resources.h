// Process resource figures reported in summaries, and how the process uses memory.
#pragma once

namespace lunarnav::util {

/// Peak resident set size of this process so far, in MiB (getrusage; 0 if unavailable).
double PeakResidentMemoryMiB();

/// Lets a buffer freed by one stage be taken again by the next instead of going back to the
/// kernel: malloc serves blocks up to 32 MiB from its heaps (not from a fresh mapping each) and
/// keeps up to 512 MiB of freed heap. A fresh page costs a fault and its zero-filling at first
/// touch; one stereo pair of 1242 x 375 allocates some 40 MB of images, codes and maps, and
/// touched afresh they were 10,000 faults a pair. Called once at the start of every tool
/// (RunMain); glibc only (elsewhere nothing is done).
void KeepFreedMemoryForReuse();

}  // namespace lunarnav::util
