#pragma once
// The fraction done of work that cannot report its own (CHOLMOD's numeric factorization is one
// call), estimated from the time elapsed against a predicted duration and reported from a thread
// of its own while the work runs.
#include <chrono>
#include <functional>
#include <optional>

#include "distlab/geometry/periodic.hpp"

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

  // report(fraction in [0, 1)) every `period` from another thread, from construction until
  // destruction (none comes after the destructor returns).
  ElapsedProgress(const std::function<void(double)>& report, double predicted_seconds,
                  std::chrono::milliseconds period = std::chrono::milliseconds(250)) {
    if (!report || !(predicted_seconds > 0)) return;
    const auto start = std::chrono::steady_clock::now();
    ticker_.emplace(period, [report, predicted_seconds, start] {
      const std::chrono::duration<double> elapsed = std::chrono::steady_clock::now() - start;
      report(fraction(elapsed.count(), predicted_seconds));
    });
  }

 private:
  std::optional<Periodic> ticker_;
};

}  // namespace distlab::kelvin
