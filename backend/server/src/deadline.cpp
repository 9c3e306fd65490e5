// The time limit as a cancel flag (deadline.hpp).
#include "distlab/server/deadline.hpp"

namespace distlab::server {

CancelAfter::CancelAfter(double seconds) {
  if (!(seconds > 0)) return;
  thread_ = std::thread([this, seconds] {
    std::unique_lock lock(mutex_);
    if (!cv_.wait_for(lock, std::chrono::duration<double>(seconds), [this] { return done_; })) flag_.store(true);
  });
}

CancelAfter::~CancelAfter() {
  {
    std::lock_guard lock(mutex_);
    done_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

}  // namespace distlab::server
