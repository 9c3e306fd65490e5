#pragma once
// Long calls run without the GIL; their progress hooks take it back briefly to call the user's
// callback and to notice Ctrl-C. A pending KeyboardInterrupt (or an exception raised by the
// callback) sets the cancellation flag the core polls, and is re-raised once the core stopped.
#include <atomic>
#include <optional>
#include <string>

#include <pybind11/pybind11.h>

namespace distlab::python {

class Interruptible {
 public:
  explicit Interruptible(pybind11::object callback) : callback_(std::move(callback)) {}
  ~Interruptible() {
    pybind11::gil_scoped_acquire gil;
    error_.reset();
    callback_ = pybind11::object();
  }

  // Called from the work (any thread, GIL not held). False once cancelled.
  template <class... Args>
  bool report(Args&&... args) {
    if (cancel_.load()) return false;
    pybind11::gil_scoped_acquire gil;
    try {
      if (PyErr_CheckSignals() != 0) throw pybind11::error_already_set();
      if (!callback_.is_none()) callback_(std::forward<Args>(args)...);
    } catch (pybind11::error_already_set& e) {
      error_.emplace(std::move(e));
      cancel_.store(true);
      return false;
    }
    return true;
  }
  const std::atomic<bool>* flag() const { return &cancel_; }
  bool cancelled() const { return cancel_.load(); }

  // After the work stopped on the flag: raises what stopped it (GIL held).
  [[noreturn]] void raise() {
    if (error_) {
      error_->restore();
      error_.reset();
      throw pybind11::error_already_set();
    }
    throw pybind11::error_already_set();  // unreachable in practice: the flag is set with an error
  }

 private:
  pybind11::object callback_;
  std::atomic<bool> cancel_{false};
  std::optional<pybind11::error_already_set> error_;
};

}  // namespace distlab::python
