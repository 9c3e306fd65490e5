#pragma once
// Long calls run without the GIL and stop on the core's one cancellation token (the
// std::atomic<bool> that kelvin::Progress, cbf::RolloutOptions and the server's jobs poll).
// Python runs signal handlers only on the main thread, so Ctrl-C is noticed where the call came
// from: at the work's checkpoints when they run on the calling thread (GAP's share of a batch,
// CBF steps), or by the calling thread itself while the work runs on a helper thread (Kelvin
// preparation, whose mesher polls only the token). A pending KeyboardInterrupt, or an exception
// raised by the progress callback, sets the token and is re-raised once the work stopped.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <exception>
#include <functional>
#include <mutex>
#include <optional>
#include <thread>
#include <utility>
#include <vector>

#include <pybind11/pybind11.h>

namespace distlab::python {

class Interruptible {
 public:
  // GIL held. `callback` (None: none) receives report()'s arguments, always on the calling thread.
  explicit Interruptible(pybind11::object callback)
      : callback_(std::move(callback)), caller_(std::this_thread::get_id()) {}
  // Taking the GIL throws only when the interpreter is gone: terminating is all that is left then.
  ~Interruptible() {  // NOLINT(bugprone-exception-escape)
    pybind11::gil_scoped_acquire gil;
    error_.reset();
    callback_ = pybind11::object();
  }
  Interruptible(const Interruptible&) = delete;
  Interruptible& operator=(const Interruptible&) = delete;

  const std::atomic<bool>* flag() const { return &cancel_; }
  bool cancelled() const { return cancel_.load(std::memory_order_relaxed); }

  // A progress event from the work (any thread, GIL not held): on the calling thread the callback
  // runs now (after the signal handlers), from another thread it is queued for the calling thread.
  // False once cancelled.
  template <class... Args>
  bool report(Args... args) {
    if (cancelled()) return false;
    auto event = [this, args...] {
      if (!callback_.is_none()) callback_(args...);
    };
    if (std::this_thread::get_id() != caller_) {
      std::lock_guard lock(mutex_);
      events_.emplace_back(std::move(event));
      return true;
    }
    pybind11::gil_scoped_acquire gil;
    guarded([&] {
      check_signals();
      event();
    });
    return !cancelled();
  }

  // A checkpoint without an event: on the calling thread, at most every kPoll, runs the signal
  // handlers. Cheap elsewhere and between polls. False once cancelled.
  bool poll() {
    if (cancelled()) return false;
    if (std::this_thread::get_id() != caller_) return true;
    const auto now = std::chrono::steady_clock::now();
    if (now - last_poll_ < kPoll) return true;
    last_poll_ = now;
    pybind11::gil_scoped_acquire gil;
    guarded([&] { check_signals(); });
    return !cancelled();
  }

  // Runs work() on a helper thread while the calling thread (GIL released in between) runs the
  // signal handlers and the queued progress events every kPoll. Rethrows what work threw, or the
  // Python exception that cancelled it. GIL held on entry and exit.
  void run(const std::function<void()>& work) {
    std::exception_ptr failure;
    bool done = false;
    std::condition_variable finished;
    {
      pybind11::gil_scoped_release release;
      std::thread worker([&] {
        try {
          work();
        } catch (...) {
          failure = std::current_exception();
        }
        std::lock_guard lock(mutex_);
        done = true;
        finished.notify_one();
      });
      for (bool over = false; !over;) {
        {
          std::unique_lock lock(mutex_);
          over = finished.wait_for(lock, kPoll, [&] { return done; });
        }
        pybind11::gil_scoped_acquire gil;
        guarded([&] {
          if (!over) check_signals();
          deliver();
        });
      }
      worker.join();
    }
    if (error_) raise();
    if (failure) std::rethrow_exception(failure);
  }

  // After the work stopped on the token: raises what set it (GIL held).
  [[noreturn]] void raise() {
    if (error_) {
      error_->restore();
      error_.reset();
    } else {
      PyErr_SetString(PyExc_RuntimeError, "cancelled");
    }
    throw pybind11::error_already_set();
  }

 private:
  static constexpr std::chrono::milliseconds kPoll{20};

  static void check_signals() {
    if (PyErr_CheckSignals() != 0) throw pybind11::error_already_set();
  }
  // GIL held: the queued events, in order, unless cancelled meanwhile.
  void deliver() {
    std::vector<std::function<void()>> events;
    {
      std::lock_guard lock(mutex_);
      events.swap(events_);
    }
    for (auto& e : events)
      if (!cancelled()) e();
  }
  // GIL held: a Python exception from f cancels the work (the first one is kept).
  template <class F>
  void guarded(F&& f) {
    try {
      f();
    } catch (pybind11::error_already_set& e) {
      if (!error_) error_.emplace(std::move(e));
      cancel_.store(true);
    }
  }

  pybind11::object callback_;
  std::thread::id caller_;
  std::atomic<bool> cancel_{false};
  std::optional<pybind11::error_already_set> error_;
  std::mutex mutex_;
  std::vector<std::function<void()>> events_;
  std::chrono::steady_clock::time_point last_poll_ = std::chrono::steady_clock::now();
};

}  // namespace distlab::python
