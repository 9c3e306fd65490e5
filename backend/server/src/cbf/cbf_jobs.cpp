// The CBF jobs: a rollout (its fields prepared, its steps kept and streamed to the session's
// sockets in batches) and a parameter sweep (its runs in parallel on the compute pool).
#include <algorithm>
#include <chrono>
#include <mutex>

#include "cbf_module.hpp"
#include "distlab/server/service.hpp"

namespace distlab::server {

using json = nlohmann::json;

namespace {

// The job's first part: the rollout runs, its scenario's fields prepared (or shared).
cbf::Scenario start(CbfRollout& r, Job& job, const std::function<cbf::Scenario(Job&)>& prepare) {
  r.id_known.wait();
  {
    std::lock_guard lock(r.mutex);
    r.state = Lifecycle::running;
  }
  try {
    return prepare(job);
  } catch (...) {
    std::lock_guard lock(r.mutex);
    r.state = job.cancelled() ? Lifecycle::cancelled : Lifecycle::failed;
    throw;
  }
}

// The record, kept when the rollout ends: all its steps, or a cancelled one's so far.
void end(CbfRollout& r, Lifecycle state, cbf::RolloutRecord&& rec) {
  std::lock_guard lock(r.mutex);
  r.state = state;
  r.steps.clear();
  r.steps.shrink_to_fit();
  r.record = std::make_shared<const cbf::RolloutRecord>(std::move(rec));
}

// The job's work: prepares the scenario (its fields), runs the rollout, keeps every step, streams
// batches to the session's sockets.
json run_rollout(const std::shared_ptr<CbfRollout>& r, cbf::RolloutOptions options, const std::weak_ptr<Session>& weak, Job& job,
                 const std::function<cbf::Scenario(Job&)>& prepare) {
  using Clock = std::chrono::steady_clock;
  const cbf::Scenario scenario = start(*r, job, prepare);
  std::size_t sent = 0;
  auto last = Clock::now();
  auto flush = [&](std::size_t done) {
    auto s = weak.lock();
    bool listening = false;
    if (s) {
      std::lock_guard lock(s->mutex);
      listening = !s->sockets.empty();
    }
    while (sent < done) {
      const std::size_t n = std::min<std::size_t>(static_cast<std::size_t>(r->stream.batch_steps), done - sent);
      if (listening) s->broadcast(cbf_frames_json(*r, sent, n).dump(), false);
      sent += n;
    }
    last = Clock::now();
  };
  options.progress = Progress{[&job](const std::string& stage, double f) { job.report(stage, f); }, &job.cancel};
  options.on_step = [&](int, const cbf::StepRecord& step) {
    std::size_t done;
    {
      std::lock_guard lock(r->mutex);
      r->steps.push_back(step);
      done = r->steps.size();
    }
    if (done - sent >= static_cast<std::size_t>(r->stream.batch_steps) ||
        std::chrono::duration<double>(Clock::now() - last).count() >= r->stream.batch_seconds)
      flush(done);
  };
  cbf::RolloutRecord rec;
  try {
    cbf::rollout(scenario, r->metric, options, rec);
  } catch (const Cancelled&) {
    // The steps so far are the job's result too: the job manager sees the cancel flag and ends
    // the job cancelled, keeping it (as a rollout that returned cancelled did).
    flush(r->steps_done());
    json partial = rollout_job_result(*r, rec);
    end(*r, Lifecycle::cancelled, std::move(rec));
    return partial;
  } catch (...) {
    std::lock_guard lock(r->mutex);
    r->state = Lifecycle::failed;
    throw;
  }
  flush(r->steps_done());
  json result = rollout_job_result(*r, rec);
  end(*r, Lifecycle::succeeded, std::move(rec));
  return result;
}

// The sweep's job: its runs in parallel on the compute pool, one run per posted task so that
// requests queued meanwhile are not held up behind the whole sweep; the job's thread runs runs
// too. Entries are kept in the sweep's order as runs finish; the job's cancel flag stops them all.
json run_sweep(const std::shared_ptr<CbfSweepRun>& s, Job& job, const std::function<bool(std::function<void()>)>& post,
               unsigned threads) {
  SweepExecution how;
  how.progress = Progress{[&job](const std::string& stage, double fraction) { job.report(stage, fraction); }, &job.cancel};
  how.finished = [&s](std::size_t, const json& entry) {
    std::lock_guard lock(s->mutex);
    auto at = std::upper_bound(s->entries.begin(), s->entries.end(), entry["index"],
                               [](const json& index, const json& e) { return index < e["index"]; });
    s->entries.insert(at, entry);
  };
  how.post = post;
  how.helpers = threads > 1 ? threads - 1 : 0;
  how.one_run_per_task = true;
  execute_sweep(*s->sweep, how);
  return sweep_job_result(*s);
}

}  // namespace

CbfRolloutStatus CbfModule::start_rollout(const CbfRolloutRequest& in, const Caller& caller) {
  auto session = require_session(caller);
  const std::shared_ptr<CbfRollout>& r = in.rollout;
  r->session = session->id;
  // The job's first part: the fields, prepared (or shared) with the job's progress.
  auto prepare = [this, r, plan = in.plan](Job& j) {
    cbf::Scenario s = r->scenario;
    if (plan->fields.empty()) return s;
    {
      std::lock_guard lock(r->mutex);
      r->fields_state = Lifecycle::running;
    }
    std::map<std::string, cbf::SceneField> prepared;
    try {
      prepare_fields(s, *plan, Progress{[&j](const std::string& stage, double f) { j.report(stage, f); }, &j.cancel}, prepared);
    } catch (...) {
      std::lock_guard lock(r->mutex);
      r->fields_state = Lifecycle::failed;
      throw;
    }
    {
      std::lock_guard lock(r->mutex);
      for (std::size_t i = 0; i < r->fields.size(); ++i) r->fields[i].field = s.fields[i].field;
      r->fields_state = Lifecycle::succeeded;
    }
    cbf_rollouts_->fields_ready(r);
    return s;
  };
  std::weak_ptr<Session> weak = session;
  // Cancelled while queued: the rollout never starts and ends cancelled, its fields unprepared.
  auto skipped = [r] {
    std::lock_guard lock(r->mutex);
    r->state = Lifecycle::cancelled;
    if (!r->fields.empty()) r->fields_state = Lifecycle::failed;
  };
  auto job = jobs_.submit(
      session->id, "cbf_rollout", rollout_job_params(*r),
      [r, options = in.options, weak, prepare](Job& j) { return run_rollout(r, options, weak, j, prepare); }, skipped);
  r->id = job->id;
  r->id_set.set_value();
  cbf_rollouts_->add(r, [this](const std::string& s) { return sessions_.find(s) != nullptr; });
  return {r, job};
}

// Every run checked before the job starts (decode_sweep); the runs' fields prepared once for all
// of them at its start.
CbfSweepStatus CbfModule::start_sweep(const CbfSweepRequest& in, const Caller& caller) {
  auto session = require_session(caller);
  auto s = std::make_shared<CbfSweepRun>();
  s->session = session->id;
  const std::shared_ptr<CbfSweep>& sweep = in.sweep;
  s->sweep = sweep;
  auto job = jobs_.submit(session->id, "cbf_sweep", sweep_job_params(*sweep), [this, s, sweep, plans = in.plans](Job& j) {
    std::map<std::string, cbf::SceneField> prepared;
    const Progress progress{[&j](const std::string& stage, double f) { j.report(stage, f); }, &j.cancel};
    for (std::size_t i = 0; i < sweep->runs.size(); ++i) prepare_fields(sweep->runs[i].scenario, (*plans)[i], progress, prepared);
    return run_sweep(
        s, j, [this](std::function<void()> task) { return post_compute(std::move(task)); }, compute_.size());
  });
  s->id = job->id;
  sweeps_->add(s);
  return {s, job};
}

CbfSweepStatus CbfModule::sweep(const CbfRolloutId& in, const Caller& caller) {
  auto session = require_session(caller);
  auto s = sweeps_->find(session->id, in.id);
  if (!s) throw ApiError(404, "unknown_sweep", "no such sweep in this session");
  return {s, jobs_.find(session->id, s->id)};
}

void CbfSweepStore::add(std::shared_ptr<CbfSweepRun> s) {
  std::lock_guard lock(mutex_);
  sweeps_.push_back(std::move(s));
  if (sweeps_.size() > kept_) sweeps_.erase(sweeps_.begin());
}

std::shared_ptr<CbfSweepRun> CbfSweepStore::find(const std::string& session, const std::string& id) const {
  std::lock_guard lock(mutex_);
  for (const auto& s : sweeps_)
    if (s->id == id && s->session == session) return s;
  return nullptr;
}

}  // namespace distlab::server
