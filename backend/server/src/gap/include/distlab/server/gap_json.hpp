#pragma once
// The JSON schema of GAP requests and responses, shared by `distlab gap` and the HTTP service.
//
// Request:  {"a": SHAPE, "b": SHAPE, "params": PARAMS}  or  {"pairs": [{"a", "b"}, ...], "params"}
//           (+ an optional top-level "comment" string, ignored, so example files can explain
//           themselves).
// SHAPE:    {"type": "polytope", "A": [[x, y, z], ...], "b": [...]} | {"type": "box", "size"}
//           | {"type": "sphere", "radius"} | {"type": "cylinder"|"capsule", "radius", "height"}
//           | {"type": "convex_hull", "points": [[x, y, z], ...]}; optional "pose" {"position",
//           "quaternion" [w, x, y, z]}, "weights" (polytope, box, convex_hull), "rho" {"center",
//           "radius"} (shape frame).
// PARAMS:   h, k, eps, sigma, weight_margin, tol, max_iter, solver ("fixed_point" | "newton"),
//           gradient, validate; defaults are GapParams's, validate defaults to true.
// Response: one pair -> the pair's object; a batch -> {"results": [...]}. Per pair: "lambda",
//           "distance", "witness_a", "witness_b", "iterations", "converged", "overlap",
//           "euclidean" {"distance", "signed_distance", "witness_a", "witness_b"[, "gradient_a",
//           "gradient_b"][, "penetration" {"depth", "direction", "witness_a", "witness_b"}]},
//           signed_distance = -penetration.depth when the shapes overlap,
//           [, "gradient_a", "gradient_b" (6 numbers: d distance / d (v, ω), world frame)]
//           [, "validation" {"a": {"ok", "max_eigenvalue", "samples"}, "b": {...}}].
// Errors:   {"error": {"code", "message", "field"}}; "field" is a path such as "pairs[2].b.size[1]"
//           ("" for the request as a whole).
#include <cstddef>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "distlab/gap/distance.hpp"
#include "distlab/geometry/error.hpp"
#include "distlab/server/config.hpp"
#include "distlab/server/json_fields.hpp"
#include "distlab/server/json_text.hpp"

namespace distlab::server {

// The codec is the one place that checks a GAP request, against the limits table (config.hpp:
// max_gap_pairs, max_gap_iterations, max_polytope_rows, max_hull_points; the JSON text's own
// limits are json_text.hpp's). The CLI and Python pass its defaults, the server its own. Past a
// limit: LimitExceeded (http.hpp) naming the field.

// A shape of the request, parsed and checked (not yet built into P2S functions).
struct ShapeSpec {
  Shape shape;
  Pose pose;
  P2SOptions options;
};
ShapeSpec parse_shape(const nlohmann::json& j, const std::string& field, const Limits& limits = {});

struct GapRequestParams {
  GapParams params;
  bool validate = true;  // run validate_p2s on every distinct shape and refuse on failure
};
// Also runs check_params. `j` may be null (all defaults). max_iter above max_gap_iterations: 422
// over_budget.
GapRequestParams parse_params(const nlohmann::json& j, const std::string& field = "params", const Limits& limits = {});

// Runs a whole request; throws InvalidInput (with the field) on bad input and
// std::runtime_error on an internal failure (e.g. a non-finite result, which is never emitted).
// `checkpoint` (if given) is called between stages and between chunks of pairs; it may throw
// to stop the work (the service's time limit).
// At most max_gap_pairs pairs (413 too_many_pairs, checked before anything else of the request).
nlohmann::json run_gap_request(const nlohmann::json& request, const std::function<void()>& checkpoint = {},
                               const Limits& limits = {});

// Encodes one result (validation reports are added by run_gap_request). `pen`: the Euclidean
// penetration of an overlapping pair (euclidean.penetration, and signed_distance = -depth).
nlohmann::json encode_result(const GapResult& r, bool gradient,
                             const std::optional<Penetration>& pen = std::nullopt);

// {"error": {"code": "invalid_input", "message", "field"}}.
nlohmann::json error_json(const InvalidInput& e);
nlohmann::json error_json(const std::string& code, const std::string& message,
                          const std::string& field = "");

}  // namespace distlab::server
