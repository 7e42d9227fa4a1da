#pragma once
// The library's one thread pool: every parallel loop of pairgrasp (index build, alignment, distance
// fields, checks, the candidate pipeline) runs on it. Internal to cpp/src.
#include <cstddef>
#include <functional>

namespace pairgrasp::detail {

/// Worker threads for a requested count: `requested` when > 0, else every core.
int resolve_threads(int requested);

/// Runs body(i) for every i in [0, n) on at most `threads` threads (0: every core): the calling
/// thread and workers of the shared pool, which take the next index as they become free (dynamic
/// scheduling: items of very different cost balance). Bodies must write disjoint outputs; the
/// order in which items run is not defined, so results must not depend on it. Nested calls (a
/// body that calls parallel_for) are allowed: the caller always works through the remaining items
/// itself, so it never waits for a worker that has not started, and while it waits for the threads
/// still inside its items it runs items of other open loops (the loops nested in those items, or
/// another caller's), one at a time, so that no thread idles while work is queued. The first exception a body throws
/// stops further items from starting and is rethrown once the running ones have finished.
void parallel_for(std::size_t n, int threads, const std::function<void(std::size_t)>& body);

/// Runs body(begin, end, t) over [0, n) cut into `threads` contiguous chunks (t = 0..threads-1, the
/// chunking depends only on n and threads) on the shared pool. Bodies must write disjoint outputs.
void parallel_chunks(std::size_t n, int threads, const std::function<void(std::size_t, std::size_t, int)>& body);

}  // namespace pairgrasp::detail
