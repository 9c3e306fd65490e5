// `distlab gap`: one GAP request (JSON) on stdin, the response (JSON) on stdout.
// Exit codes: 0 ok, 2 invalid input or usage, 65 malformed JSON, 70 internal error; on any error
// the JSON error body goes to stdout (so scripts always get JSON) and one line to stderr.
#include <string>
#include <vector>

#include "command.hpp"
#include "distlab/server/gap_json.hpp"
#include "json_command.hpp"

namespace {

namespace server = distlab::server;

constexpr const char* kHelp = R"(usage: distlab gap [--pretty] < request.json

Reads one JSON request on stdin, writes the JSON response on stdout (compact; --pretty indents).

request   {"a": SHAPE, "b": SHAPE, "params": PARAMS}
          {"pairs": [{"a": SHAPE, "b": SHAPE}, ...], "params": PARAMS}   (at most 2000: max_gap_pairs)
          an optional top-level "comment" string is ignored
SHAPE     {"type": "polytope", "A": [[x,y,z], ...], "b": [...]}         (at most 1000: max_polytope_rows)
          {"type": "box", "size": [x, y, z]}                            (full edge lengths)
          {"type": "sphere", "radius": r}
          {"type": "cylinder", "radius": r, "height": l}                (full length along z)
          {"type": "capsule", "radius": r, "height": l}                 (core segment along z)
          {"type": "convex_hull", "points": [[x,y,z], ...]}             (at most 100000: max_hull_points)
          optional: "pose": {"position": [x,y,z], "quaternion": [w,x,y,z]} (normalised),
                    "weights": [...] (polytope, box, convex_hull: one per half-space),
                    "rho": {"center": [x,y,z], "radius": R} (shape frame, must cover the shape)
PARAMS    h (0.1), k (2), eps (0.01), sigma (0.98995), weight_margin (0.01), tol (1e-10),
          max_iter (0 = solver default), solver ("newton" | "fixed_point"), gradient (true),
          validate (true: check Property 2 on every shape and refuse if it fails)
response  "lambda", "distance", "witness_a", "witness_b", "iterations", "converged", "overlap",
          "euclidean": {"distance", "witness_a", "witness_b"[, "gradient_a", "gradient_b"]},
          with gradient: "gradient_a", "gradient_b" (d distance / d (v, w), world frame),
          with validate: "validation": {"a": {"ok", "max_eigenvalue", "samples"}, "b": ...};
          a batch answers {"results": [...]}
errors    {"error": {"code", "message", "field"}}; field is a path such as "pairs[2].b.size[1]"
exit      0 ok, 2 invalid input ("invalid_input"), 65 malformed JSON ("parse_error"),
          70 internal error ("internal_error")
)";

int run_gap(const std::vector<std::string>& args, std::istream& in, std::ostream& out,
            std::ostream& err) {
  return distlab::app::run_json_command(
      {"gap", kHelp, {}}, args, in, out, err,
      [](const nlohmann::json& request, const auto&) { return server::run_gap_request(request); });
}

const distlab::app::RegisterCommand kRegister(
    "gap", {"GAP differentiable distance of shape pairs: JSON on stdin, JSON on stdout", run_gap});

}  // namespace
