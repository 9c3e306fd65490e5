// A sweep's runs in parallel (cbf_json.hpp execute_sweep): independent rollouts, so each entry is
// what the run alone gives, whichever thread computed it; entries are kept by index.
#include <algorithm>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <thread>

#include "distlab/geometry/parallel.hpp"
#include "distlab/geometry/progress.hpp"
#include "distlab/server/cbf_json.hpp"

namespace distlab::server {

using json = nlohmann::json;

namespace {

struct SweepState {
  // sweep and how are read only by a thread that claimed a run: the caller waits for those.
  const CbfSweep* sweep = nullptr;
  const SweepExecution* how = nullptr;
  std::function<bool(std::function<void()>)> post;  // a copy: helpers re-post after the caller left
  bool one_run_per_task = false;
  std::size_t n = 0;
  std::atomic<std::size_t> next{0};
  std::atomic<bool> failed{false};

  std::mutex mutex;  // everything below
  std::condition_variable all_ended;
  std::size_t ended = 0;  // claimed runs that returned
  std::size_t runs_done = 0;
  std::vector<int> steps_done;
  double steps_total = 0, steps_sum = 0;
  int reported_permille = -1;
  std::string reported_stage;
  std::vector<json> entries;
  std::vector<std::exception_ptr> errors;

  bool stopped() const {
    return failed.load(std::memory_order_relaxed) || (how->progress.cancel && how->progress.cancel->load(std::memory_order_relaxed));
  }
  // Under mutex: one report per new stage or per 0.1 % (fraction never decreases).
  void report_locked() {
    if (!how->progress.report) return;
    const std::string stage = std::to_string(runs_done) + " of " + std::to_string(n) + " runs done";
    const double fraction = steps_total > 0 ? std::min(1.0, steps_sum / steps_total) : 1.0;
    const int permille = static_cast<int>(fraction * 1000);
    if (stage == reported_stage && permille <= reported_permille) return;
    reported_stage = stage;
    reported_permille = permille;
    how->progress.report(stage, fraction);
  }
};

// Claims the next run and runs it; false when every run was claimed.
bool run_next(const std::shared_ptr<SweepState>& st) {
  const std::size_t i = st->next.fetch_add(1);
  if (i >= st->n) return false;
  try {
    if (!st->stopped()) {
      const CbfRequest& r = st->sweep->runs[i];
      cbf::RolloutOptions options = r.options;
      options.progress.cancel = st->how->progress.cancel;
      // A run stops (Cancelled) when the sweep is cancelled or another run failed.
      options.on_step = [&](int k, const cbf::StepRecord&) {
        std::lock_guard lock(st->mutex);
        st->steps_sum += k + 1 - st->steps_done[i];
        st->steps_done[i] = k + 1;
        st->report_locked();
        if (st->stopped()) throw Cancelled();
      };
      const cbf::RolloutRecord rec = cbf::rollout(r.scenario, r.metric, options);
      json entry = encode_sweep_entry(i, st->sweep->values[i], rec, r.scenario.name);
      std::lock_guard lock(st->mutex);
      if (st->how->finished) st->how->finished(i, entry);
      st->entries[i] = std::move(entry);
      ++st->runs_done;
      st->report_locked();
    }
  } catch (const Cancelled&) {  // a stopped run has no entry
  } catch (...) {
    std::lock_guard lock(st->mutex);
    st->errors[i] = std::current_exception();
    st->failed.store(true);
  }
  std::lock_guard lock(st->mutex);
  if (++st->ended == st->n) st->all_ended.notify_all();
  return true;
}

// A helper thread's share: runs until none is left, or (one_run_per_task) one run, then posts its
// successor behind whatever else waits in the pool.
void helper(const std::shared_ptr<SweepState>& st) {
  if (!st->one_run_per_task) {
    while (run_next(st)) {
    }
    return;
  }
  if (run_next(st) && st->next.load() < st->n && !st->post([st] { helper(st); }))
    while (run_next(st)) {
    }
}

}  // namespace

std::vector<json> execute_sweep(const CbfSweep& sweep, const SweepExecution& how) {
  auto st = std::make_shared<SweepState>();
  st->sweep = &sweep;
  st->how = &how;
  st->post = how.post;
  st->one_run_per_task = how.one_run_per_task;
  st->n = sweep.runs.size();
  st->steps_done.assign(st->n, 0);
  st->entries.assign(st->n, json());
  st->errors.assign(st->n, nullptr);
  for (const CbfRequest& r : sweep.runs) st->steps_total += std::max(1, r.scenario.steps());
  const unsigned helpers = std::min<unsigned>(how.helpers, static_cast<unsigned>(st->n) - 1);
  if (st->post) {
    for (unsigned h = 0; h < helpers; ++h)
      if (!st->post([st] { helper(st); })) break;
    while (run_next(st)) {
    }
  } else {  // the project's fork-join: the caller and `helpers` threads share the runs
    parallel_for(helpers + 1, helpers + 1, [&st](std::size_t) {
      while (run_next(st)) {
      }
    });
  }
  std::unique_lock lock(st->mutex);
  st->all_ended.wait(lock, [&] { return st->ended == st->n; });
  for (const auto& e : st->errors)
    if (e) std::rethrow_exception(e);
  how.progress.check();  // a cancelled sweep has no response
  return std::move(st->entries);
}

json run_cbf_sweep(const json& request, const Progress& progress) {
  const CbfSweep sweep = parse_cbf_sweep(request);
  SweepExecution how;  // no post: the calling thread and one per further core (parallel_for)
  how.progress = progress;
  how.helpers = std::max(1u, std::thread::hardware_concurrency()) - 1;
  const std::vector<json> entries = execute_sweep(sweep, how);
  const CbfRequest& first = sweep.runs.front();
  return {{"scenario", first.scenario.name},
          {"metric", cbf::to_string(first.metric)},
          {"parameter", sweep.parameter},
          {"values", sweep.values},
          {"entries", entries}};
}

}  // namespace distlab::server
