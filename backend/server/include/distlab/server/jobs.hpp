#pragma once
// Long work as jobs: a pool sized to the machine, limits per session and in total, progress
// events (throttled) to the owner's WebSocket, cooperative cancellation, a time limit, and the
// result kept for the owning session only.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "distlab/server/lifecycle.hpp"
#include "distlab/server/worker_pool.hpp"

namespace distlab::server {

using JobState = Lifecycle;

// A job at one moment (GET /api/jobs/{id}, the "job" events); job_json writes it.
struct JobStatus {
  std::string id, kind;
  JobState state = JobState::queued;
  std::string stage;
  double fraction = 0;
  nlohmann::json meta;            // the submitter's fields, e.g. {"object": id}
  std::optional<double> seconds;  // since it started (absent while queued), to now or its end
  nlohmann::json result, error;   // null until it ends
};
nlohmann::json job_json(const JobStatus& status);

class Job {
 public:
  Job(std::string id, std::string session, std::string kind, nlohmann::json meta);
  const std::string id, session, kind;
  const nlohmann::json meta;  // e.g. {"object": id}
  std::atomic<bool> cancel{false};

  // Called by the work: throttled progress (stage, fraction in [0, 1]).
  void report(const std::string& stage, double fraction);
  bool cancelled() const { return cancel.load(std::memory_order_relaxed); }

  JobState state() const;
  JobStatus status() const;
  nlohmann::json to_json() const { return job_json(status()); }

 private:
  friend class JobManager;
  mutable std::mutex mutex_;
  JobState state_ = JobState::queued;
  std::string stage_;
  double fraction_ = 0;
  nlohmann::json result_, error_;
  std::chrono::steady_clock::time_point created_, started_, finished_, last_event_;
  bool timed_out_ = false;
  std::function<void(const Job&)> on_progress_;
};

using JobEventSink = std::function<void(const std::string& session, const nlohmann::json& event)>;

class JobManager {
 public:
  struct Options {
    unsigned threads = 0;
    std::size_t per_session = 4, total = 16, keep_finished = 64;
    double max_seconds = 600;
  };
  JobManager(const Options& options, JobEventSink sink);
  ~JobManager();

  // Queues work; throws ApiError 429 too_many_jobs past a limit. The work returns the result
  // JSON or throws (Cancelled, geometry/progress.hpp / a "cancelled" state when
  // job.cancel is set -> cancelled; InvalidInput -> failed with the field; others -> failed).
  // A job cancelled while queued ends cancelled without running its work; `skipped` runs instead,
  // so that what the work would have ended (an object's or a rollout's state) ends with it.
  std::shared_ptr<Job> submit(const std::string& session, const std::string& kind, nlohmann::json meta,
                              std::function<nlohmann::json(Job&)> work, std::function<void()> skipped = {});
  std::shared_ptr<Job> find(const std::string& session, const std::string& id) const;  // owner only
  std::vector<std::shared_ptr<Job>> list(const std::string& session) const;
  void cancel_session(const std::string& session);
  void shutdown();  // cancels everything and joins

 private:
  void emit(const Job& job);
  void run(const std::shared_ptr<Job>& job, const std::function<nlohmann::json(Job&)>& work, const std::function<void()>& skipped);
  void watchdog();

  Options options_;
  JobEventSink sink_;
  mutable std::mutex mutex_;
  std::map<std::string, std::shared_ptr<Job>> jobs_;
  std::map<std::string, std::vector<std::string>> finished_order_;  // per session, oldest first
  std::size_t active_ = 0;
  std::map<std::string, std::size_t> active_per_session_;
  bool stopping_ = false;
  std::condition_variable watchdog_cv_;
  std::thread watchdog_;
  WorkerPool pool_;
};

}  // namespace distlab::server
