// Private: the one way the library runs work on several threads (fits, surfaces, discovery,
// the HTML report's slices). docs/cli.md "--threads" documents the cap.
#pragma once

#include <cstddef>
#include <functional>

namespace blmd::internal {

// The most worker threads any call uses; a larger request is capped to this. Far above any
// machine's useful parallelism for this work (each item is a whole simulation), and low
// enough that a typo (--threads 40000) does not ask the OS for tens of thousands of stacks.
inline constexpr int kMaxThreads = 256;

// The number of threads a request means: 0 (or less) = the machine's hardware threads
// (1 when unknown), otherwise `requested`, capped at kMaxThreads.
int ThreadCount(int requested);

// Calls body(k) once for every k in [0, count), on up to ThreadCount(threads) threads (the
// calling thread is one of them; never more threads than items). Items are handed out one
// at a time from a shared counter, so which thread runs an item varies, but every item runs
// exactly once: a body that writes only its own item's slot gives results independent of
// the thread count. When the OS refuses a thread (std::system_error: a process limit, no
// memory for its stack) the threads already started, at least the calling one, do all the
// work. When a body throws, no further items are started and the first exception is
// rethrown in the calling thread after every thread has finished.
void ParallelFor(std::size_t count, int threads, const std::function<void(std::size_t)>& body);

}  // namespace blmd::internal
