#pragma once
// A fixed set of threads running posted tasks in FIFO order; stop() drains nothing new and joins.
#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace distlab::server {

class WorkerPool {
 public:
  // threads 0: hardware concurrency. on_start runs first on each thread (e.g. warm_thread_heap).
  explicit WorkerPool(unsigned threads, const std::function<void()>& on_start = {});
  ~WorkerPool();
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  // False (task dropped) if more than max_pending tasks wait or the pool is stopping.
  bool post(std::function<void()> task, std::size_t max_pending = ~std::size_t{0});
  std::size_t pending() const;
  unsigned size() const { return static_cast<unsigned>(threads_.size()); }
  void stop();  // runs the tasks already queued, then joins

 private:
  void loop(const std::function<void()>& on_start);
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<std::function<void()>> tasks_;
  bool stopping_ = false;
  std::vector<std::thread> threads_;
};

// A thread's first large allocations come from a fresh glibc arena whose pages fault in on first
// touch (~15 µs each on a VM): measured, the first σ edit's frame took 550 faults, +8 ms. Run on
// a new thread, this touches `bytes` of its arena and frees them; the pages stay, as the first
// call sets the process's malloc to keep freed memory (no trim below 64 MB) and to serve blocks
// below 32 MB from the arenas (not a fresh mmap each).
void warm_thread_heap(std::size_t bytes);

}  // namespace distlab::server
