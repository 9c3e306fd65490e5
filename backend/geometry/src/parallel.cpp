#include "distlab/geometry/parallel.hpp"

#include <algorithm>
#include <atomic>
#include <exception>
#include <system_error>
#include <thread>
#include <vector>

namespace distlab {

void parallel_for(std::size_t n, unsigned threads, const std::function<void(std::size_t)>& fn) {
  std::vector<std::exception_ptr> errors(n);
  std::atomic<std::size_t> next{0}, first_failure{n};
  auto work = [&] {
    for (std::size_t i; (i = next.fetch_add(1)) < n;) {
      if (i > first_failure.load()) continue;
      try {
        fn(i);
      } catch (...) {
        errors[i] = std::current_exception();
        for (std::size_t f = first_failure.load(); i < f && !first_failure.compare_exchange_weak(f, i);) {
        }
      }
    }
  };
  if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
  threads = static_cast<unsigned>(std::min<std::size_t>(threads, std::max<std::size_t>(n, 1)));
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < threads; ++t) {
    try {
      pool.emplace_back(work);
    } catch (const std::system_error&) {  // no more threads to be had: those running share the rest
      break;
    }
  }
  work();
  for (auto& t : pool) t.join();
  if (const std::size_t f = first_failure.load(); f < n) std::rethrow_exception(errors[f]);
}

}  // namespace distlab
