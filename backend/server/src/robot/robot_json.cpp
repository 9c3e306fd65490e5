// The robot feature's codec (distlab/server/robot_json.hpp): strict reading with field paths and
// the answers.
#include "distlab/server/robot_json.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <set>
#include <utility>

#include "distlab/gap/validator.hpp"
#include "distlab/geometry/error.hpp"
#include "distlab/geometry/parallel.hpp"
#include "distlab/server/http.hpp"
#include "distlab/server/json_fields.hpp"
#include "distlab/server/json_text.hpp"

namespace distlab::server {
namespace {

using json = nlohmann::json;

[[noreturn]] void fail(const std::string& field, const std::string& message) { throw InvalidInput(field, message); }

std::string in_quotes(const std::string& s) { return "\"" + shorten(s) + "\""; }

// {"urdf": TEXT, "meshes": {FILENAME: UPLOAD_ID}}, as far as it can be read without the uploads.
RobotUrdf read_urdf(const json& j, const Limits& limits) {
  json_check_keys(j, "robot", {"urdf", "meshes"});
  const std::string uf = "robot.urdf", mf = "robot.meshes";
  RobotUrdf out;
  out.text = json_string(json_required(j, "robot", "urdf"), uf);
  // Before the package:// scan reads the text (from_urdf checks the size too, and scans the text
  // for what its XML parser cannot take).
  out.limits = description_limits(limits);
  if (out.text.size() > limits.max_urdf_bytes)
    fail(uf, "robot.urdf has " + std::to_string(out.text.size()) + " bytes, above the limit of " + std::to_string(limits.max_urdf_bytes));
  if (const json* m = json_optional(j, "meshes")) {
    json_require_object(*m, mf);
    if (m->size() > static_cast<std::size_t>(limits.max_robot_collision_elements))
      fail(mf, "robot.meshes has " + std::to_string(m->size()) + " entries, above the limit of " +
                   std::to_string(limits.max_robot_collision_elements) + " collision elements");
    for (const auto& [filename, id] : m->items()) out.meshes[filename] = json_string(id, robot_mesh_field(filename));
  }
  return out;
}

// q: one configuration or many ([[...], ...]), each number finite with |q_i| <= kMaxCoordinate;
// a row's length and a q that is no array are the robot's to check (they name its dof).
RobotQ read_q(const json& j, std::size_t max_configurations) {
  RobotQ q;
  if (!j.is_array() || j.empty()) return q;
  q.several = j[0].is_array();
  if (q.several && j.size() > max_configurations)
    throw ApiError(413, "too_many_configurations",
                   "q has " + std::to_string(j.size()) + " configurations; at most " + std::to_string(max_configurations) + " per request",
                   "q");
  const auto row = [](const json& r, const std::string& f) {
    RobotQRow out;
    if (!r.is_array()) {
      out.not_array = r.type_name();
      return out;
    }
    out.length = r.size();
    for (std::size_t k = 0; k < r.size(); ++k) {
      try {
        out.values.push_back(json_number(r[k], json_index_path(f, k), kMaxCoordinate));
      } catch (const InvalidInput& e) {
        out.bad_field = e.field();
        out.bad_message = e.what();
        break;
      }
    }
    return out;
  };
  if (!q.several) {
    q.rows.push_back(row(j, "q"));
    return q;
  }
  for (std::size_t i = 0; i < j.size(); ++i) q.rows.push_back(row(j[i], json_index_path("q", i)));
  return q;
}

const std::string& element_link(const robot::Robot& r, int element) {
  return r.links()[static_cast<std::size_t>(r.primitives()[static_cast<std::size_t>(element)].link)];
}

// Each pair: its robot element and the obstacle, or the other element of a self pair.
json pairs_json(const robot::DistanceModel& model) {
  const robot::Robot& r = model.robot();
  json pairs = json::array();
  for (const robot::RobotPair& p : model.pairs()) {
    json e = {{"name", p.name},
              {"link", element_link(r, p.a)},
              {"element", r.primitives()[static_cast<std::size_t>(p.a)].name},
              {"self", p.self}};
    if (p.self)
      e["other"] = {{"link", element_link(r, p.b)}, {"element", r.primitives()[static_cast<std::size_t>(p.b)].name}};
    else
      e["obstacle"] = model.obstacles()[static_cast<std::size_t>(p.b)].name;
    pairs.push_back(std::move(e));
  }
  return pairs;
}

// The batch's arrays, N-leading: (N, P) and (N, P, dof | 3 | 6).
void add_batch_json(const robot::DistanceBatch& b, bool gradient, json& out) {
  const auto n = static_cast<std::size_t>(b.n), np = static_cast<std::size_t>(b.pairs), dof = static_cast<std::size_t>(b.dof);
  const auto finite = [](double v, std::size_t i, std::size_t p) {
    if (!std::isfinite(v))
      throw std::runtime_error("non-finite result for configuration " + std::to_string(i) + ", pair " + std::to_string(p) + "; refusing to report it");
    return v;
  };
  json distance = json::array(), jacobian = json::array(), obstacle_gradient = json::array(), wr = json::array(),
       wo = json::array(), overlap = json::array(), converged = json::array(), iterations = json::array();
  for (std::size_t i = 0; i < n; ++i) {
    json d = json::array(), jac = json::array(), og = json::array(), a = json::array(), o = json::array(),
         ov = json::array(), cv = json::array(), it = json::array();
    for (std::size_t p = 0; p < np; ++p) {
      const std::size_t c = i * np + p;
      d.push_back(finite(b.distance[c], i, p));
      if (gradient) {
        json g = json::array();
        for (std::size_t k = 0; k < dof; ++k) g.push_back(finite(b.jacobian[c * dof + k], i, p));
        jac.push_back(std::move(g));
        json go = json::array();
        for (std::size_t k = 0; k < 6; ++k) go.push_back(finite(b.obstacle_gradient[c * 6 + k], i, p));
        og.push_back(std::move(go));
      }
      a.push_back({finite(b.witness_robot[c * 3], i, p), finite(b.witness_robot[c * 3 + 1], i, p), finite(b.witness_robot[c * 3 + 2], i, p)});
      o.push_back({finite(b.witness_obstacle[c * 3], i, p), finite(b.witness_obstacle[c * 3 + 1], i, p), finite(b.witness_obstacle[c * 3 + 2], i, p)});
      ov.push_back(b.overlap[c] != 0);
      cv.push_back(b.converged[c] != 0);
      it.push_back(b.iterations[c]);
    }
    distance.push_back(std::move(d));
    if (gradient) {
      jacobian.push_back(std::move(jac));
      obstacle_gradient.push_back(std::move(og));
    }
    wr.push_back(std::move(a));
    wo.push_back(std::move(o));
    overlap.push_back(std::move(ov));
    converged.push_back(std::move(cv));
    iterations.push_back(std::move(it));
  }
  out["distance"] = std::move(distance);
  out["witness_robot"] = std::move(wr);
  out["witness_obstacle"] = std::move(wo);
  out["overlap"] = std::move(overlap);
  out["converged"] = std::move(converged);
  out["iterations"] = std::move(iterations);
  if (gradient) {
    out["jacobian"] = std::move(jacobian);
    out["obstacle_gradient"] = std::move(obstacle_gradient);
  }
}

}  // namespace

std::string robot_mesh_field(const std::string& filename) { return "robot.meshes[" + json(shorten(filename)).dump() + "]"; }

std::vector<robot::Obstacle> parse_robot_obstacles(const json& j, const Limits& limits) {
  if (j.is_array() && j.size() > limits.max_robot_obstacles)
    throw LimitExceeded(413, "too_many_obstacles", "obstacles", "at most " + std::to_string(limits.max_robot_obstacles) + " obstacles per request");
  json_array(j, "obstacles", limits.max_robot_obstacles, "obstacles");
  std::vector<robot::Obstacle> out;
  std::map<std::string, std::size_t> taken;  // name → the obstacle that has it
  for (std::size_t i = 0; i < j.size(); ++i) {
    const std::string f = json_index_path("obstacles", i), nf = json_key_path(f, "name");
    json_require_object(j[i], f);
    json shape = j[i];
    std::string name = "obstacle" + std::to_string(i);
    const json* given = json_optional(j[i], "name");
    if (given != nullptr) {
      name = json_string(*given, nf);
      if (name.empty() || name.size() > 64) fail(nf, "obstacle names have 1 to 64 characters");
      shape.erase("name");
    }
    if (const auto [at, fresh] = taken.emplace(name, i); !fresh)
      fail(nf, (given != nullptr ? "obstacle name " + in_quotes(name) : f + " has no name and its default " + in_quotes(name)) +
                   " is already " + json_index_path("obstacles", at->second) + "'s: names identify the pairs, give each obstacle its own");
    ShapeSpec spec = parse_shape(shape, f, limits);
    out.push_back({std::move(name), std::move(spec.shape), spec.pose, std::move(spec.options)});
  }
  return out;
}

robot::PairSelection parse_pair_selection(const json& j, const Limits& limits) {
  robot::PairSelection s;
  if (j.is_string()) {
    const std::string v = j.get<std::string>();
    if (v == "obstacles") return s;
    if (v == "self" || v == "both") {
      s.obstacles = v == "both";
      s.self = true;
      return s;
    }
  }
  if (!j.is_object())
    fail("pairs", "pairs must be \"obstacles\", \"self\", \"both\" or {\"obstacles\", \"self\", \"allow\", \"deny\"}, got " +
                      (j.is_string() ? in_quotes(j.get<std::string>()) : std::string(j.type_name())));
  json_check_keys(j, "pairs", {"obstacles", "self", "allow", "deny"});
  if (const json* v = json_optional(j, "obstacles")) s.obstacles = json_bool(*v, "pairs.obstacles");
  if (const json* v = json_optional(j, "self")) s.self = json_bool(*v, "pairs.self");
  for (auto [key, links] : {std::pair{"allow", &s.allow}, std::pair{"deny", &s.deny}}) {
    const json* v = json_optional(j, key);
    if (v == nullptr) continue;
    const std::string f = json_key_path("pairs", key);
    // At most one entry per pair of links.
    json_array(*v, f, static_cast<std::size_t>(limits.max_robot_links) * static_cast<std::size_t>(limits.max_robot_links), "link pairs");
    if (!v->empty() && !s.self) fail(f, f + " edits the self pairs: set pairs.self to true");
    for (std::size_t i = 0; i < v->size(); ++i) {
      const std::string e = json_index_path(f, i);
      if (!(*v)[i].is_array() || (*v)[i].size() != 2) fail(e, e + " must be a pair of link names [LINK, LINK]");
      links->emplace_back(json_string((*v)[i][0], json_index_path(e, 0)), json_string((*v)[i][1], json_index_path(e, 1)));
    }
  }
  return s;
}

robot::Metric parse_robot_metric(const json& j) {
  const std::string v = json_string(j, "metric");
  if (v == "gap") return robot::Metric::gap;
  if (v != "euclidean") fail("metric", "metric must be \"gap\" or \"euclidean\", got " + in_quotes(v));
  return robot::Metric::euclidean;
}

void validate_robot_bodies(const robot::DistanceModel& model, const std::string& robot_field,
                           const std::function<void()>& checkpoint) {
  if (model.metric() != robot::Metric::gap) return;
  // Each body once: robot elements and obstacles that are in a pair.
  std::set<int> elements, obstacles;
  for (const robot::RobotPair& p : model.pairs()) {
    elements.insert(p.a);
    (p.self ? elements : obstacles).insert(p.b);
  }
  const robot::DistanceModel::Workspace w = model.workspace();
  std::vector<std::pair<const GapBody*, std::string>> bodies;
  bodies.reserve(elements.size() + obstacles.size());
  for (int e : elements) bodies.emplace_back(&w.robot_gap[static_cast<std::size_t>(e)], "collision element " + in_quotes(model.robot().primitives()[static_cast<std::size_t>(e)].name));
  for (int o : obstacles) bodies.emplace_back(&model.obstacle_body(o), json_index_path("obstacles", static_cast<std::size_t>(o)));
  std::vector<ValidationReport> reports(bodies.size());
  parallel_for(bodies.size(), 0, [&](std::size_t k) {
    if (checkpoint) checkpoint();
    reports[k] = validate_p2s(bodies[k].first->p2s());
  });
  for (std::size_t k = 0; k < bodies.size(); ++k)
    if (!reports[k].ok) {
      const bool robot_element = k < elements.size();
      fail(robot_element ? robot_field : bodies[k].second, (robot_element ? bodies[k].second + ": " : "") + reports[k].message);
    }
}

RobotDistancesRequest decode_robot_distances(const Request& request, const Limits& limits) {
  const json body = parse_body(request);
  json_require_object(body, "");
  json_check_keys(body, "", {"robot", "q", "obstacles", "metric", "pairs", "params", "comment"});
  if (const json* c = json_optional(body, "comment")) json_string(*c, "comment");
  RobotDistancesRequest out;
  if (const json* mj = json_optional(body, "metric")) out.metric = parse_robot_metric(*mj);
  const json* pj = json_optional(body, "params");
  out.params = parse_params(pj != nullptr ? *pj : json(nullptr), "params", limits);
  out.pairs = parse_pair_selection(body.contains("pairs") ? body["pairs"] : json("obstacles"), limits);
  const json* given = json_optional(body, "obstacles");
  out.obstacles = parse_robot_obstacles(given != nullptr ? *given : json::array(), limits);
  const json& rj = json_required(body, "", "robot");
  if (rj.is_string())
    out.builtin = rj.get<std::string>();
  else if (rj.is_object())
    out.urdf = read_urdf(rj, limits);
  else
    fail("robot", "robot must be a built-in robot's name or {\"urdf\": TEXT, \"meshes\": {...}}");
  out.q = read_q(json_required(body, "", "q"), limits.max_robot_configurations);
  return out;
}

namespace {
// The robot's (from its URDF), then the model's (elements with their own h).
json warnings_json(const robot::DistanceModel& model) {
  json out = model.robot().warnings();
  for (const std::string& w : model.warnings()) out.push_back(w);
  return out;
}
}  // namespace

Response encode_robot_distances(const RobotDistances& result) {
  const robot::DistanceModel& model = *result.model;
  const robot::Robot& r = model.robot();
  json out = {{"robot", result.robot_name},
              {"dof", r.dof()},
              {"joint_names", r.joint_names()},
              {"metric", robot::to_string(model.metric())},
              {"n", result.batch.n},
              {"warnings", warnings_json(model)},
              {"pairs", pairs_json(model)}};
  add_batch_json(result.batch, result.gradient, out);
  return json_response(200, out);
}

Response encode_robot_list(const RobotList& list) {
  json robots = json::array();
  for (const auto& [name, r] : list.robots) {
    json elements = json::array();
    for (const robot::LinkPrimitive& p : r->primitives())
      elements.push_back({{"name", p.name}, {"link", r->links()[static_cast<std::size_t>(p.link)]}});
    robots.push_back({{"name", name},
                      {"dof", r->dof()},
                      {"joint_names", r->joint_names()},
                      {"links", r->links()},
                      {"elements", std::move(elements)},
                      {"self_pairs", r->self_pairs().size()}});
  }
  return json_response(200, {{"robots", std::move(robots)}});
}

}  // namespace distlab::server
