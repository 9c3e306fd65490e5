// `distlab cbf`: one CBF rollout request (JSON) on stdin, the record (JSON) on stdout.
// Exit codes as `distlab gap`: 0 ok, 2 invalid input or usage, 65 malformed JSON, 70 internal
// error; on any error the JSON error body goes to stdout and one line to stderr.
#include <istream>
#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "command.hpp"
#include "distlab/server/cbf_json.hpp"

namespace {

using nlohmann::json;
namespace server = distlab::server;

constexpr int kExitOk = 0;
constexpr int kExitInvalid = 2;
constexpr int kExitParse = 65;     // EX_DATAERR
constexpr int kExitInternal = 70;  // EX_SOFTWARE

constexpr const char* kHelp = R"(usage: distlab cbf [--pretty] < request.json

Runs one CBF-QP rollout of the Franka Panda (paper Section IV-B) and writes its record.

request   {"scenario": NAME | SCENARIO, "metric": "gap" | "euclidean", "params": {...}}
          NAME: assets/scenarios/NAME.json (e.g. "corridor"); SCENARIO: the same object inline
params    overrides: dt, duration, q0, task_gain, damping, eta, eta_joint, self_collision,
          goal_tolerance, slack_weight, margins {gap|euclidean: {obstacle, self}},
          gap {h, k, eps, sigma, weight_margin, tol, max_iter, solver}; output:
          record_pairs (true: per-step distance and witnesses of every pair),
          audit (true: true Euclidean clearance per step, needed for min_distance with GAP)
response  "t", "q", "u", "task_error", "min_distance" (per step), "infeasible_steps", "slack",
          "pairs", ["distance", "witness_a", "witness_b"], "timing" {"step_us_mean",
          "kinematics_us_mean", "distance_us_mean", "qp_us_mean", "audit_us_mean", "wall_s"},
          "summary" {"reached", "final_task_error", "min_distance", "cancelled", "cold_solves",
          "q_final"}
errors    {"error": {"code", "message", "field"}}
exit      0 ok, 2 invalid input, 65 malformed JSON, 70 internal error
)";

std::string one_line(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  return s;
}

int run_cbf(const std::vector<std::string>& args, std::istream& in, std::ostream& out,
            std::ostream& err) {
  bool pretty = false;
  for (const std::string& a : args) {
    if (a == "--pretty") {
      pretty = true;
    } else if (a == "--help" || a == "-h") {
      out << kHelp;
      return kExitOk;
    } else {
      err << "distlab cbf: unknown option '" << a << "' (see distlab cbf --help)\n";
      return kExitInvalid;
    }
  }
  auto emit = [&](const json& j) {
    out << j.dump(pretty ? 2 : -1, ' ', false, json::error_handler_t::replace) << '\n';
    out.flush();
  };
  try {
    std::string text;
    char buf[1 << 16];
    while (text.size() <= server::kMaxRequestBytes && in.read(buf, sizeof buf).gcount() > 0)
      text.append(buf, static_cast<std::size_t>(in.gcount()));
    if (in.bad()) throw std::runtime_error("cannot read stdin");
    emit(server::run_cbf_request(server::parse_json_text(text)));
    return kExitOk;
  } catch (const server::JsonSyntaxError& e) {
    json body = server::error_json("parse_error", e.what());
    body["error"]["byte"] = e.byte();
    emit(body);
    err << "distlab cbf: malformed JSON: " << one_line(e.what()) << "\n";
    return kExitParse;
  } catch (const distlab::InvalidInput& e) {
    emit(server::error_json(e));
    err << "distlab cbf: invalid input" << (e.field().empty() ? "" : " at " + e.field()) << ": "
        << one_line(e.what()) << "\n";
    return kExitInvalid;
  } catch (const std::exception& e) {
    emit(server::error_json("internal_error", e.what()));
    err << "distlab cbf: internal error: " << one_line(e.what()) << "\n";
    return kExitInternal;
  }
}

const distlab::app::RegisterCommand kRegister(
    "cbf", {"CBF-QP rollout of the Panda (GAP or Euclidean): JSON on stdin, record on stdout",
            run_cbf});

}  // namespace
