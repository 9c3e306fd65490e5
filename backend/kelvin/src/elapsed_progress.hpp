#pragma once
// The fraction done of work that cannot report its own (CHOLMOD's numeric factorization is one
// call), estimated from the time elapsed against a predicted duration and reported from a thread
// of its own while the work runs.
#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>
#include <utility>

namespace distlab::kelvin {

class ElapsedProgress {
 public:
  // Linear up to 0.9 of the predicted time, then towards 1 without reaching it, continuous and
  // increasing: a work that runs longer than predicted stalls near the end instead of passing it.
  static double fraction(double elapsed, double predicted) {
    if (!(predicted > 0) || !(elapsed > 0)) return 0;
    const double r = elapsed / predicted;
    return r <= 0.9 ? r : 1 - 0.1 / (1 + (r - 0.9) / 0.1);  // same slope at 0.9; < 1 in double up to r ~ 1e14
  }

  // report(fraction in [0, 1)) every `period` from another thread, from construction on.
  ElapsedProgress(std::function<void(double)> report, double predicted_seconds,
                  std::chrono::milliseconds period = std::chrono::milliseconds(250))
      : report_(std::move(report)), predicted_(predicted_seconds), period_(period) {
    if (report_ && predicted_ > 0) thread_ = std::thread([this] { run(); });
  }
  // Stops the reports and waits for the thread: none comes after this returns.
  ~ElapsedProgress() {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_one();
    if (thread_.joinable()) thread_.join();
  }
  ElapsedProgress(const ElapsedProgress&) = delete;
  ElapsedProgress& operator=(const ElapsedProgress&) = delete;

 private:
  void run() {
    const auto start = std::chrono::steady_clock::now();
    std::unique_lock<std::mutex> lock(mutex_);
    while (!wake_.wait_for(lock, period_, [this] { return stop_; })) {
      const std::chrono::duration<double> elapsed = std::chrono::steady_clock::now() - start;
      report_(fraction(elapsed.count(), predicted_));
    }
  }

  std::function<void(double)> report_;
  double predicted_;
  std::chrono::milliseconds period_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false;
  std::thread thread_;  // last: started once the members it reads are set
};

}  // namespace distlab::kelvin
