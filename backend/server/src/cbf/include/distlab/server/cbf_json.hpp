#pragma once
// CBF rollouts as JSON, shared by `distlab cbf` and (later) the HTTP service.
//
// Scenario: {"name", "comment"?, "robot": NAME? (assets/robots/NAME.urdf, default "panda"), "obstacles": [{"name", "shape": SHAPE}],
//            "target": {"position", "quaternion" [w, x, y, z]}, "q0": [dof], "dt", "duration",
//            "task_gain", "damping", "eta", "eta_joint", "self_collision", "goal_tolerance",
//            "slack_weight", "margins": {"gap"|"euclidean": {"obstacle", "self"}},
//            "gap": {h, k, eps, sigma, weight_margin, tol, max_iter, solver,
//                    mode: "exact" | "as_published"},
//            "velocity_limit": null | number | [dof] | "robot" (rad/s, u clipped per joint;
//            "robot": the URDF's limit velocity), "fields", "control_points" (Kelvin objects as
//            barriers: cbf_fields.hpp)}
//            (SHAPE as in gap_json, pose in the world; every key but obstacles/target/q0 optional,
//            defaults from cbf::Scenario).
// Request:  {"scenario": NAME | SCENARIO, "metric": "gap" | "euclidean", "params": {...}?,
//            "comment"?}; NAME is a file assets/scenarios/NAME.json; params override the
//            scenario's dt, duration, q0, task_gain, damping, eta, eta_joint, self_collision,
//            goal_tolerance, slack_weight, margins, gap, fields (σ and δ by index), field_mode, and
//            set the output: "record_pairs"
//            (true: every pair's distance and witnesses per step), "audit" (true: true
//            Euclidean clearance per step; needed for min_distance with GAP).
// Response: see encode_record.
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "distlab/cbf/feasibility.hpp"
#include "distlab/cbf/rollout.hpp"
#include "distlab/geometry/progress.hpp"
#include "distlab/server/config.hpp"
#include "distlab/server/gap_json.hpp"

