// A CBF rollout's record as JSON (cbf_json.hpp): the record `distlab cbf` prints and the service
// serves, its final state and smoothness, a sweep's entry, and the target feasibility.
#include "cbf_fields.hpp"
#include "distlab/server/cbf_json.hpp"
#include "distlab/server/json_fields.hpp"

namespace distlab::server {

using json = nlohmann::json;

json encode_smoothness(const cbf::RolloutRecord& rec) {
  json tv = json::array(), rate = json::array();
  for (int j = 0; j < rec.q_final.size(); ++j) {
    const cbf::Smoothness s = cbf::smoothness(rec, j);
    tv.push_back(s.total_variation);
    rate.push_back(s.max_rate);
  }
  return {{"total_variation", tv}, {"max_rate", rate}};
}

json encode_final_state(const cbf::FinalState& f) {
  json active = json::array();
  for (const cbf::ActiveConstraint& a : f.active)
    active.push_back({{"name", a.name},
                      {"kind", a.kind == cbf::ActiveConstraint::Kind::pair ? "pair" : a.kind == cbf::ActiveConstraint::Kind::field ? "field"
                                                                                                                                   : "joint_limit"},
                      {"distance", a.distance},
                      {"margin", a.margin},
                      {"clearance", finite_or_null(a.clearance)},
                      {"converged_distance", finite_or_null(a.converged_distance)},
                      {"multiplier", a.multiplier}});
  return {{"ee_position", vec_json(f.ee_position)},
          {"position_error", f.position_error},
          {"min_clearance", finite_or_null(f.min_clearance)},
          {"closest_pair", f.closest_pair},
          {"active", active}};
}

namespace {

json timing_of(const cbf::RolloutRecord& rec) {
  return {{"kinematics_us_mean", rec.timing.kinematics}, {"distance_us_mean", rec.timing.distance}, {"qp_us_mean", rec.timing.qp}, {"step_us_mean", rec.timing.step}, {"audit_us_mean", rec.timing.audit}, {"wall_s", rec.wall_seconds}};
}

json summary_of(const cbf::RolloutRecord& rec, bool cancelled) {
  return {{"reached", rec.reached},
          {"final_task_error", rec.final_task_error},
          {"min_distance", finite_or_null(rec.min_clearance)},
          {"cancelled", cancelled},
          {"cold_solves", rec.cold_solves},
          {"clipped_steps", rec.clipped_steps},
          {"q_final", vec_json(rec.q_final)},
          {"final", encode_final_state(rec.final_state)}};
}

}  // namespace

json encode_record(const cbf::RolloutRecord& rec, const std::string& scenario_name, bool with_pairs, bool cancelled) {
  json t = json::array(), q = json::array(), u = json::array(), err = json::array(),
       mind = json::array(), slack = json::object();
  const bool pairs = with_pairs && !rec.steps.empty() && !rec.steps.front().pairs.empty();
  json dist = json::array(), wa = json::array(), wb = json::array(), conv = json::array();
  for (std::size_t i = 0; i < rec.steps.size(); ++i) {
    const cbf::StepRecord& s = rec.steps[i];
    t.push_back(s.t);
    q.push_back(vec_json(s.q));
    u.push_back(vec_json(s.u));
    err.push_back(s.task_error);
    mind.push_back(finite_or_null(s.min_clearance));
    if (s.relaxed || s.held)
      slack[std::to_string(i)] = s.held ? json("held") : json(s.slack);
    if (pairs) {
      json d = json::array(), a = json::array(), b = json::array(), c = json::array();
      for (const cbf::PairSample& p : s.pairs) {
        d.push_back(p.distance);
        c.push_back(finite_or_null(p.converged_distance));
        a.push_back(vec_json(p.witness_a));
        b.push_back(vec_json(p.witness_b));
      }
      dist.push_back(std::move(d));
      conv.push_back(std::move(c));
      wa.push_back(std::move(a));
      wb.push_back(std::move(b));
    }
  }
  json names = json::array();
  for (const cbf::PairInfo& p : rec.pairs) names.push_back(p.name);
  json out = {{"scenario", scenario_name},
              {"metric", cbf::to_string(rec.metric)},
              {"dt", rec.dt},
              {"steps", rec.steps.size()},
              {"pairs", names},
              {"t", t},
              {"q", q},
              {"u", u},
              {"task_error", err},
              {"min_distance", mind},
              {"infeasible_steps", rec.infeasible_steps},
              {"slack", slack},
              {"smoothness", encode_smoothness(rec)},
              {"timing", timing_of(rec)},
              {"summary", summary_of(rec, cancelled)}};
  out["gap_mode"] = cbf::to_string(rec.gap_mode);
  if (!rec.field_names.empty()) {
    out["kelvin"] = encode_fields(rec);
    out["timing"]["field_us_mean"] = rec.timing.field;
  }
  if (pairs) {
    if (rec.gap_mode == cbf::GapMode::as_published && rec.metric == cbf::Metric::gap)
      out["converged_distance"] = std::move(conv);
    out["distance"] = std::move(dist);
    out["witness_a"] = std::move(wa);
    out["witness_b"] = std::move(wb);
  }
  return out;
}

static json feasibility_of(const cbf::Feasibility& f, const cbf::Scenario& s);

json encode_feasibility(const cbf::Feasibility& f, const cbf::Scenario& s) {
  json out = feasibility_of(f, s);
  if (!s.fields.empty()) {
    out["start_safe"] = f.start_problem.empty();
    if (!f.start_problem.empty()) out["start_problem"] = f.start_problem;
  }
  return out;
}

static json feasibility_of(const cbf::Feasibility& f, const cbf::Scenario& s) {
  if (!f.reachable)
    return {{"scenario", s.name}, {"reachable", false}, {"configurations", f.configurations}};
  return {{"scenario", s.name},
          {"reachable", true},
          {"q", vec_json(f.q)},
          {"clearance", f.clearance},
          {"limiting_pair", f.limiting_pair},
          {"self_clearance", finite_or_null(f.self_clearance)},
          {"gap_distance", f.gap_distance},
          {"gap_limiting_pair", f.gap_limiting_pair},
          {"margins", {{"euclidean", s.euclidean_margins.obstacle}, {"gap", s.gap_margins.obstacle}}},
          {"euclidean_feasible", f.euclidean_feasible},
          {"gap_feasible", f.gap_feasible},
          {"configurations", f.configurations}};
}

json encode_sweep_entry(std::size_t index, const json& value, const cbf::RolloutRecord& rec,
                        const std::string& scenario_name) {
  json record = encode_record(rec, scenario_name, false);
  double tv = 0;
  for (const json& v : record["smoothness"]["total_variation"]) tv += v.get<double>();
  return {{"index", index},
          {"value", value},
          {"summary", record["summary"]},
          {"smoothness", record["smoothness"]},
          {"gap_mode", record["gap_mode"]},
          {"position_error", record["summary"]["final"]["position_error"]},
          {"min_clearance", record["summary"]["min_distance"]},
          {"total_variation", tv},
          {"infeasible_steps", rec.infeasible_steps.size()},
          {"steps", rec.steps.size()},
          {"step_us_mean", rec.timing.step}};
}

}  // namespace distlab::server
