// CBF endpoints: scenarios, the robot description, rollouts as jobs whose steps stream over the
// WebSocket ("cbf_frames"), their status, frames and full record (same JSON as `distlab cbf`), and
// the Kelvin fields of their scenarios. A request is checked in full on the request thread (its
// fields planned: read and checked against the budget, cbf_fields.hpp); the fields are prepared
// in the job, whose progress shows Kelvin's stages before "rollout".
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <mutex>
#include <optional>

#include "cbf_module.hpp"
#include "distlab/geometry/error.hpp"
#include "distlab/server/cbf_json.hpp"
#include "distlab/server/cbf_rollouts.hpp"
#include "distlab/server/frames.hpp"
#include "distlab/server/json_fields.hpp"
#include "distlab/server/request_params.hpp"
#include "distlab/server/service.hpp"

namespace distlab::server {

using json = nlohmann::json;
namespace fs = std::filesystem;

namespace {

// "levels=A,B,...": finite numbers, at most max (413 too_many_levels).
std::vector<double> parse_levels(const std::string& text, std::size_t max) {
  std::vector<double> out;
  for (std::size_t b = 0; b <= text.size();) {
    const std::size_t e = std::min(text.find(',', b), text.size());
    const std::string item = text.substr(b, e - b);
    char* end = nullptr;
    const double v = std::strtod(item.c_str(), &end);
    if (item.empty() || end != item.c_str() + item.size() || !std::isfinite(v))
      throw InvalidInput("levels", "levels must be finite numbers separated by commas");
    out.push_back(v);
    if (out.size() > max) throw ApiError(413, "too_many_levels", "at most " + std::to_string(max) + " levels (max_levels)", "levels");
    b = e + 1;
  }
  return out;
}

CbfStreamOptions parse_stream(const json& j, const CbfLimits& limits) {
  CbfStreamOptions s;
  json_require_object(j, "stream");
  json_check_keys(j, "stream", {"batch_steps", "pairs", "poses"});
  if (auto it = j.find("batch_steps"); it != j.end()) {
    const double n = json_number(*it, "stream.batch_steps");
    if (n != std::floor(n) || n < 1 || n > limits.max_batch_steps)
      throw InvalidInput("stream.batch_steps",
                         "stream.batch_steps must be a whole number from 1 to " + std::to_string(limits.max_batch_steps));
    s.batch_steps = static_cast<int>(n);
  }
  if (auto it = j.find("pairs"); it != j.end()) s.pairs = json_bool(*it, "stream.pairs");
  if (auto it = j.find("poses"); it != j.end()) s.poses = json_bool(*it, "stream.poses");
  return s;
}

// Where duration came from, for the error's field.
std::string duration_field(const json& body) {
  const json* p = body.contains("params") ? &body["params"] : nullptr;
  if (p && p->is_object() && (p->contains("duration") || p->contains("dt"))) return "params.duration";
  return "scenario.duration";
}

// A job cancelled while queued ends without running its work: its rollout, still "queued", ended
// with it (and so did the preparation of its fields).
void settle(CbfRollout& r, const Job& job) {
  const JobState s = job.state();
  if (s == JobState::queued || s == JobState::running) return;
  std::lock_guard lock(r.mutex);
  if (r.state != "queued") return;
  r.state = s == JobState::cancelled ? "cancelled" : "failed";
  if (!r.fields.empty() && r.fields_state == "preparing") r.fields_state = "failed";
}

// The job's work: prepares the scenario (its fields), runs the rollout, keeps every step, streams
// batches to the session's sockets.
json run_rollout(const std::shared_ptr<CbfRollout>& r, cbf::RolloutOptions options, const std::weak_ptr<Session>& weak, Job& job,
                 const std::function<cbf::Scenario(Job&)>& prepare) {
  using Clock = std::chrono::steady_clock;
  r->id_known.wait();
  {
    std::lock_guard lock(r->mutex);
    r->state = "running";
  }
  cbf::Scenario scenario;
  try {
    scenario = prepare(job);
  } catch (...) {
    std::lock_guard lock(r->mutex);
    r->state = job.cancelled() ? "cancelled" : "failed";
    throw;
  }
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
  options.cancel = &job.cancel;
  options.progress = [&](int i, const cbf::StepRecord& step) {
    std::size_t done;
    {
      std::lock_guard lock(r->mutex);
      r->steps.push_back(step);
      done = r->steps.size();
    }
    job.report("rollout", (i + 1.0) / r->steps_total);
    if (done - sent >= static_cast<std::size_t>(r->stream.batch_steps) ||
        std::chrono::duration<double>(Clock::now() - last).count() >= r->stream.batch_seconds)
      flush(done);
    return !job.cancelled();
  };
  cbf::RolloutRecord rec;
  try {
    rec = cbf::rollout(scenario, r->metric, options);
  } catch (...) {
    std::lock_guard lock(r->mutex);
    r->state = "failed";
    throw;
  }
  flush(r->steps_done());
  const json summary = {{"reached", rec.reached}, {"final_task_error", rec.final_task_error}, {"infeasible_steps", rec.infeasible_steps.size()}, {"steps", rec.steps.size()}};
  {
    std::lock_guard lock(r->mutex);
    r->state = rec.cancelled ? "cancelled" : "finished";
    r->steps.clear();
    r->steps.shrink_to_fit();
    r->record = std::make_shared<const cbf::RolloutRecord>(std::move(rec));
  }
  return {{"rollout", r->id}, {"summary", summary}};
}

// A parameter sweep (one job): the runs' entries as they finish, so a cancelled sweep still shows
// the runs it completed. Owner only, like rollouts; the oldest are forgotten past kept_total.
struct CbfSweepRun {
  std::string id, session;
  json head;  // scenario, metric, parameter, values
  std::mutex mutex;
  json entries = json::array();
};

class CbfSweepStore {
 public:
  explicit CbfSweepStore(std::size_t kept) : kept_(kept) {}
  void add(std::shared_ptr<CbfSweepRun> s) {
    std::lock_guard lock(mutex_);
    sweeps_.push_back(std::move(s));
    if (sweeps_.size() > kept_) sweeps_.erase(sweeps_.begin());
  }
  std::shared_ptr<CbfSweepRun> find(const std::string& session, const std::string& id) const {
    std::lock_guard lock(mutex_);
    for (const auto& s : sweeps_)
      if (s->id == id && s->session == session) return s;
    return nullptr;
  }

