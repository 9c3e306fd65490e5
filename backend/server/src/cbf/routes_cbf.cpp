// CBF endpoints, one row each: scenarios, the robot description, target feasibility, rollouts as
// jobs whose steps stream over the WebSocket ("cbf_frames"), their status, frames and full record
// (same JSON as `distlab cbf`), the Kelvin fields of their scenarios, and parameter sweeps. A
// request is checked in full by its decode (cbf_codec.hpp: its fields planned against the budget);
// the fields are prepared in the job, whose progress shows Kelvin's stages before "rollout".
#include <algorithm>
#include <filesystem>
#include <mutex>

#include "cbf_module.hpp"
#include "distlab/server/cbf_json.hpp"
#include "distlab/server/cbf_rollouts.hpp"
#include "distlab/server/frames.hpp"
#include "distlab/server/json_fields.hpp"
#include "distlab/server/request_params.hpp"
#include "distlab/server/service.hpp"

namespace distlab::server {

using json = nlohmann::json;
namespace fs = std::filesystem;

void CbfModule::register_routes() {
  cbf_rollouts_ = std::make_shared<CbfRolloutStore>(config_.limits);
  sweeps_ = std::make_shared<CbfSweepStore>(config_.limits.cbf_rollouts_kept_total);
  using M = CbfModule;
  // A rollout is a job of the session (job limits); its length and memory are bounded by steps
  // and pair-steps; ended rollouts past the kept counts are forgotten, oldest first. Feasibility
  // is well under a second (a q7 grid with IK per point); a sweep's runs are each a rollout's.
  const std::vector<std::string> feasibility_bounds = {"max_body_bytes", "max_cbf_pair_steps", "min_lx", "max_vertex_estimate"};
  const std::vector<std::string> rollout_bounds = {"max_body_bytes", "max_cbf_steps", "max_cbf_duration", "max_cbf_pair_steps",
                                                   "max_cbf_batch_steps", "max_jobs_per_session", "max_jobs_total", "max_job_seconds",
                                                   "cbf_rollouts_kept_per_session", "cbf_rollouts_kept_total", "min_lx",
                                                   "max_vertex_estimate", "cbf_fields_kept_total"};
  const std::vector<std::string> sweep_bounds = {"max_body_bytes", "max_cbf_sweep_values", "max_cbf_steps", "max_cbf_pair_steps", "max_jobs_per_session",
                                                 "max_jobs_total", "max_job_seconds", "min_lx", "max_vertex_estimate"};
  add_routes(router_, *this, config_.limits,
             {{"GET", "/api/cbf/scenarios", Work::light, {}, codec(decode_nothing, &M::scenarios, encode_scenarios)},
              {"GET", "/api/cbf/scenarios/{name}", Work::light, {}, codec(decode_scenario_name, &M::scenario, encode_scenario_file)},
              {"GET", "/api/cbf/robot", Work::light, {}, codec(decode_robot_name, &M::robot, encode_robot)},
              {"POST", "/api/cbf/feasibility", Work::heavy, feasibility_bounds, codec(decode_feasibility, &M::feasibility, encode_feasibility_answer)},
              {"POST", "/api/cbf/rollouts", Work::heavy, rollout_bounds, codec(decode_rollout, &M::start_rollout, encode_rollout_started)},
              {"POST", "/api/cbf/sweeps", Work::heavy, sweep_bounds, codec(decode_sweep, &M::start_sweep, encode_sweep_started)},
              {"GET", "/api/cbf/sweeps/{id}", Work::light, {}, codec(decode_rollout_id, &M::sweep, encode_sweep_status)},
              {"GET", "/api/cbf/rollouts", Work::light, {}, codec(decode_nothing, &M::rollouts, encode_rollouts)},
              {"GET", "/api/cbf/rollouts/{id}", Work::light, {}, codec(decode_rollout_id, &M::rollout, encode_rollout_status)},
              {"GET", "/api/cbf/rollouts/{id}/frames", Work::heavy, {"max_cbf_frames_per_request", "max_cbf_pair_steps"}, codec(decode_frames, &M::frames, encode_frames)},
              {"GET", "/api/cbf/rollouts/{id}/record", Work::heavy, {"max_cbf_steps", "max_cbf_pair_steps"}, codec(decode_rollout_id, &M::record, encode_rollout_record)},
              // The objects of a rollout's Kelvin fields and their iso-surfaces, once: the frames
              // carry what changes per step.
              {"GET", "/api/cbf/rollouts/{id}/fields", Work::heavy, {"max_vertex_estimate", "max_levels", "cbf_fields_kept_total"}, codec(decode_fields, &M::fields, encode_fields_frame)}});
}

CbfScenarioList CbfModule::scenarios(const Nothing& /*in*/, const Caller& /*caller*/) {
  CbfScenarioList out{{}, config_.limits};
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(fs::path(config_.assets_dir) / "scenarios", ec))
    if (e.path().extension() == ".json" && valid_name(e.path().stem().string())) out.names.push_back(e.path().stem().string());
  std::sort(out.names.begin(), out.names.end());
  return out;
}

