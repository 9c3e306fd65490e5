#pragma once
// Progress reporting and cooperative cancellation for long preparation work.
#include <atomic>
#include <functional>
#include <stdexcept>
#include <string>

namespace distlab::kelvin {

class Cancelled : public std::runtime_error {
 public:
  Cancelled() : std::runtime_error("cancelled") {}
};

struct Progress {
  // stage is "load", "invert", "mesh", "build", "decomp", "solve", "cache"; fraction in [0, 1].
  std::function<void(const std::string& stage, double fraction)> report;
  const std::atomic<bool>* cancel = nullptr;

  void operator()(const std::string& stage, double fraction) const {
    check();
    if (report) report(stage, fraction);
  }
  void check() const {
    if (cancel != nullptr && cancel->load(std::memory_order_relaxed)) throw Cancelled();
  }
};

}  // namespace distlab::kelvin
