#pragma once
// A task run every period on a thread of its own while an object lives: the field store's lease
// heartbeat, the elapsed-time progress of work that cannot report its own.
#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>
#include <utility>

namespace distlab {

class Periodic {
 public:
  // tick() runs every `period` (first after one period) until destruction.
  Periodic(std::chrono::steady_clock::duration period, std::function<void()> tick)
      : tick_(std::move(tick)), period_(period), thread_([this] { run(); }) {}
  // Stops the ticks and waits for the thread: no tick runs after this returns.
  ~Periodic() {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_one();
    thread_.join();
  }
  Periodic(const Periodic&) = delete;
  Periodic& operator=(const Periodic&) = delete;

 private:
  void run() {
    std::unique_lock<std::mutex> lock(mutex_);
    while (!wake_.wait_for(lock, period_, [this] { return stop_; })) tick_();
  }

  std::function<void()> tick_;
  std::chrono::steady_clock::duration period_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false;
  std::thread thread_;  // last: started once the members it reads are set
};

}  // namespace distlab
