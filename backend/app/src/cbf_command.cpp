// `distlab cbf`: one CBF rollout request (JSON) on stdin, the record (JSON) on stdout.
// Exit codes as `distlab gap`: 0 ok, 2 invalid input or usage, 65 malformed JSON, 70 internal
// error; on any error the JSON error body goes to stdout and one line to stderr.
#include <string>
#include <vector>

#include "command.hpp"
#include "distlab/server/cbf_json.hpp"
#include "json_command.hpp"

namespace {

namespace server = distlab::server;

constexpr const char* kHelp = R"(usage: distlab cbf [--pretty] [--feasibility] < request.json

Runs one CBF-QP rollout of a URDF arm (assets/robots; the paper's Franka Panda, Section IV-B) and
writes its record.
With --feasibility: the best robot-obstacle clearance reachable at the scenario's exact target
pose over the arm's redundancy (last joint scanned if dof > 6, joints 1-6 solved), the
configuration and the pair that limit it, the GAP D there, and whether each metric's margin
delta_obs can hold there.

request   {"scenario": NAME | SCENARIO, "metric": "gap" | "euclidean", "params": {...},
           "sweep": {"parameter": PATH, "values": [...]}?}
          NAME: assets/scenarios/NAME.json (corridor, corridor_real, corridor_narrow,
          corridor_fine_margin, ur5e_reach); SCENARIO: the same object inline ("robot": NAME of
          assets/robots/NAME.urdf, default panda)
params    overrides: dt, duration, q0, task_gain, damping, eta, eta_joint, self_collision,
          goal_tolerance, slack_weight, velocity_limit (null | rad/s | [dof] | "robot"),
          margins {gap|euclidean: {obstacle, self}},
          gap {h, k, eps, sigma, weight_margin, tol, max_iter, solver,
               mode: "exact" | "as_published"}; output:
          record_pairs (true: per-step distance and witnesses of every pair),
          audit (true: true Euclidean clearance per step, needed for min_distance with GAP)
response  "t", "q", "u", "task_error", "min_distance" (per step), "infeasible_steps", "slack",
          "pairs", ["distance", "witness_a", "witness_b"], "timing" {"step_us_mean",
          "kinematics_us_mean", "distance_us_mean", "qp_us_mean", "audit_us_mean", "wall_s"},
          "summary" {"reached", "final_task_error", "min_distance", "cancelled", "cold_solves",
          "clipped_steps", "q_final", "final" {"ee_position", "position_error", "min_clearance",
          "closest_pair", "active": [{"name", "kind", "distance", "margin", "clearance",
          "converged_distance", "multiplier"}]}}, "gap_mode", ["converged_distance"]
sweep     one run per value with params.PATH = value (PATH a dotted key of params, e.g.
          margins.gap.obstacle, gap.tol, duration; at most 16 values; audit on by default),
          the runs in parallel on all cores; response {"scenario", "metric", "parameter",
          "values", "entries": [{"index", "value",
          "position_error", "min_clearance", "total_variation", "infeasible_steps", "steps",
          "step_us_mean", "gap_mode", "summary", "smoothness"}]} (summary and smoothness as the
          record of the single run with that value)
errors    {"error": {"code", "message", "field"}}
exit      0 ok, 2 invalid input, 65 malformed JSON, 70 internal error
)";

int run_cbf(const std::vector<std::string>& args, std::istream& in, std::ostream& out,
            std::ostream& err) {
  return distlab::app::run_json_command(
      {"cbf", kHelp, {"--feasibility"}}, args, in, out, err,
      [](const nlohmann::json& request, const auto& flags) {
        if (flags.count("--feasibility")) return server::run_cbf_feasibility(request);
        return request.is_object() && request.contains("sweep") ? server::run_cbf_sweep(request)
                                                                : server::run_cbf_request(request);
      });
}

const distlab::app::RegisterCommand kRegister(
    "cbf", {"CBF-QP rollout of the Panda (GAP or Euclidean): JSON on stdin, record on stdout",
            run_cbf});

}  // namespace
