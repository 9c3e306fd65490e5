#pragma once
// The project's one fork-join over indices: every batch that fans out over cores (GAP pairs, the
// request codec's shapes, level-set grid rows, the Python bindings' blocks) goes through it. The
// server's WorkerPool is another thing: a queue of whole requests and jobs, bounded for back
// pressure; work it runs may itself call parallel_for.
#include <cstddef>
#include <functional>

namespace distlab {

// Runs fn(i) for every i < n on up to `threads` threads (0: all cores), the calling thread being
// one of them (so it may poll for interrupts), and returns when all calls have returned. If calls
// throw, the exception of the lowest failing index is rethrown, the one a sequential loop would
// throw; indices above a known failure are skipped. Without a thread to be had, the caller runs
// them all.
void parallel_for(std::size_t n, unsigned threads, const std::function<void(std::size_t)>& fn);

}  // namespace distlab