 private:
  std::size_t kept_;
  mutable std::mutex mutex_;
  std::vector<std::shared_ptr<CbfSweepRun>> sweeps_;
};

// The sweep's job: its runs in parallel on the compute pool, one run per posted task so that
// requests queued meanwhile are not held up behind the whole sweep; the job's thread runs runs
// too. Entries are kept in the sweep's order as runs finish; the job's cancel flag stops them all.
json run_sweep(const std::shared_ptr<CbfSweepRun>& s, const CbfSweep& sweep, Job& job,
               const std::function<bool(std::function<void()>)>& post, unsigned threads) {
  SweepExecution how;
  how.cancel = &job.cancel;
  how.progress = [&job](const std::string& stage, double fraction) { job.report(stage, fraction); };
  how.finished = [&s](std::size_t, const json& entry) {
    std::lock_guard lock(s->mutex);
    auto at = std::upper_bound(s->entries.begin(), s->entries.end(), entry["index"],
                               [](const json& index, const json& e) { return index < e["index"]; });
    s->entries.insert(at, entry);
  };
  how.post = post;
  how.helpers = threads > 1 ? threads - 1 : 0;
  how.one_run_per_task = true;
  execute_sweep(sweep, how);
  json out = s->head;
  std::lock_guard lock(s->mutex);
  out["entries"] = s->entries;
  return out;
}

}  // namespace

void CbfModule::register_routes() {
  cbf_rollouts_ = std::make_shared<CbfRolloutStore>(CbfLimits{});
  const CbfLimits limits = cbf_rollouts_->limits();
  const std::string scenarios_dir = (fs::path(config_.assets_dir) / "scenarios").string();

  router_.add({"GET", "/api/cbf/scenarios", [scenarios_dir, limits](Request&) {
                 std::vector<std::string> names;
                 std::error_code ec;
                 for (const auto& e : fs::directory_iterator(scenarios_dir, ec))
                   if (e.path().extension() == ".json" && valid_name(e.path().stem().string()))
                     names.push_back(e.path().stem().string());
                 std::sort(names.begin(), names.end());
                 return json_response(200, {{"scenarios", names},
                                            {"metrics", {"gap", "euclidean"}},
                                            {"limits",
                                             {{"max_steps", limits.max_steps},
                                              {"max_duration", kMaxScenarioDuration},
                                              {"max_pair_steps", limits.max_pair_steps},
                                              {"max_batch_steps", limits.max_batch_steps},
                                              {"max_frames_per_request", limits.max_frames_per_request},
                                              {"kept_per_session", limits.kept_per_session},
                                              {"max_sweep_values", limits.max_sweep_values}}}});
               }});
  router_.add({"GET", "/api/cbf/scenarios/{name}", [scenarios_dir](Request& req) {
                 const std::string name = req.params["name"];
                 if (!valid_name(name))
                   throw InvalidInput("name", "scenario names are 1 to 64 letters, digits, '_' and '-'");
                 const fs::path path = fs::path(scenarios_dir) / (name + ".json");
                 std::error_code ec;
                 if (!fs::is_regular_file(path, ec))
                   throw ApiError(404, "unknown_scenario", "no scenario named \"" + name + "\"", "name");
                 return json_response(200, read_scenario_file(path.string()));
               }});
  // ?name=NAME (default panda): assets/robots/NAME.urdf as the view draws it.
  router_.add({"GET", "/api/cbf/robot", [this](Request& req) {
                 auto it = req.query.find("name");
                 const std::string name = it == req.query.end() ? "panda" : it->second;
                 return json_response(200, cbf_robot_json(*load_robot(name, config_.assets_dir, "name")));
               }});
  // Is the scenario's exact target inside the safe set? (cbf::target_feasibility, well under a
  // second: a q7 grid with IK per point.)
  Route feasibility{"POST", "/api/cbf/feasibility", [this, limits](Request& req) {
                      const json body = parse_body(req);
                      refuse_mesh_paths(body);
                      FieldPlan plan;
                      CbfRequest parsed = plan_cbf_request(body, config_.assets_dir, plan);
                      for (const PlannedField& p : plan.fields) check_field_budget(p, config_.limits);
                      // About 4000 IK configurations are examined, each against every pair.
                      const cbf::Robot& robot = *parsed.scenario.robot;
                      const std::size_t pairs = robot.primitives().size() * parsed.scenario.obstacles.size() +
                                                (parsed.scenario.self_collision ? robot.self_pairs().size() : 0);
                      if (pairs * 4000 > limits.max_pair_steps)
                        throw ApiError(422, "too_large",
                                       std::to_string(pairs) + " pairs: the feasibility scan allows at most " +
                                           std::to_string(limits.max_pair_steps / 4000) + " on this server",
                                       "scenario.obstacles");
                      // The fields are prepared here, synchronously: usually held by the rollout
                      // just run, else from the cache directory (seconds; the first time longer).
                      std::map<std::string, cbf::SceneField> prepared;
                      prepare_fields(parsed.scenario, plan, {}, prepared);
                      return json_response(200, encode_feasibility(cbf::target_feasibility(parsed.scenario),
                                                                   parsed.scenario));
                    }};
  feasibility.heavy = true;
  feasibility.bounds = {"max_body_bytes", "max_cbf_pair_steps", "min_lx", "max_vertex_estimate"};
  router_.add(std::move(feasibility));

  Route post{"POST", "/api/cbf/rollouts", [this, limits](Request& req) {
               auto session = require_session(req);
               json body = parse_body(req);
               json_require_object(body, "");
               CbfStreamOptions stream;
               if (auto it = body.find("stream"); it != body.end()) {
                 stream = parse_stream(*it, limits);
                 body.erase("stream");
               }
               refuse_mesh_paths(body);
               auto plan = std::make_shared<FieldPlan>();
               const CbfRequest parsed = plan_cbf_request(body, config_.assets_dir, *plan);
               for (const PlannedField& p : plan->fields) check_field_budget(p, config_.limits);
               const cbf::Scenario& sc = parsed.scenario;
               const int steps = sc.steps();
               if (steps > limits.max_steps)
                 throw ApiError(422, "too_long",
                                "duration / dt = " + std::to_string(steps) + " steps; at most " +
                                    std::to_string(limits.max_steps) + " per rollout on this server",
                                duration_field(body));
               const cbf::Robot& robot = *sc.robot;
               const std::size_t pairs = robot.primitives().size() * sc.obstacles.size() +
                                         (sc.self_collision ? robot.self_pairs().size() : 0);
               if (pairs * static_cast<std::size_t>(steps) > limits.max_pair_steps)
                 throw ApiError(422, "too_long",
                                std::to_string(pairs) + " pairs × " + std::to_string(steps) + " steps is over this server's " +
                                    std::to_string(limits.max_pair_steps) + " pair-steps per rollout; shorten it or use fewer obstacles",
                                duration_field(body));

               auto r = std::make_shared<CbfRollout>();
               r->session = session->id;
               const json& sj = body["scenario"];
               r->scenario_json = sj.is_string() ? read_scenario_file(scenario_path(sj.get<std::string>(), config_.assets_dir)) : sj;
               r->scenario_name = sc.name;
               r->scenario = sc;
               r->metric = parsed.metric;
               r->record_pairs = parsed.options.record_pairs;
               r->stream = stream;
               r->steps_total = steps;
               cbf::RolloutOptions options = parsed.options;
               options.record_pairs = options.record_pairs || stream.pairs;
               // The pair list without building the controller's GAP bodies.
               robot::PairSelection selection;
               selection.self = sc.self_collision;
               r->pairs = robot::select_pairs(robot, sc.obstacles, selection);
               r->control_points = plan->control_points;
               r->fields = rollout_fields(*plan);

               // The job's first part: the fields, prepared (or shared) with the job's progress.
               auto prepare = [this, r, plan](Job& j) {
                 cbf::Scenario s = r->scenario;
                 if (plan->fields.empty()) return s;
                 std::map<std::string, cbf::SceneField> prepared;
                 try {
                   prepare_fields(s, *plan, Progress{[&j](const std::string& stage, double f) { j.report(stage, f); }, &j.cancel}, prepared);
                 } catch (...) {
                   std::lock_guard lock(r->mutex);
                   r->fields_state = "failed";
                   throw;
                 }
                 {
                   std::lock_guard lock(r->mutex);
                   for (std::size_t i = 0; i < r->fields.size(); ++i) r->fields[i].field = s.fields[i].field;
                   r->fields_state = "ready";
                 }
                 cbf_rollouts_->fields_ready(r);
                 return s;
               };
               std::weak_ptr<Session> weak = session;
               auto job = jobs_.submit(session->id, "cbf_rollout", {{"scenario", sc.name}, {"metric", cbf::to_string(parsed.metric)}},
                                       [r, options, weak, prepare](Job& j) mutable { return run_rollout(r, options, weak, j, prepare); });
               r->id = job->id;
               r->id_set.set_value();
               cbf_rollouts_->add(r, [this](const std::string& s) { return sessions_.find(s) != nullptr; });
               json status = r->status_json();
               return json_response(202, {{"rollout", status}, {"job", job->to_json()}});
             }};
  post.heavy = true;  // reads a scenario file, builds the request
  // The rollout is a job of the session (job limits); its length and memory are bounded by steps
  // and pair-steps; finished rollouts past the kept counts are forgotten, oldest first.
  post.bounds = {"max_body_bytes", "max_cbf_steps", "max_cbf_duration", "max_cbf_pair_steps", "max_cbf_batch_steps",
                 "max_jobs_per_session", "max_jobs_total", "max_job_seconds", "cbf_rollouts_kept_per_session",
                 "cbf_rollouts_kept_total", "min_lx", "max_vertex_estimate", "cbf_fields_kept_total"};
  router_.add(std::move(post));

  // POST /api/cbf/sweeps: a rollout request with "sweep": {"parameter", "values"} (cbf_json.hpp),
  // every run checked before the job starts; GET .../{id}: the entries so far and the job.
  auto sweeps = std::make_shared<CbfSweepStore>(limits.kept_total);
  Route sweep_post{"POST", "/api/cbf/sweeps", [this, limits, sweeps](Request& req) {
                     auto session = require_session(req);
                     const json body = parse_body(req);
                     refuse_mesh_paths(body);
                     auto plans = std::make_shared<std::vector<FieldPlan>>();
                     auto sweep = std::make_shared<CbfSweep>(plan_cbf_sweep(body, config_.assets_dir, limits.max_sweep_values, *plans));
                     for (const FieldPlan& plan : *plans)
                       for (const PlannedField& p : plan.fields) check_field_budget(p, config_.limits);
                     for (std::size_t i = 0; i < sweep->runs.size(); ++i) {
                       const cbf::Scenario& sc = sweep->runs[i].scenario;
                       const std::size_t steps = static_cast<std::size_t>(sc.steps());
                       const std::size_t pairs = sc.robot->primitives().size() * sc.obstacles.size() +
                                                 (sc.self_collision ? sc.robot->self_pairs().size() : 0);
                       if (steps > static_cast<std::size_t>(limits.max_steps) || pairs * steps > limits.max_pair_steps)
                         throw ApiError(422, "too_long",
                                        "run " + std::to_string(i) + ": " + std::to_string(steps) + " steps × " +
                                            std::to_string(pairs) + " pairs is over this server's " +
                                            std::to_string(limits.max_steps) + " steps or " +
                                            std::to_string(limits.max_pair_steps) + " pair-steps per rollout",
                                        "sweep.values[" + std::to_string(i) + "]");
                     }
                     auto s = std::make_shared<CbfSweepRun>();
                     s->session = session->id;
                     s->head = {{"scenario", sweep->runs.front().scenario.name},
                                {"metric", cbf::to_string(sweep->runs.front().metric)},
                                {"parameter", sweep->parameter},
                                {"values", sweep->values}};
                     auto job = jobs_.submit(session->id, "cbf_sweep", {{"parameter", sweep->parameter}},
                                             [this, s, sweep, plans](Job& j) {
                                               // The runs' fields, prepared once for all of them.
                                               std::map<std::string, cbf::SceneField> prepared;
                                               const Progress progress{[&j](const std::string& stage, double f) { j.report(stage, f); }, &j.cancel};
                                               for (std::size_t i = 0; i < sweep->runs.size(); ++i)
                                                 prepare_fields(sweep->runs[i].scenario, (*plans)[i], progress, prepared);
                                               return run_sweep(
                                                   s, *sweep, j, [this](std::function<void()> task) { return post_compute(std::move(task)); },
                                                   compute_.size());
                                             });
                     s->id = job->id;
                     sweeps->add(s);
                     json status = s->head;
                     status["id"] = job->id;
                     status["entries"] = json::array();
                     return json_response(202, {{"sweep", status}, {"job", job->to_json()}});
                   }};
  sweep_post.heavy = true;  // parses every run's request
  sweep_post.bounds = {"max_body_bytes", "max_cbf_sweep_values", "max_cbf_steps", "max_cbf_pair_steps", "max_jobs_per_session",
                       "max_jobs_total", "max_job_seconds", "min_lx", "max_vertex_estimate"};
  router_.add(std::move(sweep_post));
  router_.add({"GET", "/api/cbf/sweeps/{id}", [this, sweeps](Request& req) {
                 auto session = require_session(req);
                 auto s = sweeps->find(session->id, req.params.at("id"));
                 if (!s) throw ApiError(404, "unknown_sweep", "no such sweep in this session");
                 json out = s->head;
                 out["id"] = s->id;
                 {
                   std::lock_guard lock(s->mutex);
                   out["entries"] = s->entries;
                 }
                 if (auto j = jobs_.find(session->id, s->id)) {
                   out["job"] = j->to_json();
                   out["job"].erase("result");  // the entries are above
                 }
                 return json_response(200, out);
               }});

  auto require_rollout = [this](const Request& req) {
    auto session = require_session(req);
    auto r = cbf_rollouts_->find(session->id, req.params.at("id"));
    if (!r) throw ApiError(404, "unknown_rollout", "no such rollout in this session");
    if (auto j = jobs_.find(session->id, r->id)) settle(*r, *j);
    return std::make_pair(session, r);
  };

  router_.add({"GET", "/api/cbf/rollouts", [this](Request& req) {
                 auto session = require_session(req);
                 json list = json::array();
                 for (const auto& r : cbf_rollouts_->list(session->id)) {
                   if (auto j = jobs_.find(session->id, r->id)) settle(*r, *j);
                   list.push_back(r->status_json());
                 }
                 return json_response(200, {{"rollouts", list}});
               }});
  router_.add({"GET", "/api/cbf/rollouts/{id}", [this, require_rollout](Request& req) {
                 auto [session, r] = require_rollout(req);
                 json status = r->status_json();
                 if (auto j = jobs_.find(session->id, r->id)) status["job"] = j->to_json();
                 return json_response(200, status);
               }});
  Route frames{"GET", "/api/cbf/rollouts/{id}/frames", [require_rollout, limits](Request& req) {
                 auto [session, r] = require_rollout(req);
                 const std::size_t from = query_index(req, "from", 0);
                 const std::size_t count = query_index(req, "count", limits.max_frames_per_request);
                 if (count > limits.max_frames_per_request)
                   throw ApiError(413, "too_many_frames",
                                  "at most " + std::to_string(limits.max_frames_per_request) + " frames per request", "count");
                 return json_response(200, cbf_frames_json(*r, from, count));
               }};
  frames.heavy = true;
  frames.bounds = {"max_cbf_frames_per_request", "max_cbf_pair_steps"};
  router_.add(std::move(frames));
  Route record{"GET", "/api/cbf/rollouts/{id}/record", [require_rollout](Request& req) {
                 auto [session, r] = require_rollout(req);
                 std::shared_ptr<const cbf::RolloutRecord> rec;
                 std::string state;
                 {
                   std::lock_guard lock(r->mutex);
                   rec = r->record;
                   state = r->state;
                 }
                 if (!rec)
                   throw ApiError(409, "not_finished", "the rollout is " + state +
                                                           "; its record is ready when it ends "
                                                           "(its frames so far: GET .../frames)");
                 return json_response(200, encode_record(*rec, r->scenario_name, r->record_pairs));
               }};
  record.heavy = true;
  record.bounds = {"max_cbf_steps", "max_cbf_pair_steps"};
  router_.add(std::move(record));
  // The objects of a rollout's Kelvin fields and their iso-surfaces (cbf_field_service.hpp), once:
  // the frames carry what changes per step.
  Route fields{"GET", "/api/cbf/rollouts/{id}/fields", [this, require_rollout](Request& req) {
                 auto [session, r] = require_rollout(req);
                 std::optional<std::vector<double>> levels;
                 single_query(req, "levels");
                 if (auto it = req.query.find("levels"); it != req.query.end()) levels = parse_levels(it->second, config_.limits.max_levels);
                 Response out;
                 out.content_type = "application/msgpack";
                 out.body = to_msgpack(fields_frame(*r, levels));
                 return out;
               }};
  fields.heavy = true;
  fields.bounds = {"max_vertex_estimate", "max_levels", "cbf_fields_kept_total"};
  router_.add(std::move(fields));
}

void CbfModule::prepare_fields(cbf::Scenario& scenario, const FieldPlan& plan, const Progress& progress,
                               std::map<std::string, cbf::SceneField>& prepared) {
  if (plan.fields.empty()) return;
  prepared.merge(shared_fields_.held(plan));
  prepare_planned_fields(scenario, plan, service_preparer(core_.cache_dir(), config_.limits, progress, shared_fields_), progress, &prepared);
  shared_fields_.remember(prepared);
}

// WebSocket {"type": "cbf_replay", "rollout", "from"?}: the frames computed so far, to this socket
// only (a late joiner; live batches keep coming to every socket of the session).
void CbfModule::cbf_ws_message(const std::shared_ptr<Session>& session, const std::shared_ptr<WsSink>& socket,
                               const json& msg) {
  const std::string type = msg["type"].get<std::string>();
  if (type != "cbf_replay") throw InvalidInput("type", "unknown message type \"" + type.substr(0, 32) + "\"");
  json_check_keys(msg, "", {"type", "request", "rollout", "from"});
  if (!msg.contains("rollout") || !msg["rollout"].is_string())
    throw InvalidInput("rollout", "rollout must be a rollout id");
  std::size_t from = 0;
  if (msg.contains("from")) {
    const double f = json_number(msg["from"], "from");
    if (f < 0 || f != std::floor(f) || f > 1e9) throw InvalidInput("from", "from must be a step index");
    from = static_cast<std::size_t>(f);
  }
  auto r = cbf_rollouts_->find(session->id, msg["rollout"].get<std::string>());
  if (!r) throw ApiError(404, "unknown_rollout", "no such rollout in this session", "rollout");
  const std::size_t batch = static_cast<std::size_t>(cbf_rollouts_->limits().max_batch_steps);
  std::weak_ptr<WsSink> weak = socket;
  if (!post_compute([r, weak, from, batch] {
        const std::size_t done = r->steps_done();
        std::size_t i = from;
        do {  // at least one message, so the client learns steps_done even when nothing is new
          auto s = weak.lock();
          if (!s) return;
          s->send(cbf_frames_json(*r, i, batch).dump(), false);
          i += batch;
        } while (i < done);
      }))
    throw ApiError(503, "busy", "the server is busy; try again");
}

}  // namespace distlab::server
