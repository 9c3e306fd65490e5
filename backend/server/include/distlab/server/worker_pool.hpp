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
  explicit WorkerPool(unsigned threads);  // 0: hardware concurrency
  ~WorkerPool();
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  // False (task dropped) if more than max_pending tasks wait or the pool is stopping.
  bool post(std::function<void()> task, std::size_t max_pending = ~std::size_t{0});
  std::size_t pending() const;
  unsigned size() const { return static_cast<unsigned>(threads_.size()); }
  void stop();  // runs the tasks already queued, then joins

 private:
  void loop();
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<std::function<void()>> tasks_;
  bool stopping_ = false;
  std::vector<std::thread> threads_;
};

}  // namespace distlab::server
