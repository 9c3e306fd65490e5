#include "distlab/server/worker_pool.hpp"

#include <malloc.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <mutex>

namespace distlab::server {

WorkerPool::WorkerPool(unsigned threads, const std::function<void()>& on_start) {
  if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
  for (unsigned i = 0; i < threads; ++i) threads_.emplace_back([this, on_start] { loop(on_start); });
}

WorkerPool::~WorkerPool() { stop(); }

bool WorkerPool::post(std::function<void()> task, std::size_t max_pending) {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ || tasks_.size() >= max_pending) return false;
    tasks_.push_back(std::move(task));
  }
  cv_.notify_one();
  return true;
}

std::size_t WorkerPool::pending() const {
  std::lock_guard lock(mutex_);
  return tasks_.size();
}

void WorkerPool::stop() {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ && threads_.empty()) return;
    stopping_ = true;
  }
  cv_.notify_all();
  for (auto& t : threads_)
    if (t.joinable()) t.join();
  threads_.clear();
}

void WorkerPool::loop(const std::function<void()>& on_start) {
  if (on_start) on_start();
  for (;;) {
    std::function<void()> task;
    {
      std::unique_lock lock(mutex_);
      cv_.wait(lock, [&] { return stopping_ || !tasks_.empty(); });
      if (tasks_.empty()) return;
      task = std::move(tasks_.front());
      tasks_.pop_front();
    }
    try {
      task();
    } catch (const std::exception& e) {
      std::fprintf(stderr, "distlab serve: task failed: %s\n", e.what());
    } catch (...) {
      std::fprintf(stderr, "distlab serve: task failed\n");
    }
  }
}

void warm_thread_heap(std::size_t bytes) {
  static std::once_flag policy;
  std::call_once(policy, [] {
    // Fixed thresholds also turn off glibc's dynamic ones, which send each new large block to a
    // fresh mmap until a block that large has been freed.
    mallopt(M_MMAP_THRESHOLD, 32 << 20);  // glibc's largest: half an arena heap
    mallopt(M_TRIM_THRESHOLD, 64 << 20);
  });
  void* p = std::malloc(bytes);
  if (p == nullptr) return;  // only an optimisation
  std::memset(p, 1, bytes);
  asm volatile(""
               :
               : "r"(p)
               : "memory");  // the stores must happen: nothing reads them
  std::free(p);
}

}  // namespace distlab::server
