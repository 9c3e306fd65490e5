#pragma once
// The time limit of one synchronous request (Limits::max_request_seconds): work checks it between
// chunks and stops with 408 time_limit, so a request can never hold a compute thread for long.
// Work that polls only a cancel flag (Progress::cancel: the mesher) gets CancelAfter's.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <string>
#include <thread>

#include "distlab/server/http.hpp"

namespace distlab::server {

class Deadline {
 public:
  explicit Deadline(double seconds)
      : end_(std::chrono::steady_clock::now() +
             std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(seconds))) {}
  bool expired() const { return std::chrono::steady_clock::now() > end_; }
  // Throws ApiError 408 time_limit once expired; `hint` tells how to ask for less.
  void check(const std::string& hint) const {
    if (expired()) throw ApiError(408, "time_limit", "the request exceeded this server's time limit; " + hint);
  }

 private:
  std::chrono::steady_clock::time_point end_;
};

// The time limit as a flag that becomes true `seconds` after construction (a watchdog thread;
// never when seconds is not positive): the cancel token of work a request bounds by
// max_request_seconds.
class CancelAfter {
 public:
  explicit CancelAfter(double seconds);
  ~CancelAfter();
  CancelAfter(const CancelAfter&) = delete;
  CancelAfter& operator=(const CancelAfter&) = delete;
  const std::atomic<bool>* flag() const { return &flag_; }
  bool fired() const { return flag_.load(); }

 private:
  std::atomic<bool> flag_{false};
  std::mutex mutex_;
  std::condition_variable cv_;
  bool done_ = false;
  std::thread thread_;
};

}  // namespace distlab::server
