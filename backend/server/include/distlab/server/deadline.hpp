#pragma once
// The time limit of one synchronous request (Limits::max_request_seconds): work checks it between
// chunks and stops with 408 time_limit, so a request can never hold a compute thread for long.
#include <chrono>
#include <string>

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

}  // namespace distlab::server
