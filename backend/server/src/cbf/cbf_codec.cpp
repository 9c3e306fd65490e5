// The CBF routes' codec: requests read and checked in full (cbf_fields.hpp plans their fields
// against the budget), answers written.
#include "cbf_codec.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "distlab/server/frames.hpp"
#include "distlab/server/json_fields.hpp"
#include "distlab/server/request_params.hpp"

namespace distlab::server {

using json = nlohmann::json;

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

CbfStreamOptions parse_stream(const json& j, const Limits& limits) {
  CbfStreamOptions s;
  json_require_object(j, "stream");
  json_check_keys(j, "stream", {"batch_steps", "pairs", "poses"});
  if (auto it = j.find("batch_steps"); it != j.end()) {
    const double n = json_number(*it, "stream.batch_steps");
    if (n != std::floor(n) || n < 1 || n > limits.max_cbf_batch_steps)
      throw InvalidInput("stream.batch_steps",
                         "stream.batch_steps must be a whole number from 1 to " + std::to_string(limits.max_cbf_batch_steps));
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

// The collision pairs a rollout of sc computes every step.
std::size_t pair_count(const cbf::Scenario& sc) {
  return sc.robot->primitives().size() * sc.obstacles.size() + (sc.self_collision ? sc.robot->self_pairs().size() : 0);
}

void check_fields_budget(const FieldPlan& plan, const Limits& limits) {
  for (const PlannedField& p : plan.fields) check_field_budget(p, limits);
}

// A rollout's steps and pair-steps within the limits (422 too_long, naming where duration came from).
void check_rollout_size(const cbf::Scenario& sc, const Limits& limits, const std::string& field) {
  const int steps = sc.steps();
  if (steps > limits.max_cbf_steps)
    throw ApiError(422, "too_long",
                   "duration / dt = " + std::to_string(steps) + " steps; at most " + std::to_string(limits.max_cbf_steps) +
                       " per rollout on this server",
                   field);
  const std::size_t pairs = pair_count(sc);
  if (pairs * static_cast<std::size_t>(steps) > limits.max_cbf_pair_steps)
    throw ApiError(422, "too_long",
                   std::to_string(pairs) + " pairs × " + std::to_string(steps) + " steps is over this server's " +
                       std::to_string(limits.max_cbf_pair_steps) + " pair-steps per rollout; shorten it or use fewer obstacles",
                   field);
}

Response accepted(const char* key, json status, const Job& job) {
  return json_response(202, {{key, std::move(status)}, {"job", job.to_json()}});
}

}  // namespace

Response encode_scenarios(const CbfScenarioList& list) {
  const Limits& l = list.limits;
  return json_response(200, {{"scenarios", list.names},
                             {"metrics", {"gap", "euclidean"}},
                             {"limits",
                              {{"max_steps", l.max_cbf_steps},
                               {"max_duration", l.max_cbf_duration},
                               {"max_pair_steps", l.max_cbf_pair_steps},
                               {"max_batch_steps", l.max_cbf_batch_steps},
                               {"max_frames_per_request", l.max_cbf_frames_per_request},
                               {"kept_per_session", l.cbf_rollouts_kept_per_session},
                               {"max_sweep_values", l.max_cbf_sweep_values}}}});
}

CbfScenarioName decode_scenario_name(const Request& req, const Limits& /*limits*/) {
  const std::string name = req.params.at("name");
  if (!valid_name(name)) throw InvalidInput("name", "scenario names are 1 to 64 letters, digits, '_' and '-'");
  return {name};
}

Response encode_scenario_file(const CbfScenarioFile& file) { return json_response(200, read_scenario_file(file.path)); }

CbfRobotName decode_robot_name(const Request& req, const Limits& /*limits*/) {
  auto it = req.query.find("name");
  return {it == req.query.end() ? "panda" : it->second};
}

Response encode_robot(const CbfRobotDescription& robot) { return json_response(200, cbf_robot_json(*robot.robot)); }

CbfPlannedRequest decode_feasibility(const Request& req, const Limits& limits, const std::string& assets_dir) {
  const json body = parse_body(req);
  refuse_mesh_paths(body);
  CbfPlannedRequest out;
  out.request = plan_cbf_request(body, assets_dir, out.plan, limits);
  check_fields_budget(out.plan, limits);
  // About kFeasibilityConfigurations IK configurations are examined, each against every pair.
  const std::size_t pairs = pair_count(out.request.scenario);
  if (pairs * cbf::kFeasibilityConfigurations > limits.max_cbf_pair_steps)
    throw ApiError(422, "too_large",
                   std::to_string(pairs) + " pairs: the feasibility scan allows at most " +
                       std::to_string(limits.max_cbf_pair_steps / cbf::kFeasibilityConfigurations) + " on this server",
                   "scenario.obstacles");
  return out;
}

Response encode_feasibility_answer(const CbfFeasibilityAnswer& answer) {
  return json_response(200, encode_feasibility(answer.feasibility, answer.scenario));
}

CbfRolloutRequest decode_rollout(const Request& req, const Limits& limits, const std::string& assets_dir) {
  json body = parse_body(req);
  json_require_object(body, "");
  CbfStreamOptions stream;
  if (auto it = body.find("stream"); it != body.end()) {
    stream = parse_stream(*it, limits);
    body.erase("stream");
  }
  refuse_mesh_paths(body);
  auto plan = std::make_shared<FieldPlan>();
  const CbfRequest parsed = plan_cbf_request(body, assets_dir, *plan, limits);
  check_fields_budget(*plan, limits);
  const cbf::Scenario& sc = parsed.scenario;
  check_rollout_size(sc, limits, duration_field(body));

  auto r = std::make_shared<CbfRollout>();
  const json& sj = body["scenario"];
  r->scenario_json = sj.is_string() ? read_scenario_file(scenario_path(sj.get<std::string>(), assets_dir)) : sj;
  r->scenario_name = sc.name;
  r->scenario = sc;
  r->metric = parsed.metric;
  r->record_pairs = parsed.options.record_pairs;
  r->stream = stream;
  r->steps_total = sc.steps();
  // The pair list without building the controller's GAP bodies.
  robot::PairSelection selection;
  selection.self = sc.self_collision;
  r->pairs = robot::select_pairs(*sc.robot, sc.obstacles, selection);
  r->control_points = plan->control_points;
  r->fields = rollout_fields(*plan);
  cbf::RolloutOptions options = parsed.options;
  options.record_pairs = options.record_pairs || stream.pairs;
  return {r, plan, options};
}

Response encode_rollout_started(const CbfRolloutStatus& started) {
  return accepted("rollout", started.rollout->status_json(), *started.job);
}

Response encode_rollout_status(const CbfRolloutStatus& status) {
  json out = status.rollout->status_json();
  if (status.job) out["job"] = status.job->to_json();
  return json_response(200, out);
}

Response encode_rollouts(const CbfRolloutList& list) {
  json out = json::array();
  for (const auto& r : list.rollouts) out.push_back(r->status_json());
  return json_response(200, {{"rollouts", out}});
}

json rollout_job_params(const CbfRollout& r) { return {{"scenario", r.scenario_name}, {"metric", cbf::to_string(r.metric)}}; }

json rollout_job_result(const CbfRollout& r, const cbf::RolloutRecord& rec) {
  const json summary = {{"reached", rec.reached}, {"final_task_error", rec.final_task_error}, {"infeasible_steps", rec.infeasible_steps.size()}, {"steps", rec.steps.size()}};
  return {{"rollout", r.id}, {"summary", summary}};
}

CbfRolloutId decode_rollout_id(const Request& req, const Limits& /*limits*/) { return {req.params.at("id")}; }

CbfFramesRequest decode_frames(const Request& req, const Limits& limits) {
  const std::size_t max = limits.max_cbf_frames_per_request;
  CbfFramesRequest out{req.params.at("id"), query_index(req, "from", 0), query_index(req, "count", max)};
  if (out.count > max) throw ApiError(413, "too_many_frames", "at most " + std::to_string(max) + " frames per request", "count");
  return out;
}

Response encode_frames(const CbfFrames& frames) {
  return json_response(200, cbf_frames_json(*frames.rollout, frames.from, frames.count));
}

Response encode_rollout_record(const CbfRecord& record) {
  return json_response(200, encode_record(*record.record, record.scenario_name, record.with_pairs, record.cancelled));
}

CbfFieldsRequest decode_fields(const Request& req, const Limits& limits) {
  CbfFieldsRequest out{req.params.at("id"), std::nullopt};
  single_query(req, "levels");
  if (auto it = req.query.find("levels"); it != req.query.end()) out.levels = parse_levels(it->second, limits.max_levels);
  return out;
}

Response encode_fields_frame(const CbfFieldSurfaces& fields) {
  Response out;
  out.content_type = "application/msgpack";
  out.body = to_msgpack(fields_frame(fields));
  return out;
}

CbfSweepRequest decode_sweep(const Request& req, const Limits& limits, const std::string& assets_dir) {
  const json body = parse_body(req);
  refuse_mesh_paths(body);
  auto plans = std::make_shared<std::vector<FieldPlan>>();
  auto sweep = std::make_shared<CbfSweep>(plan_cbf_sweep(body, assets_dir, limits, *plans));
  for (const FieldPlan& plan : *plans) check_fields_budget(plan, limits);
  for (std::size_t i = 0; i < sweep->runs.size(); ++i) {
    const cbf::Scenario& sc = sweep->runs[i].scenario;
    const std::size_t steps = static_cast<std::size_t>(sc.steps());
    const std::size_t pairs = pair_count(sc);
    if (steps > static_cast<std::size_t>(limits.max_cbf_steps) || pairs * steps > limits.max_cbf_pair_steps)
      throw ApiError(422, "too_long",
                     "run " + std::to_string(i) + ": " + std::to_string(steps) + " steps × " + std::to_string(pairs) +
                         " pairs is over this server's " + std::to_string(limits.max_cbf_steps) + " steps or " +
                         std::to_string(limits.max_cbf_pair_steps) + " pair-steps per rollout",
                     "sweep.values[" + std::to_string(i) + "]");
  }
  return {sweep, plans};
}

json sweep_job_params(const CbfSweep& sweep) { return {{"parameter", sweep.parameter}}; }

json sweep_head(const CbfSweep& sweep) {
  return {{"scenario", sweep.runs.front().scenario.name},
          {"metric", cbf::to_string(sweep.runs.front().metric)},
          {"parameter", sweep.parameter},
          {"values", sweep.values}};
}

json sweep_job_result(const CbfSweepRun& run) {
  json out = sweep_head(*run.sweep);
  std::lock_guard lock(run.mutex);
  out["entries"] = run.entries;
  return out;
}

Response encode_sweep_started(const CbfSweepStatus& started) {
  json status = sweep_head(*started.sweep->sweep);
  status["id"] = started.sweep->id;
  status["entries"] = json::array();
  return accepted("sweep", std::move(status), *started.job);
}

Response encode_sweep_status(const CbfSweepStatus& status) {
  json out = sweep_job_result(*status.sweep);
  out["id"] = status.sweep->id;
  if (status.job) {
    out["job"] = status.job->to_json();
    out["job"].erase("result");  // the entries are above
  }
  return json_response(200, out);
}

}  // namespace distlab::server