namespace distlab::server {

// Prepares a scenario's Kelvin object (its "fields" entry): the surface and options in, the
// prepared field out (σ is solved on it afterwards). Unset: kelvin::Field::prepare_cached in
// default_cache_dir() (the disk cache `distlab serve` uses by default).
using FieldPreparer = std::function<kelvin::Field(const mesh::SurfaceMesh& surface, const kelvin::PrepareOptions& options,
                                                  const std::string& field)>;

// Throws InvalidInput naming the field (prefixed with `field`, e.g. "scenario.q0[2]"). The robot
// ("robot": NAME, default "panda") is assets/robots/NAME.urdf, looked up as scenario_path does.
// Bounded by limits.max_cbf_duration and max_cbf_obstacles (the CLI and Python: the defaults).
cbf::Scenario parse_scenario(const nlohmann::json& j, const std::string& field = "scenario",
                             const std::string& assets_dir = "", const FieldPreparer& prepare = {},
                             const Limits& limits = {});
// Reads "fields" and "control_points" of scenario JSON j (the keys of a scenario: cbf_fields.hpp)
// into s, whose robot is set; `field` prefixes error paths. The fields are prepared by `prepare`.
// At most limits.max_cbf_fields fields and max_cbf_control_points control points.
void parse_scenario_fields(const nlohmann::json& j, const std::string& field, const std::string& assets_dir,
                           const FieldPreparer& prepare, cbf::Scenario& s, const Limits& limits = {});

// assets/robots/NAME.urdf, parsed once (an unknown name is InvalidInput(field); a broken file is
// std::runtime_error).
std::shared_ptr<const cbf::Robot> load_robot(const std::string& name, const std::string& assets_dir = "",
                                             const std::string& field = "robot");

// Looks for NAME.json in ASSETS_DIR/scenarios when assets_dir is given (the service), else in
// $DISTLAB_ASSETS/scenarios, ./assets/scenarios and assets/scenarios above the executable.
// Names are letters, digits, '_' and '-'; an unknown name is InvalidInput("scenario").
std::string scenario_path(const std::string& name, const std::string& assets_dir = "");
// A scenario file's JSON, checked with parse_scenario; a broken file is std::runtime_error
// (the server's fault, not the caller's).
nlohmann::json read_scenario_file(const std::string& path);

struct CbfRequest {
  cbf::Scenario scenario;
  cbf::Metric metric = cbf::Metric::gap;
  cbf::RolloutOptions options;
};
CbfRequest parse_cbf_request(const nlohmann::json& request, const std::string& assets_dir = "",
                             const FieldPreparer& prepare = {}, const Limits& limits = {});

// {"scenario", "metric", "dt", "steps", "pairs": [names], "t": [...], "q": [[7]...], "u": [[7]...],
//  "task_error": [...], "min_distance": [...], "infeasible_steps": [indices], "slack": {index: s},
//  "smoothness": {"total_variation": [7], "max_rate": [7]} (per joint: Σ|Δu|, max |Δu|/dt),
//  "distance": [[per pair]...], "witness_a"/"witness_b": [[[x,y,z] per pair]...] (record_pairs),
//  "timing": {"kinematics_us_mean", "step_us_mean", "distance_us_mean", "qp_us_mean",
//             "audit_us_mean", "wall_s"}, "summary": {"reached", "final_task_error",
//  "min_distance", "cancelled", "cold_solves", "clipped_steps", "q_final", "final":
//  encode_final_state}, "gap_mode", and with gap.mode as_published and record_pairs
//  "converged_distance": [[per pair]...] (the converged D beside the early-stopped one).
// with_pairs = false leaves out "distance"/"witness_a"/"witness_b" even if the record has them;
// cancelled: the record is of the steps a cancelled rollout made (summary "cancelled").
nlohmann::json encode_record(const cbf::RolloutRecord& record, const std::string& scenario_name,
                             bool with_pairs = true, bool cancelled = false);
nlohmann::json encode_smoothness(const cbf::RolloutRecord& record);
// {"ee_position", "position_error", "min_clearance", "closest_pair", "active": [{"name", "kind"
//  ("pair" | "joint_limit"), "distance", "margin", "clearance", "converged_distance",
//  "multiplier"}]}: where the arm ends and which constraints hold it there.
nlohmann::json encode_final_state(const cbf::FinalState& f);

// Parse, run, encode; throws InvalidInput on bad input.
nlohmann::json run_cbf_request(const nlohmann::json& request);

// A parameter sweep: one request with "sweep": {"parameter": PATH, "values": [...]}, PATH a
// dotted key of params (e.g. "margins.gap.obstacle", "gap.tol", "duration"). Run i is the request
// with params.PATH = values[i] (audit on unless params.audit says otherwise), so each entry is
// what `distlab cbf` returns for that request. A bad value is InvalidInput("sweep.values[i]"), a
// path that is no parameter InvalidInput("sweep.parameter"). At most limits.max_cbf_sweep_values.
// The throw the check finds is nlohmann::json's unreachable internal-error branch of its noexcept
// default constructor.
struct CbfSweep {  // NOLINT(bugprone-exception-escape)
  std::string parameter;
  nlohmann::json values;                 // as given
  std::vector<nlohmann::json> requests;  // one per value (no "sweep")
  std::vector<CbfRequest> runs;
};
CbfSweep parse_cbf_sweep(const nlohmann::json& request, const std::string& assets_dir = "", const Limits& limits = {});
// One run of a sweep: {"index" (of values), "value", "summary" and "smoothness" (as the run's
// record), "gap_mode", "position_error", "min_clearance", "total_variation" (Σ over joints),
// "infeasible_steps" (count), "steps", "step_us_mean"}.
nlohmann::json encode_sweep_entry(std::size_t index, const nlohmann::json& value, const cbf::RolloutRecord& record,
                                  const std::string& scenario_name);

// How a sweep's runs are spread over threads (cbf_sweep.cpp). The calling thread runs runs too,
// so the sweep advances even when post refuses every helper.
struct SweepExecution {
  // Over all runs' steps: stage "K of N runs done", fraction; serialised, never decreasing. Its
  // cancel stops every run (a cancelled run has no entry) and then the sweep (Cancelled).
  Progress progress;
  // A finished run's entry, as it finishes (serialised; runs finish in any order).
  std::function<void(std::size_t index, const nlohmann::json& entry)> finished;
  // Runs a task on another thread; false: it cannot (fewer runs go in parallel). Empty: the
  // helpers run on distlab::parallel_for's threads, joined before execute_sweep returns.
  std::function<bool(std::function<void()>)> post;
  unsigned helpers = 0;           // threads besides the caller's (at most runs − 1)
  bool one_run_per_task = false;  // a helper re-posts itself after each run (a shared pool stays fair)
};
// Runs every run of the sweep; the entries in the sweep's order. Each entry is the same whatever
// thread ran it. Rethrows the error of the lowest failing run; Cancelled once every run stopped.
std::vector<nlohmann::json> execute_sweep(const CbfSweep& sweep, const SweepExecution& how);
// `distlab cbf` with "sweep": {"scenario", "metric", "parameter", "values", "entries": [...]}, the
// runs on all cores. progress (geometry/progress.hpp): report(stage, fraction) as execute_sweep's,
// cancel stops the sweep (then throws Cancelled).
nlohmann::json run_cbf_sweep(const nlohmann::json& request, const Progress& progress = {});

// Target feasibility of a request's scenario (cbf::target_feasibility; "metric" is ignored):
// {"scenario", "reachable", "q": [7], "clearance", "limiting_pair", "self_clearance",
//  "gap_distance", "gap_limiting_pair", "margins": {"euclidean", "gap"}, "euclidean_feasible",
//  "gap_feasible", "configurations"}.
nlohmann::json encode_feasibility(const cbf::Feasibility& f, const cbf::Scenario& scenario);
nlohmann::json run_cbf_feasibility(const nlohmann::json& request, const std::string& assets_dir = "");

}  // namespace distlab::server
