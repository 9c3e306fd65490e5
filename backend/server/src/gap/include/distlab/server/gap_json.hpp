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
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "distlab/gap/distance.hpp"
#include "distlab/gap/validator.hpp"
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

// A distance request, decoded and checked against the limits: every distinct shape once (the same
// JSON apart from the pose; a hull or a 1000-row polytope is costly to build and check), and the
// two instances of each pair in request order.
struct GapShapeInstance {
  std::size_t shape = 0;  // index into GapDistanceRequest::shapes
  Pose pose;
};
struct GapDistanceRequest {
  bool batch = false;  // "pairs" (answered {"results": [...]}) rather than "a" and "b"
  GapRequestParams params;
  std::vector<ShapeSpec> shapes;
  std::vector<std::string> shape_fields;    // where each distinct shape first appears ("pairs[2].b")
  std::vector<GapShapeInstance> instances;  // a, b of pair 0, a, b of pair 1, ...
};
// Throws InvalidInput naming the field; past max_gap_pairs 413 too_many_pairs, checked before
// anything else of the request.
GapDistanceRequest decode_gap_request(const nlohmann::json& request, const Limits& limits = {});

// Each pair's result, finite (a non-finite one is std::runtime_error, never reported), with the
// Euclidean penetration of an overlapping pair and, when params.validate, Property 2 of its shapes.
struct GapDistanceResults {
  bool batch = false;
  bool gradient = true;
  std::vector<GapResult> results;
  std::vector<std::optional<Penetration>> penetrations;
  std::vector<std::pair<ValidationReport, ValidationReport>> validation;  // empty unless validated
};
// Builds each distinct shape once and checks Property 2 (InvalidInput naming the shape when it
// fails), then solves the pairs. `checkpoint` (if given) is called between stages and between
// chunks of pairs; it may throw to stop the work (the service's time limit).
GapDistanceResults compute_gap_request(const GapDistanceRequest& request, const std::function<void()>& checkpoint = {});

// The answer: one pair -> the pair's object; a batch -> {"results": [...]}.
nlohmann::json encode_gap_results(const GapDistanceResults& results);

// decode, compute, encode: the CLI's and the Python bindings' whole request.
nlohmann::json run_gap_request(const nlohmann::json& request, const std::function<void()>& checkpoint = {},
                               const Limits& limits = {});

// Encodes one result (validation reports are added by encode_gap_results). `pen`: the Euclidean
// penetration of an overlapping pair (euclidean.penetration, and signed_distance = -depth).
nlohmann::json encode_result(const GapResult& r, bool gradient,
                             const std::optional<Penetration>& pen = std::nullopt);

// {"error": {"code": "invalid_input", "message", "field"}}.
nlohmann::json error_json(const InvalidInput& e);
nlohmann::json error_json(const std::string& code, const std::string& message,
                          const std::string& field = "");

}  // namespace distlab::server
