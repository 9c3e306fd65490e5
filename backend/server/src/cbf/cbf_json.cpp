// CBF scenarios and rollout requests as JSON: strict parsing with field paths (the record and
// its pieces: cbf_record.cpp).
#include "distlab/server/cbf_json.hpp"

#include "cbf_fields.hpp"

#include "distlab/server/data_dirs.hpp"
#include "distlab/server/json_fields.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <map>
#include <sstream>
#include <string_view>

namespace distlab::server {
namespace {

using json = nlohmann::json;
namespace fs = std::filesystem;

// The one typed reader (json_fields.hpp), under the short names this codec reads best with.
std::string key_path(const std::string& base, const std::string& key) { return json_key_path(base, key); }
std::string index_path(const std::string& base, std::size_t i) { return json_index_path(base, i); }
[[noreturn]] void fail(const std::string& field, const std::string& message) {
  throw InvalidInput(field, message);
}
void require_object(const json& j, const std::string& field) { json_require_object(j, field); }
void check_keys(const json& j, const std::string& field,
                std::initializer_list<std::string_view> allowed) {
  json_check_keys(j, field, allowed);
}
const json& required(const json& j, const std::string& field, const char* key) {
  return json_required(j, field, key);
}
// Every number of a scenario is a coordinate, a gain or a time: |v| <= 1e6 keeps squares finite.
double number(const json& j, const std::string& field) { return json_number(j, field, kMaxCoordinate); }
bool boolean(const json& j, const std::string& field) { return json_bool(j, field); }
std::string string(const json& j, const std::string& field) { return json_string(j, field); }

cbf::Margins parse_margins(const json& j, const std::string& field, cbf::Margins m) {
  require_object(j, field);
  check_keys(j, field, {"obstacle", "self"});
  if (auto it = j.find("obstacle"); it != j.end()) m.obstacle = number(*it, key_path(field, "obstacle"));
  if (auto it = j.find("self"); it != j.end()) m.self = number(*it, key_path(field, "self"));
  return m;
}

// The settings a scenario and a request's params share.
constexpr std::array<std::string_view, 13> kSettings = {
    "dt", "duration", "q0", "task_gain", "damping", "eta", "eta_joint", "self_collision",
    "goal_tolerance", "slack_weight", "margins", "gap", "velocity_limit"};

void apply_settings(const json& j, const std::string& field, const Limits& limits, cbf::Scenario& s) {
  const auto get = [&](const char* key) { return json_optional(j, key); };
  const auto f = [&](const char* key) { return key_path(field, key); };
  if (auto v = get("dt")) s.dt = number(*v, f("dt"));
  if (auto v = get("duration")) {
    s.duration = number(*v, f("duration"));
    if (s.duration > limits.max_cbf_duration)
      fail(f("duration"), "at most " + std::to_string(limits.max_cbf_duration) + " s per request");
  }
  const int dof = s.robot->dof();
  if (auto v = get("q0")) s.q0 = json_vecx(*v, f("q0"), dof, kMaxCoordinate);
  if (auto v = get("task_gain")) s.task_gain = number(*v, f("task_gain"));
  if (auto v = get("damping")) s.damping = number(*v, f("damping"));
  if (auto v = get("eta")) s.eta = number(*v, f("eta"));
  if (auto v = get("eta_joint")) s.eta_joint = number(*v, f("eta_joint"));
  if (auto v = get("self_collision")) s.self_collision = boolean(*v, f("self_collision"));
  if (auto v = get("goal_tolerance")) s.goal_tolerance = number(*v, f("goal_tolerance"));
  if (auto v = get("slack_weight")) s.slack_weight = number(*v, f("slack_weight"));
  if (auto v = get("velocity_limit")) {
    // null: no limit; one number: every joint; an array: per joint (rad/s).
    if (v->is_null()) s.velocity_limit.setConstant(dof, std::numeric_limits<double>::infinity());
    else if (v->is_number()) s.velocity_limit.setConstant(dof, number(*v, f("velocity_limit")));
    else if (v->is_string() && v->get<std::string>() == "robot") s.velocity_limit = s.robot->velocity_max();
    else s.velocity_limit = json_vecx(*v, f("velocity_limit"), dof, kMaxCoordinate);
  }
  if (auto v = get("margins")) {
    require_object(*v, f("margins"));
    check_keys(*v, f("margins"), {"gap", "euclidean"});
    const std::string mf = f("margins");
    if (auto it = v->find("gap"); it != v->end())
      s.gap_margins = parse_margins(*it, key_path(mf, "gap"), s.gap_margins);
    if (auto it = v->find("euclidean"); it != v->end())
      s.euclidean_margins = parse_margins(*it, key_path(mf, "euclidean"), s.euclidean_margins);
  }
  if (auto v = get("gap")) {
    const std::string gf = f("gap");
    require_object(*v, gf);
    // gradient and validate are not settings here: the controller needs gradients.
    check_keys(*v, gf, {"h", "k", "eps", "sigma", "weight_margin", "tol", "max_iter", "solver", "mode"});
    json merged = {{"h", s.gap.h}, {"k", s.gap.k}, {"eps", s.gap.eps}, {"sigma", s.gap.sigma}, {"weight_margin", s.gap.weight_margin}, {"tol", s.gap.tol}, {"max_iter", s.gap.max_iter}, {"solver", s.gap.solver == GapSolver::newton ? "newton" : "fixed_point"}};
    merged.update(*v);
    if (auto m = merged.find("mode"); m != merged.end()) {
      const std::string mode = string(*m, key_path(gf, "mode"));
      if (mode == "exact") s.gap_mode = cbf::GapMode::exact;
      else if (mode == "as_published") s.gap_mode = cbf::GapMode::as_published;
      else fail(key_path(gf, "mode"), "expected \"exact\" or \"as_published\"");
      merged.erase(m);
    }
    try {
      s.gap = parse_params(merged, gf).params;
    } catch (const InvalidInput& e) {  // check_params names "params.<x>"
      const std::string& ef = e.field();
      throw InvalidInput(ef.rfind("params.", 0) == 0 ? key_path(gf, ef.substr(7)) : ef, e.what());
    }
    s.gap.gradient = true;
  }
}

// cbf::validate names fields relative to the scenario.
void validated(const cbf::Scenario& s, const std::string& field) {
  try {
    cbf::validate(s);
  } catch (const InvalidInput& e) {
    throw InvalidInput(key_path(field, e.field()), e.what());
  }
}

// parse_scenario with its fields planned, not prepared (cbf_fields.hpp): everything is checked
// before anything is prepared.
cbf::Scenario scenario_of(const json& j, const std::string& field, const std::string& assets_dir, FieldPlan& plan,
                          const Limits& limits) {
  require_object(j, field);
  for (const auto& [key, value] : j.items()) {
    static const std::initializer_list<std::string_view> own = {"name", "comment", "robot", "obstacles", "target",
                                                                "fields", "control_points", "field_mode"};
    if (std::find(own.begin(), own.end(), key) == own.end() &&
        std::find(kSettings.begin(), kSettings.end(), key) == kSettings.end())
      fail(key_path(field, key), "unknown key \"" + key.substr(0, 64) + "\"");
  }
  cbf::Scenario s;
  s.name = "inline";
  if (auto it = j.find("name"); it != j.end()) s.name = string(*it, key_path(field, "name"));
  if (auto it = j.find("comment"); it != j.end()) string(*it, key_path(field, "comment"));
  if (auto it = j.find("robot"); it != j.end()) s.robot_name = string(*it, key_path(field, "robot"));
  s.robot = load_robot(s.robot_name, assets_dir, key_path(field, "robot"));
  const std::string of = key_path(field, "obstacles");
  const json& obstacles = required(j, field, "obstacles");
  if (!obstacles.is_array()) fail(of, "expected an array of obstacles");
  if (obstacles.size() > limits.max_cbf_obstacles)
    fail(of, "at most " + std::to_string(limits.max_cbf_obstacles) + " obstacles");
  for (std::size_t i = 0; i < obstacles.size(); ++i) {
    const std::string f = index_path(of, i);
    require_object(obstacles[i], f);
    check_keys(obstacles[i], f, {"name", "shape"});
    ShapeSpec spec = parse_shape(required(obstacles[i], f, "shape"), key_path(f, "shape"));
    cbf::Obstacle o{"obstacle" + std::to_string(i), std::move(spec.shape), spec.pose,
                    std::move(spec.options)};
    if (auto it = obstacles[i].find("name"); it != obstacles[i].end())
      o.name = string(*it, key_path(f, "name"));
    s.obstacles.push_back(std::move(o));
  }
  s.target = json_pose(required(j, field, "target"), key_path(field, "target"), /*position_required=*/true);
  required(j, field, "q0");
  plan_scenario_fields(j, field, assets_dir, limits, plan, s);
  apply_settings(j, field, limits, s);
  validated(s, field);
  return s;
}

}  // namespace

cbf::Scenario parse_scenario(const json& j, const std::string& field, const std::string& assets_dir,
                             const FieldPreparer& prepare, const Limits& limits) {
  FieldPlan plan;
  cbf::Scenario s = scenario_of(j, field, assets_dir, plan, limits);
  prepare_planned_fields(s, plan, prepare);
  validated(s, field);
  return s;
}

namespace {

// assets/KIND/NAME.EXT under the roots of scenario_path.
std::string asset_path(const std::string& kind, const std::string& name, const std::string& ext,
                       const std::string& assets_dir, const std::string& field) {
  const std::string what = kind == "scenarios" ? "scenario" : "robot";
  if (name.empty() || name.size() > 64) fail(field, what + " names have 1 to 64 characters");
  for (char c : name)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-')
      fail(field, what + " names are letters, digits, '_' and '-'");
  const std::vector<std::string> roots =
      assets_dir.empty() ? data_dir_candidates("DISTLAB_ASSETS", "assets", "assets") : std::vector<std::string>{assets_dir};
  for (const fs::path root : roots)
    if (fs::is_regular_file(root / kind / (name + ext))) return (root / kind / (name + ext)).string();
  fail(field, "unknown " + what + " \"" + name + "\" (looked for " + kind + "/" + name + ext +
                  " in $DISTLAB_ASSETS and assets/)");
}

}  // namespace

std::string scenario_path(const std::string& name, const std::string& assets_dir) {
  return asset_path("scenarios", name, ".json", assets_dir, "scenario");
}

std::shared_ptr<const cbf::Robot> load_robot(const std::string& name, const std::string& assets_dir,
                                             const std::string& field) {
  const std::string path = asset_path("robots", name, ".urdf", assets_dir, field);
  try {
    return cbf::Robot::load(path, field);
  } catch (const InvalidInput& e) {  // a broken asset is the server's fault, not the caller's
    throw std::runtime_error("robot file " + name + ".urdf: " + e.what());
  }
}

nlohmann::json read_scenario_file(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  if (!in) throw std::runtime_error("cannot read " + path);
  // A broken asset is an internal error, not the caller's.
  try {
    json j = parse_json_text(text.str());
    // The scenario's robot from the same assets directory. Its Kelvin objects are checked as
    // hulls (the mesh is read, nothing is prepared): the run prepares them.
    json check = j;
    if (check.is_object() && check.contains("fields")) check["field_mode"] = "hull";
    parse_scenario(check, "scenario", fs::path(path).parent_path().parent_path().string());
    return j;
  } catch (const std::exception& e) {
    throw std::runtime_error("scenario file " + path + ": " + e.what());
  }
}

namespace {

// A scenario field's σ or δ that params.fields replaced is named by its path in params:
// "scenario.fields[0].sigma.per_vertex" -> "params.fields[0].sigma.per_vertex".
std::string params_field(const std::string& field, const json& params) {
  const auto it = params.find("fields");
  if (it == params.end() || !it->is_array()) return field;
  for (std::size_t i = 0; i < it->size(); ++i)
    for (const char* key : {"sigma", "delta"}) {
      const std::string from = key_path(index_path("scenario.fields", i), key);
      if ((*it)[i].is_object() && (*it)[i].contains(key) && field.rfind(from, 0) == 0 &&
          (field.size() == from.size() || field[from.size()] == '.' || field[from.size()] == '['))
        return key_path(index_path("params.fields", i), key) + field.substr(from.size());
    }
  return field;
}

CbfRequest request_of(const json& r, const std::string& assets_dir, FieldPlan& plan, const Limits& limits) {
  require_object(r, "");
  check_keys(r, "", {"scenario", "metric", "params", "comment"});
  if (auto it = r.find("comment"); it != r.end()) string(*it, "comment");
  CbfRequest out;
  const json& sj = required(r, "", "scenario");
  const json no_params = json::object();
  const json& params = r.contains("params") ? r["params"] : no_params;
  require_object(params, "params");
  try {
    if (sj.is_string()) {
      const std::string path = scenario_path(sj.get<std::string>(), assets_dir);
      json scenario = read_scenario_file(path);
      apply_field_params(scenario, params);
      out.scenario = scenario_of(scenario, "scenario", fs::path(path).parent_path().parent_path().string(), plan, limits);
    } else {
      json scenario = sj;
      apply_field_params(scenario, params);
      out.scenario = scenario_of(scenario, "scenario", assets_dir, plan, limits);
    }
  } catch (const InvalidInput& e) {
    throw InvalidInput(params_field(e.field(), params), e.what());
  }
  if (auto it = r.find("metric"); it != r.end()) {
    const std::string m = string(*it, "metric");
    if (m == "gap") out.metric = cbf::Metric::gap;
    else if (m == "euclidean") out.metric = cbf::Metric::euclidean;
    else fail("metric", "expected \"gap\" or \"euclidean\"");
  }
  if (auto it = r.find("params"); it != r.end()) {
    require_object(*it, "params");
    for (const auto& [key, value] : it->items())
      if (key != "record_pairs" && key != "audit" && key != "fields" && key != "field_mode" &&
          std::find(kSettings.begin(), kSettings.end(), key) == kSettings.end())
        fail("params." + key.substr(0, 64), "unknown key \"" + key.substr(0, 64) + "\"");
    apply_settings(*it, "params", limits, out.scenario);
    if (auto v = it->find("record_pairs"); v != it->end())
      out.options.record_pairs = boolean(*v, "params.record_pairs");
    if (auto v = it->find("audit"); v != it->end())
      out.options.audit_clearance = boolean(*v, "params.audit");
    try {
      cbf::validate(out.scenario);
    } catch (const InvalidInput& e) {
      throw InvalidInput("params." + e.field(), e.what());
    }
  }
  return out;
}

}  // namespace

CbfRequest plan_cbf_request(const json& request, const std::string& assets_dir, FieldPlan& plan, const Limits& limits) {
  return request_of(request, assets_dir, plan, limits);
}

CbfRequest parse_cbf_request(const json& request, const std::string& assets_dir, const FieldPreparer& prepare,
                             const Limits& limits) {
  FieldPlan plan;
  CbfRequest out = request_of(request, assets_dir, plan, limits);
  prepare_planned_fields(out.scenario, plan, prepare);
  validated(out.scenario, "scenario");
  return out;
}

json run_cbf_feasibility(const json& request, const std::string& assets_dir) {
  const CbfRequest r = parse_cbf_request(request, assets_dir);
  return encode_feasibility(cbf::target_feasibility(r.scenario), r.scenario);
}

json run_cbf_request(const json& request) {
  const CbfRequest r = parse_cbf_request(request);
  return encode_record(cbf::rollout(r.scenario, r.metric, r.options), r.scenario.name);
}

CbfSweep plan_cbf_sweep(const json& request, const std::string& assets_dir, const Limits& limits, std::vector<FieldPlan>& plans) {
  const std::size_t max_values = limits.max_cbf_sweep_values;
  require_object(request, "");
  const json& sw = required(request, "", "sweep");
  require_object(sw, "sweep");
  check_keys(sw, "sweep", {"parameter", "values"});
  CbfSweep out;
  out.parameter = string(required(sw, "sweep", "parameter"), "sweep.parameter");
  std::vector<std::string> path;
  for (std::size_t b = 0;;) {
    const std::size_t e = out.parameter.find('.', b);
    path.push_back(out.parameter.substr(b, e == std::string::npos ? std::string::npos : e - b));
    if (path.back().empty() || path.back().size() > 64) fail("sweep.parameter", "expected a dotted key of params, e.g. \"margins.gap.obstacle\"");
    if (e == std::string::npos) break;
    b = e + 1;
  }
  if (path.front() == "record_pairs" || path.front() == "audit")
    fail("sweep.parameter", "\"" + path.front() + "\" sets the output, not the run");
  out.values = required(sw, "sweep", "values");
  if (!out.values.is_array() || out.values.empty() || out.values.size() > max_values)
    fail("sweep.values", "expected an array of 1 to " + std::to_string(max_values) + " values");
  json base = request;
  base.erase("sweep");
  json& params = base["params"];
  if (params.is_null()) params = json::object();
  require_object(params, "params");
  if (!params.contains("audit")) params["audit"] = true;  // min clearance for each run
  const std::string pf = "params." + out.parameter;
  for (std::size_t i = 0; i < out.values.size(); ++i) {
    json r = base;
    json* node = &r["params"];
    for (std::size_t k = 0; k + 1 < path.size(); ++k) {
      node = &(*node)[path[k]];
      if (node->is_null()) *node = json::object();
      if (!node->is_object()) fail("sweep.parameter", "params." + path[k] + " is not an object");
    }
    (*node)[path.back()] = out.values[i];
    const std::string vf = "sweep.values[" + std::to_string(i) + "]";
    try {
      plans.emplace_back();
      out.runs.push_back(request_of(r, assets_dir, plans.back(), limits));
    } catch (const InvalidInput& e) {
      const std::string& f = e.field();
      // An unknown key at or on the way to the parameter: the path names no parameter.
      if (std::string_view(e.what()).starts_with("unknown key") && (f == pf || pf.starts_with(f + ".")))
        throw InvalidInput("sweep.parameter", std::string("sweep.parameter: ") + e.what());
      if (f == pf || f.starts_with(pf + ".") || f.starts_with(pf + "["))
        throw InvalidInput(vf, vf + " = " + out.values[i].dump().substr(0, 64) + ": " + e.what());
      throw;
    }
    out.requests.push_back(std::move(r));
  }
  return out;
}

CbfSweep parse_cbf_sweep(const json& request, const std::string& assets_dir, const Limits& limits) {
  std::vector<FieldPlan> plans;
  CbfSweep out = plan_cbf_sweep(request, assets_dir, limits, plans);
  std::map<std::string, cbf::SceneField> prepared;  // the runs' fields are the same: prepared once
  for (std::size_t i = 0; i < out.runs.size(); ++i) {
    prepare_planned_fields(out.runs[i].scenario, plans[i], {}, {}, &prepared);
    validated(out.runs[i].scenario, "scenario");
  }
  return out;
}

}  // namespace distlab::server
