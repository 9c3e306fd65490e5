// GAP requests as JSON: strict parsing with field paths, running, and encoding the results.
#include "distlab/server/gap_json.hpp"

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <map>
#include <optional>
#include <utility>
#include <vector>

#include "distlab/gap/validator.hpp"
#include "distlab/geometry/parallel.hpp"
#include "distlab/geometry/polytope.hpp"
#include "distlab/server/http.hpp"
#include "distlab/server/json_fields.hpp"

namespace distlab::server {
namespace {

using json = nlohmann::json;

// ---------------------------------------------------------------------------------------------
// Typed readers (json_fields.hpp) name the field of every failure; the schema's own checks too.

[[noreturn]] void fail(const std::string& field, const std::string& message) {
  throw InvalidInput(field, message);
}

std::string type_of(const json& j) { return j.type_name(); }

Polytope checked_extent(Polytope P, const std::string& field) {
  for (const Vec3& v : P.vertices)
    if (!(v.cwiseAbs().maxCoeff() <= kMaxCoordinate))
      fail(field, "polytope reaches beyond the coordinate limit of " + json(kMaxCoordinate).dump());
  return P;
}

Polytope parse_polytope(const json& j, const std::string& field, const Limits& limits) {
  const std::string af = json_key_path(field, "A"), bf = json_key_path(field, "b");
  const json& A = json_array(json_required(j, field, "A"), af, limits.max_polytope_rows, "rows");
  const json& b = json_array(json_required(j, field, "b"), bf, limits.max_polytope_rows, "offsets");
  MatX3 Am(static_cast<Eigen::Index>(A.size()), 3);
  for (std::size_t i = 0; i < A.size(); ++i)
    Am.row(static_cast<Eigen::Index>(i)) = json_vec3(A[i], json_index_path(af, i)).transpose();
  VecX bv(static_cast<Eigen::Index>(b.size()));
  for (std::size_t i = 0; i < b.size(); ++i)
    bv[static_cast<Eigen::Index>(i)] = json_number(b[i], json_index_path(bf, i));
  return checked_extent(make_polytope(Am, bv, field), field);
}

Polytope parse_hull(const json& j, const std::string& field, const Limits& limits) {
  const std::string pf = json_key_path(field, "points");
  const json& pts = json_array(json_required(j, field, "points"), pf, limits.max_hull_points, "points");
  std::vector<Vec3> points;
  points.reserve(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i)
    points.push_back(json_vec3(pts[i], json_index_path(pf, i), kMaxCoordinate));
  Polytope P = polytope_from_points(points, field);
  if (static_cast<std::size_t>(P.rows()) > limits.max_polytope_rows)
    fail(pf, "the hull has " + std::to_string(P.rows()) + " facets, above the limit of " +
                 std::to_string(limits.max_polytope_rows));
  return P;
}

}  // namespace

// ---------------------------------------------------------------------------------------------

ShapeSpec parse_shape(const json& j, const std::string& field, const Limits& limits) {
  json_require_object(j, field);
  const std::string tf = json_key_path(field, "type");
  const json& type_j = json_required(j, field, "type");
  if (!type_j.is_string()) fail(tf, "expected a string, got " + type_of(type_j));
  const std::string type = type_j.get<std::string>();

  ShapeSpec spec;
  if (type == "polytope") {
    json_check_keys(j, field, {"type", "A", "b", "pose", "weights", "rho"});
    spec.shape = parse_polytope(j, field, limits);
  } else if (type == "convex_hull") {
    json_check_keys(j, field, {"type", "points", "pose", "weights", "rho"});
    spec.shape = parse_hull(j, field, limits);
  } else if (type == "box") {
    json_check_keys(j, field, {"type", "size", "pose", "weights", "rho"});
    spec.shape = Box{json_vec<3>(json_required(j, field, "size"), json_key_path(field, "size"), kMaxCoordinate, true)};
  } else if (type == "sphere") {
    json_check_keys(j, field, {"type", "radius", "pose", "rho"});
    spec.shape = Sphere{json_positive(json_required(j, field, "radius"), json_key_path(field, "radius"), kMaxCoordinate)};
  } else if (type == "cylinder" || type == "capsule") {
    json_check_keys(j, field, {"type", "radius", "height", "pose", "rho"});
    const double r = json_positive(json_required(j, field, "radius"), json_key_path(field, "radius"), kMaxCoordinate);
    const double h = json_positive(json_required(j, field, "height"), json_key_path(field, "height"), kMaxCoordinate);
    if (type == "cylinder")
      spec.shape = Cylinder{r, h};
    else
      spec.shape = Capsule{r, h};
  } else {
    fail(tf, "unknown shape type \"" + shorten(type) +
                 "\" (known: polytope, box, sphere, cylinder, capsule, convex_hull)");
  }

  if (const auto it = j.find("pose"); it != j.end())
    spec.pose = json_pose(*it, json_key_path(field, "pose"));
  if (const auto it = j.find("weights"); it != j.end()) {
    const std::string wf = json_key_path(field, "weights");
    const json& w = json_array(*it, wf, limits.max_polytope_rows, "weights");
    VecX weights(static_cast<Eigen::Index>(w.size()));
    for (std::size_t i = 0; i < w.size(); ++i)
      weights[static_cast<Eigen::Index>(i)] = json_number(w[i], json_index_path(wf, i));
    spec.options.weights = weights;  // count and sign are checked by PointToSet
  }
  if (const auto it = j.find("rho"); it != j.end()) {
    const std::string rf = json_key_path(field, "rho");
    json_require_object(*it, rf);
    json_check_keys(*it, rf, {"center", "radius"});
    const Vec3 c = json_vec3(json_required(*it, rf, "center"), json_key_path(rf, "center"), kMaxCoordinate);
    const double r = json_positive(json_required(*it, rf, "radius"), json_key_path(rf, "radius"), kMaxCoordinate);
    spec.options.rho = Ball{c, r};
  }
  return spec;
}

GapRequestParams parse_params(const json& j, const std::string& field, const Limits& limits) {
  GapRequestParams out;
  if (j.is_null()) {
    check_params(out.params);
    return out;
  }
  json_require_object(j, field);
  json_check_keys(j, field,
                  {"h", "k", "eps", "sigma", "weight_margin", "tol", "max_iter", "solver", "gradient",
                   "validate"});
  GapParams& p = out.params;
  const auto get = [&](const char* key) { return json_optional(j, key); };
  const auto f = [&](const char* key) { return json_key_path(field, key); };
  if (auto v = get("h")) p.h = json_number(*v, f("h"));
  if (auto v = get("k")) p.k = json_integer(*v, f("k"));
  if (auto v = get("eps")) p.eps = json_number(*v, f("eps"));
  if (auto v = get("sigma")) p.sigma = json_number(*v, f("sigma"));
  if (auto v = get("weight_margin")) p.weight_margin = json_number(*v, f("weight_margin"));
  if (auto v = get("tol")) p.tol = json_number(*v, f("tol"));
  if (auto v = get("max_iter")) {
    p.max_iter = json_integer(*v, f("max_iter"));
    if (p.max_iter > limits.max_gap_iterations)
      throw LimitExceeded(422, "over_budget", f("max_iter"),
                          f("max_iter") + " must be at most " + std::to_string(limits.max_gap_iterations) + " on this server");
  }
  if (auto v = get("solver")) {
    if (!v->is_string())
      fail(f("solver"), "expected \"fixed_point\" or \"newton\", got " + type_of(*v));
    const std::string s = v->get<std::string>();
    if (s == "newton")
      p.solver = GapSolver::newton;
    else if (s == "fixed_point")
      p.solver = GapSolver::fixed_point;
    else
      fail(f("solver"), "unknown solver \"" + shorten(s) + "\" (expected fixed_point or newton)");
  }
  if (auto v = get("gradient")) p.gradient = json_bool(*v, f("gradient"));
  if (auto v = get("validate")) out.validate = json_bool(*v, f("validate"));
  check_params(p);
  return out;
}

json encode_result(const GapResult& r, bool gradient, const std::optional<Penetration>& pen) {
  json euclid = {{"distance", r.euclidean.distance},
                 {"signed_distance", pen ? -pen->depth : r.euclidean.distance},
                 {"witness_a", vec_json(r.euclidean.witness_a)},
                 {"witness_b", vec_json(r.euclidean.witness_b)}};
  if (pen)
    euclid["penetration"] = {{"depth", pen->depth},
                             {"direction", vec_json(pen->direction)},
                             {"witness_a", vec_json(pen->witness_a)},
                             {"witness_b", vec_json(pen->witness_b)}};
  json out = {{"lambda", r.lambda},
              {"distance", r.distance},
              {"witness_a", vec_json(r.witness_a)},
              {"witness_b", vec_json(r.witness_b)},
              {"iterations", r.iterations},
              {"converged", r.converged},
              {"overlap", r.overlap}};
  if (gradient) {
    euclid["gradient_a"] = vec_json(r.euclidean.gradient_a);
    euclid["gradient_b"] = vec_json(r.euclidean.gradient_b);
    out["gradient_a"] = vec_json(r.gradient_a);
    out["gradient_b"] = vec_json(r.gradient_b);
  }
  out["euclidean"] = std::move(euclid);
  return out;
}

namespace {

// Every shape instance of a request in request order (a, b of each pair), with its path.
std::vector<std::pair<const json*, std::string>> shape_instances(const json& request, bool batch, const Limits& limits) {
  std::vector<std::pair<const json*, std::string>> instances;
  if (!batch) {
    instances.emplace_back(&json_required(request, "", "a"), "a");
    instances.emplace_back(&json_required(request, "", "b"), "b");
    return instances;
  }
  const json& pairs = json_array(request["pairs"], "pairs", limits.max_gap_pairs, "pairs");
  instances.reserve(2 * pairs.size());
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const std::string pf = json_index_path("pairs", i);
    json_require_object(pairs[i], pf);
    json_check_keys(pairs[i], pf, {"a", "b"});
    instances.emplace_back(&json_required(pairs[i], pf, "a"), json_key_path(pf, "a"));
    instances.emplace_back(&json_required(pairs[i], pf, "b"), json_key_path(pf, "b"));
  }
  return instances;
}

// The distinct shapes (by their JSON without the pose), each parsed once on all cores; the lowest
// failing index wins, so errors are the same as a sequential run's.
void decode_shapes(const std::vector<std::pair<const json*, std::string>>& instances, const Limits& limits,
                   GapDistanceRequest& out) {
  std::vector<std::size_t> first_instance;  // per distinct shape
  std::map<std::string, std::size_t> seen;
  out.instances.resize(instances.size());
  for (std::size_t i = 0; i < instances.size(); ++i) {
    const auto& [j, field] = instances[i];
    json_require_object(*j, field);
    json key_json = *j;
    key_json.erase("pose");
    const auto [it, inserted] = seen.emplace(key_json.dump(), first_instance.size());
    if (inserted) first_instance.push_back(i);
    out.instances[i].shape = it->second;
  }
  std::vector<std::optional<ShapeSpec>> specs(first_instance.size());
  parallel_for(specs.size(), 0, [&](std::size_t k) {
    const auto& [j, field] = instances[first_instance[k]];
    specs[k] = parse_shape(*j, field, limits);
  });
  for (std::size_t k = 0; k < specs.size(); ++k) {
    out.shapes.push_back(std::move(*specs[k]));
    out.shape_fields.push_back(instances[first_instance[k]].second);
  }
  for (std::size_t i = 0; i < instances.size(); ++i) {
    const auto& [j, field] = instances[i];
    if (const auto pit = j->find("pose"); pit != j->end())
      out.instances[i].pose = json_pose(*pit, json_key_path(field, "pose"));
  }
}

json validation_json(const ValidationReport& rep) {
  return json{{"ok", rep.ok}, {"max_eigenvalue", rep.max_eigenvalue}, {"samples", rep.samples}};
}

}  // namespace