CbfScenarioFile CbfModule::scenario(const CbfScenarioName& in, const Caller& /*caller*/) {
  const fs::path path = fs::path(config_.assets_dir) / "scenarios" / (in.name + ".json");
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw ApiError(404, "unknown_scenario", "no scenario named \"" + in.name + "\"", "name");
  return {path.string()};
}

// assets/robots/NAME.urdf as the view draws it.
CbfRobotDescription CbfModule::robot(const CbfRobotName& in, const Caller& /*caller*/) {
  return {load_robot(in.name, config_.assets_dir, "name")};
}

// Is the scenario's exact target inside the safe set? The fields are prepared here,
// synchronously: usually held by the rollout just run, else from the cache directory (seconds;
// the first time longer).
CbfFeasibilityAnswer CbfModule::feasibility(const CbfPlannedRequest& in, const Caller& /*caller*/) {
  cbf::Scenario scenario = in.request.scenario;
  std::map<std::string, cbf::SceneField> prepared;
  prepare_fields(scenario, in.plan, {}, prepared);
  return {cbf::target_feasibility(scenario), scenario};
}

CbfRolloutList CbfModule::rollouts(const Nothing& /*in*/, const Caller& caller) {
  auto session = require_session(caller);
  CbfRolloutList out;
  for (const auto& r : cbf_rollouts_->list(session->id)) out.rollouts.push_back(r);
  return out;
}

std::shared_ptr<CbfRollout> CbfModule::require_rollout(const std::string& id, const Caller& caller) {
  auto session = require_session(caller);
  auto r = cbf_rollouts_->find(session->id, id);
  if (!r) throw ApiError(404, "unknown_rollout", "no such rollout in this session");
  return r;
}

CbfRolloutStatus CbfModule::rollout(const CbfRolloutId& in, const Caller& caller) {
  auto r = require_rollout(in.id, caller);
  return {r, jobs_.find(r->session, r->id)};
}

CbfFrames CbfModule::frames(const CbfFramesRequest& in, const Caller& caller) {
  return {require_rollout(in.id, caller), in.from, in.count};
}

CbfRecord CbfModule::record(const CbfRolloutId& in, const Caller& caller) {
  auto r = require_rollout(in.id, caller);
  std::lock_guard lock(r->mutex);
  if (!r->record && ended(r->state))  // cancelled before its first step, or failed
    throw ApiError(409, "no_record", std::string("the rollout is ") + rollout_state_word(r->state) + " and has no record (it ended before its first step, or failed: see its job)");
  if (!r->record)
    throw ApiError(409, "not_finished", std::string("the rollout is ") + rollout_state_word(r->state) +
                                            "; its record is ready when it ends "
                                            "(its frames so far: GET .../frames)");
  return {r->record, r->scenario_name, r->record_pairs, r->state == Lifecycle::cancelled};
}

CbfFieldSurfaces CbfModule::fields(const CbfFieldsRequest& in, const Caller& caller) {
  return field_surfaces(require_rollout(in.id, caller), in.levels);
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
  const std::size_t batch = static_cast<std::size_t>(config_.limits.max_cbf_batch_steps);
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
