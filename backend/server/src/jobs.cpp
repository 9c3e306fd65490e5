#include "distlab/server/jobs.hpp"

#include <cstdio>

#include <cmath>

#include "distlab/geometry/error.hpp"
#include "distlab/geometry/progress.hpp"
#include "distlab/server/http.hpp"

namespace distlab::server {

using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

Job::Job(std::string id_, std::string session_, std::string kind_, json meta_)
    : id(std::move(id_)), session(std::move(session_)), kind(std::move(kind_)), meta(std::move(meta_)), created_(Clock::now()) {}

JobState Job::state() const {
  std::lock_guard lock(mutex_);
  return state_;
}

void Job::report(const std::string& stage, double fraction) {
  if (!std::isfinite(fraction)) fraction = 0;
  fraction = std::min(1.0, std::max(0.0, fraction));
  bool emit = false;
  {
    std::lock_guard lock(mutex_);
    const auto now = Clock::now();
    emit = stage != stage_ || fraction >= 1.0 || fraction - fraction_ >= 0.05 ||
           now - last_event_ > std::chrono::milliseconds(200);
    stage_ = stage;
    fraction_ = fraction;
    if (emit) last_event_ = now;
  }
  if (emit && on_progress_) on_progress_(*this);
}

JobStatus Job::status() const {
  std::lock_guard lock(mutex_);
  JobStatus s{id, kind, state_, stage_, fraction_, meta, std::nullopt, result_, error_};
  const auto end = (state_ == JobState::queued || state_ == JobState::running) ? Clock::now() : finished_;
  if (state_ != JobState::queued) s.seconds = std::chrono::duration<double>(end - started_).count();
  return s;
}

json job_json(const JobStatus& s) {
  json j = {{"id", s.id}, {"kind", s.kind}, {"state", to_string(s.state)}, {"stage", s.stage}, {"fraction", s.fraction}};
  for (const auto& [k, v] : s.meta.items()) j[k] = v;
  if (s.seconds) j["seconds"] = *s.seconds;
  if (!s.result.is_null()) j["result"] = s.result;
  if (!s.error.is_null()) j["error"] = s.error;
  return j;
}

JobManager::JobManager(const Options& options, JobEventSink sink)
    : options_(options), sink_(std::move(sink)), pool_(options.threads) {
  watchdog_ = std::thread([this] { watchdog(); });
}

JobManager::~JobManager() { shutdown(); }

void JobManager::emit(const Job& job) {
  if (sink_) sink_(job.session, {{"type", "job"}, {"job", job.to_json()}});
}

std::shared_ptr<Job> JobManager::submit(const std::string& session, const std::string& kind, json meta,
                                        std::function<json(Job&)> work, std::function<void()> skipped) {
  std::shared_ptr<Job> job;
  {
    std::lock_guard lock(mutex_);
    if (stopping_) throw ApiError(503, "shutting_down", "the server is shutting down");
    if (active_per_session_[session] >= options_.per_session)
      throw ApiError(429, "too_many_jobs",
                     "this session already has " + std::to_string(options_.per_session) +
                         " jobs queued or running; wait for one or cancel it");
    if (active_ >= options_.total)
      throw ApiError(429, "too_many_jobs", "the server is at its job limit; try again shortly");
    std::string id;
    do id = random_id();
    while (jobs_.count(id));
    job = std::make_shared<Job>(id, session, kind, std::move(meta));
    job->on_progress_ = [this](const Job& j) { emit(j); };
    jobs_.emplace(id, job);
    ++active_;
    ++active_per_session_[session];
  }
  emit(*job);
  if (!pool_.post([this, job, work = std::move(work), skipped = std::move(skipped)] { run(job, work, skipped); })) {
    std::lock_guard lock(mutex_);
    jobs_.erase(job->id);
    --active_;
    --active_per_session_[session];
    throw ApiError(503, "shutting_down", "the server is shutting down");
  }
  return job;
}

void JobManager::run(const std::shared_ptr<Job>& job, const std::function<json(Job&)>& work, const std::function<void()>& skipped) {
  {
    std::lock_guard lock(job->mutex_);
    job->state_ = JobState::running;
    job->started_ = Clock::now();
  }
  emit(*job);
  JobState final_state = JobState::succeeded;
  json result, error;
  try {
    if (job->cancelled()) {
      if (skipped) skipped();
      throw Cancelled();
    }
    result = work(*job);
    if (job->cancelled()) throw Cancelled();
  } catch (const Cancelled&) {  // the one cancellation of every module's work
    final_state = JobState::cancelled;
  } catch (const ApiError&) {  // a refusal of the API fails the job, cancelled or not
    final_state = JobState::failed;
    error = error_answer(std::current_exception()).body();
  } catch (const std::exception&) {
    final_state = job->cancelled() ? JobState::cancelled : JobState::failed;
    const std::string context = "job " + job->kind + " failed";
    error = error_answer(std::current_exception(), "job_failed", "internal error (logged on the server)", context.c_str()).body();
  }
  if (final_state == JobState::cancelled) {
    std::lock_guard lock(job->mutex_);
    error = job->timed_out_ ? json{{"code", "time_limit"}, {"message", "the job exceeded its time limit"}, {"field", ""}}
                            : json{{"code", "cancelled"}, {"message", "the job was cancelled"}, {"field", ""}};
  }
  {
    std::lock_guard lock(job->mutex_);
    job->state_ = final_state;
    job->result_ = std::move(result);
    job->error_ = std::move(error);
    job->finished_ = Clock::now();
  }
  {
    std::lock_guard lock(mutex_);
    --active_;
    --active_per_session_[job->session];
    auto& order = finished_order_[job->session];
    order.push_back(job->id);
    while (order.size() > options_.keep_finished) {
      jobs_.erase(order.front());
      order.erase(order.begin());
    }
  }
  emit(*job);
}

std::shared_ptr<Job> JobManager::find(const std::string& session, const std::string& id) const {
  std::lock_guard lock(mutex_);
  auto it = jobs_.find(id);
  if (it == jobs_.end() || it->second->session != session) return nullptr;
  return it->second;
}

std::vector<std::shared_ptr<Job>> JobManager::list(const std::string& session) const {
  std::lock_guard lock(mutex_);
  std::vector<std::shared_ptr<Job>> out;
  for (const auto& [id, j] : jobs_)
    if (j->session == session) out.push_back(j);
  return out;
}

void JobManager::cancel_session(const std::string& session) {
  std::lock_guard lock(mutex_);
  for (const auto& [id, j] : jobs_)
    if (j->session == session) j->cancel = true;
}

void JobManager::watchdog() {
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    watchdog_cv_.wait_for(lock, std::chrono::milliseconds(250));
    const auto now = Clock::now();
    for (const auto& [id, j] : jobs_) {
      std::lock_guard jl(j->mutex_);
      if (j->state_ == JobState::running &&
          std::chrono::duration<double>(now - j->started_).count() > options_.max_seconds && !j->cancel) {
        j->timed_out_ = true;
        j->cancel = true;
      }
    }
  }
}

void JobManager::shutdown() {
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return;
    stopping_ = true;
    for (const auto& [id, j] : jobs_) j->cancel = true;
  }
  watchdog_cv_.notify_all();
  if (watchdog_.joinable()) watchdog_.join();
  pool_.stop();
}

}  // namespace distlab::server