GapDistanceRequest decode_gap_request(const json& request, const Limits& limits) {
  json_require_object(request, "");
  if (const auto it = request.find("pairs"); it != request.end() && it->is_array() && it->size() > limits.max_gap_pairs)
    throw LimitExceeded(413, "too_many_pairs", "pairs", "at most " + std::to_string(limits.max_gap_pairs) + " pairs per request");
  json_check_keys(request, "", {"a", "b", "pairs", "params", "comment"});
  if (const auto it = request.find("comment"); it != request.end() && !it->is_string())
    fail("comment", "expected a string, got " + type_of(*it));
  GapDistanceRequest out;
  out.batch = request.contains("pairs");
  if (out.batch)
    for (const char* k : {"a", "b"})
      if (request.contains(k)) fail(k, "give either \"a\" and \"b\" or \"pairs\", not both");
  const auto params_it = request.find("params");
  out.params = parse_params(params_it == request.end() ? json() : *params_it, "params", limits);
  decode_shapes(shape_instances(request, out.batch, limits), limits, out);
  return out;
}

json encode_gap_results(const GapDistanceResults& results) {
  json out = json::array();
  for (std::size_t i = 0; i < results.results.size(); ++i) {
    json r = encode_result(results.results[i], results.gradient, results.penetrations[i]);
    if (!results.validation.empty())
      r["validation"] = {{"a", validation_json(results.validation[i].first)},
                         {"b", validation_json(results.validation[i].second)}};
    out.push_back(std::move(r));
  }
  if (results.batch) return json{{"results", std::move(out)}};
  return std::move(out[0]);
}

json run_gap_request(const json& request, const std::function<void()>& checkpoint, const Limits& limits) {
  return encode_gap_results(compute_gap_request(decode_gap_request(request, limits), checkpoint));
}

json error_json(const InvalidInput& e) { return error_json("invalid_input", e.what(), e.field()); }

json error_json(const std::string& code, const std::string& message, const std::string& field) {
  return json{{"error", {{"code", code}, {"message", message}, {"field", field}}}};
}

}  // namespace distlab::server
