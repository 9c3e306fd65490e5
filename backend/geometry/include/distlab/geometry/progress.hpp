#pragma once
// Progress reporting and cooperative cancellation for long work (Kelvin preparation, mesh repair
// and wrapping): the job's one cancel flag is polled between chunks; Cancelled unwinds the work.
#include <atomic>
#include <functional>
#include <stdexcept>
#include <string>

namespace distlab {

class Cancelled : public std::runtime_error {
 public:
  Cancelled() : std::runtime_error("cancelled") {}
};

struct Progress {
  // stage is "repair" (mesh::fix, mesh::wrap), "simplify" (mesh::simplify) or Kelvin's "load", "invert", "mesh", "build",
  // "decomp", "solve", "cache", "response"; fraction in [0, 1].
  std::function<void(const std::string& stage, double fraction)> report;
  const std::atomic<bool>* cancel = nullptr;

  void operator()(const std::string& stage, double fraction) const {
    check();
    if (report) report(stage, fraction);
  }
  bool cancelled() const { return cancel != nullptr && cancel->load(std::memory_order_relaxed); }
  void check() const {
    if (cancelled()) throw Cancelled();
  }
};

}  // namespace distlab
