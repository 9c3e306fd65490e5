// The robot feature's codec (distlab/server/robot_json.hpp): strict reading with field paths, the
// batched run in chunks, and the answer.
#include "distlab/server/robot_json.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <span>
#include <utility>

#include "distlab/gap/validator.hpp"
#include "distlab/geometry/error.hpp"
#include "distlab/geometry/parallel.hpp"
#include "distlab/server/http.hpp"
#include "distlab/server/json_fields.hpp"
#include "distlab/server/json_text.hpp"
#include "distlab/server/request_params.hpp"

namespace distlab::server {
namespace {

using json = nlohmann::json;
namespace fs = std::filesystem;

// Work between two checks of the time limit: 4096 pairs of a Newton solve at its iteration limit
// (100); a fixed-point solve may take 1000 times more per pair, so its chunks hold that many fewer
// pairs. At least one configuration: the library checks nothing within one.
constexpr double kChunkIterations = 4096.0 * 100;

[[noreturn]] void fail(const std::string& field, const std::string& message) { throw InvalidInput(field, message); }

std::string in_quotes(const std::string& s) { return "\"" + shorten(s) + "\""; }

// `"robot.meshes[\"x.stl\"]"`: a map entry's field (the key as a JSON string, shortened).
std::string entry_path(const std::string& base, const std::string& key) { return base + "[" + json(shorten(key)).dump() + "]"; }

bool name_char(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.' || c == ':';
}

// The built-in robots' names: NAME.urdf in robots_dir, sorted.
std::vector<std::string> builtin_names(const std::string& robots_dir) {
  std::vector<std::string> names;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(robots_dir, ec))
    if (e.path().extension() == ".urdf" && valid_name(e.path().stem().string())) names.push_back(e.path().stem().string());
  std::sort(names.begin(), names.end());
  return names;
}

// The built-in robot NAME (robots_dir/NAME.urdf, parsed once), or InvalidInput naming `field`.
std::shared_ptr<const robot::Robot> builtin_robot(const std::string& name, const std::string& robots_dir,
                                                  const std::string& field) {
  const std::vector<std::string> names = builtin_names(robots_dir);
  if (std::find(names.begin(), names.end(), name) == names.end()) {
    std::string known;
    for (const std::string& k : names) known += (known.empty() ? "" : ", ") + k;
    fail(field, "unknown robot " + in_quotes(name) + " (built-in: " + known + "; or give {\"urdf\": TEXT})");
  }
  try {
    return robot::Robot::load((fs::path(robots_dir) / (name + ".urdf")).string(), field);
  } catch (const InvalidInput& e) {  // a broken asset is the server's fault, not the caller's
    throw std::runtime_error("robot file " + name + ".urdf: " + e.what());
  }
}

// {"urdf": TEXT, "meshes": {FILENAME: UPLOAD_ID}}: the URDF with its meshes read from the
// session's uploads (parsed when they were uploaded, in the isolated child).
std::shared_ptr<const robot::Robot> urdf_robot(const json& j, const RobotSources& sources) {
  json_check_keys(j, "robot", {"urdf", "meshes"});
  const std::string uf = "robot.urdf", mf = "robot.meshes";
  const std::string xml = json_string(json_required(j, "robot", "urdf"), uf);
  // Before the package:// scan below reads the text (from_urdf checks the size too, and scans the
  // text for what its XML parser cannot take).
  if (xml.size() > robot::kMaxUrdfBytes)
    fail(uf, "robot.urdf has " + std::to_string(xml.size()) + " bytes, above the limit of " + std::to_string(robot::kMaxUrdfBytes));

  // Every entry names an upload of this session, looked up before the URDF is parsed.
  std::map<std::string, std::shared_ptr<const Upload>> meshes;
  if (const json* m = json_optional(j, "meshes")) {
    json_require_object(*m, mf);
    if (m->size() > static_cast<std::size_t>(robot::kMaxCollisionElements))
      fail(mf, "robot.meshes has " + std::to_string(m->size()) + " entries, above the limit of " +
                   std::to_string(robot::kMaxCollisionElements) + " collision elements");
    for (const auto& [filename, id] : m->items()) {
      const std::string f = entry_path(mf, filename);
      meshes[filename] = sources.upload(json_string(id, f), f);
    }
  }

  // The URDF's filenames are keys of `meshes`: a relative one needs some folder and a package://
  // one its package for resolve_mesh_path to pass it on; nothing is read from either.
  robot::UrdfOptions options;
  options.base_dir = "/upload";
  for (std::size_t at = xml.find("package://"); at != std::string::npos; at = xml.find("package://", at + 1)) {
    const std::size_t begin = at + 10;
    std::size_t end = begin;
    while (end < xml.size() && name_char(xml[end])) ++end;
    options.package_dirs.emplace(xml.substr(begin, end - begin), "/upload");
  }
  std::set<std::string> read;
  std::string reading;  // the filename whose hull is being made (its defects name its entry)
  options.read_mesh = [&](const std::string& filename, const std::string&, const std::string&) {
    const auto it = meshes.find(filename);
    if (it == meshes.end())
      fail(mf, "the URDF's mesh " + in_quotes(filename) + " has no upload: add " + json(shorten(filename)).dump() +
                   ": UPLOAD_ID to robot.meshes (POST /api/kelvin/uploads)");
    read.insert(filename);
    reading = filename;
    return it->second->surface;
  };
  std::shared_ptr<const robot::Robot> robot;
  try {
    robot = robot::Robot::from_urdf(xml, uf, options);
  } catch (const InvalidInput& e) {
    // The library names the URDF element in the message. A defect of the mesh just read (flat,
    // too many facets: the message names it) is its upload's; the rest is the URDF's.
    if (e.field() == mf) throw;
    const std::string what = e.what();
    if (!reading.empty() && what.find("mesh \"" + reading.substr(0, 200) + "\"") != std::string::npos)
      throw InvalidInput(entry_path(mf, reading), what);
    throw InvalidInput(uf, what);
  }
  for (const auto& [filename, upload] : meshes)
    if (!read.count(filename))
      fail(entry_path(mf, filename), "the URDF has no <mesh filename=" + in_quotes(filename) + ">");
  return robot;
}

// q: one configuration (dof numbers) or many ([[dof numbers], ...]), finite, |q_i| <= kMaxCoordinate.
std::vector<double> parse_q(const json& j, int dof, std::size_t max_configurations, int& n) {
  if (!j.is_array() || j.empty())
    fail("q", "q must be one configuration [" + std::to_string(dof) + " numbers] or several [[...], ...]");
  const bool many = j[0].is_array();
  if (many && j.size() > max_configurations)
    throw ApiError(413, "too_many_configurations",
                   "q has " + std::to_string(j.size()) + " configurations; at most " + std::to_string(max_configurations) + " per request",
                   "q");
  std::vector<double> q;
  q.reserve((many ? j.size() : 1) * static_cast<std::size_t>(dof));
  const auto row = [&](const json& r, const std::string& f) {
    const Eigen::VectorXd v = json_vecx(r, f, dof, kMaxCoordinate);
    q.insert(q.end(), v.data(), v.data() + v.size());
  };
  if (!many) {
    row(j, "q");
    n = 1;
    return q;
  }
  for (std::size_t i = 0; i < j.size(); ++i) row(j[i], json_index_path("q", i));
  n = static_cast<int>(j.size());
  return q;
}

const std::string& element_link(const robot::Robot& r, int element) {
  return r.links()[static_cast<std::size_t>(r.primitives()[static_cast<std::size_t>(element)].link)];
}

}  // namespace

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

robot::PairSelection parse_pair_selection(const json& j) {
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
    json_array(*v, f, static_cast<std::size_t>(robot::kMaxLinks) * robot::kMaxLinks, "link pairs");
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

RobotDistancesRequest parse_robot_distances(const json& body, const RobotSources& sources, const Limits& limits) {
  json_require_object(body, "");
  json_check_keys(body, "", {"robot", "q", "obstacles", "metric", "pairs", "params", "comment"});
  if (const json* c = json_optional(body, "comment")) json_string(*c, "comment");
  const json* mj = json_optional(body, "metric");
  const robot::Metric metric = mj != nullptr ? parse_robot_metric(*mj) : robot::Metric::gap;
  const json* pj = json_optional(body, "params");
  const GapRequestParams params = parse_params(pj != nullptr ? *pj : json(nullptr), "params", limits);
  const robot::PairSelection pairs = parse_pair_selection(body.contains("pairs") ? body["pairs"] : json("obstacles"));
  const json none = json::array();
  const json* given = json_optional(body, "obstacles");
  const json& oj = given != nullptr ? *given : none;
  std::vector<robot::Obstacle> obstacles = parse_robot_obstacles(oj, limits);

  RobotDistancesRequest out;
  const json& rj = json_required(body, "", "robot");
  std::shared_ptr<const robot::Robot> robot;
  if (rj.is_string()) {
    robot = builtin_robot(rj.get<std::string>(), sources.robots_dir, "robot");
    out.robot_name = rj.get<std::string>();
    out.robot_field = "robot";
  } else if (rj.is_object()) {
    robot = urdf_robot(rj, sources);
    out.robot_name = robot->name();
    out.robot_field = "robot.urdf";
  } else {
    fail("robot", "robot must be a built-in robot's name or {\"urdf\": TEXT, \"meshes\": {...}}");
  }
  out.q = parse_q(json_required(body, "", "q"), robot->dof(), limits.max_robot_configurations, out.n);
  out.validate = params.validate;
  out.gradient = params.params.gradient;
  // Throws InvalidInput naming "params.*", "obstacles[i]..." or "pairs.allow[i]" / "pairs.deny[i]".
  out.model = std::make_shared<const robot::DistanceModel>(std::move(robot), std::move(obstacles), metric, params.params, pairs);
  const std::size_t evaluations = static_cast<std::size_t>(out.n) * out.model->pairs().size();
  if (evaluations > limits.max_robot_pair_evaluations)
    throw ApiError(413, "too_many_evaluations",
                   std::to_string(out.n) + " configurations × " + std::to_string(out.model->pairs().size()) +
                       " pairs is above this server's " + std::to_string(limits.max_robot_pair_evaluations) +
                       " per request; send fewer configurations or pairs",
                   "q");
  return out;
}

robot::DistanceBatch run_robot_distances(const RobotDistancesRequest& request, const std::function<void()>& checkpoint) {
  const robot::DistanceModel& model = *request.model;
  const auto check = [&] {
    if (checkpoint) checkpoint();
  };
  const auto& pairs = model.pairs();
  if (request.validate) validate_robot_bodies(model, request.robot_field, check);

  const int dof = model.dof();
  const std::size_t np = pairs.size();
  const double per_pair = model.metric() == robot::Metric::gap ? model.params().iteration_limit() : 100;
  const auto chunk = static_cast<std::size_t>(std::max(1.0, std::floor(kChunkIterations / (static_cast<double>(std::max<std::size_t>(1, np)) * per_pair))));
  robot::DistanceBatch all;
  all.n = request.n;
  all.pairs = static_cast<int>(np);
  all.dof = dof;
  std::vector<GapTrack> tracks;
  for (std::size_t begin = 0; begin < static_cast<std::size_t>(request.n); begin += chunk) {
    check();
    const std::size_t count = std::min(chunk, static_cast<std::size_t>(request.n) - begin);
    robot::BatchOptions options;
    options.warm_start = tracks;  // the previous chunk's last solutions
    robot::DistanceBatch b = robot::distances(
        model, std::span<const double>(request.q).subspan(begin * static_cast<std::size_t>(dof), count * static_cast<std::size_t>(dof)),
        static_cast<int>(count), options);
    const auto append = [](auto& to, const auto& from) { to.insert(to.end(), from.begin(), from.end()); };
    append(all.distance, b.distance);
    append(all.jacobian, b.jacobian);
    append(all.witness_robot, b.witness_robot);
    append(all.witness_obstacle, b.witness_obstacle);
    append(all.overlap, b.overlap);
    append(all.converged, b.converged);
    append(all.iterations, b.iterations);
    tracks = std::move(b.tracks);
  }
  return all;
}

json encode_robot_distances(const RobotDistancesRequest& request, const robot::DistanceBatch& b) {
  const robot::DistanceModel& model = *request.model;
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
  const auto n = static_cast<std::size_t>(b.n), np = static_cast<std::size_t>(b.pairs), dof = static_cast<std::size_t>(b.dof);
  const auto finite = [](double v, std::size_t i, std::size_t p) {
    if (!std::isfinite(v))
      throw std::runtime_error("non-finite result for configuration " + std::to_string(i) + ", pair " + std::to_string(p) + "; refusing to report it");
    return v;
  };
  json distance = json::array(), jacobian = json::array(), wr = json::array(), wo = json::array(), overlap = json::array(),
       converged = json::array(), iterations = json::array();
  for (std::size_t i = 0; i < n; ++i) {
    json d = json::array(), jac = json::array(), a = json::array(), o = json::array(), ov = json::array(), cv = json::array(),
         it = json::array();
    for (std::size_t p = 0; p < np; ++p) {
      const std::size_t c = i * np + p;
      d.push_back(finite(b.distance[c], i, p));
      if (request.gradient) {
        json g = json::array();
        for (std::size_t k = 0; k < dof; ++k) g.push_back(finite(b.jacobian[c * dof + k], i, p));
        jac.push_back(std::move(g));
      }
      a.push_back({finite(b.witness_robot[c * 3], i, p), finite(b.witness_robot[c * 3 + 1], i, p), finite(b.witness_robot[c * 3 + 2], i, p)});
      o.push_back({finite(b.witness_obstacle[c * 3], i, p), finite(b.witness_obstacle[c * 3 + 1], i, p), finite(b.witness_obstacle[c * 3 + 2], i, p)});
      ov.push_back(b.overlap[c] != 0);
      cv.push_back(b.converged[c] != 0);
      it.push_back(b.iterations[c]);
    }
    distance.push_back(std::move(d));
    if (request.gradient) jacobian.push_back(std::move(jac));
    wr.push_back(std::move(a));
    wo.push_back(std::move(o));
    overlap.push_back(std::move(ov));
    converged.push_back(std::move(cv));
    iterations.push_back(std::move(it));
  }
  json out = {{"robot", request.robot_name},
              {"dof", r.dof()},
              {"joint_names", r.joint_names()},
              {"metric", robot::to_string(model.metric())},
              {"n", b.n},
              {"warnings", r.warnings()},
              {"pairs", std::move(pairs)},
              {"distance", std::move(distance)},
              {"witness_robot", std::move(wr)},
              {"witness_obstacle", std::move(wo)},
              {"overlap", std::move(overlap)},
              {"converged", std::move(converged)},
              {"iterations", std::move(iterations)}};
  if (request.gradient) out["jacobian"] = std::move(jacobian);
  return out;
}

json robots_json(const std::string& robots_dir) {
  json list = json::array();
  for (const std::string& name : builtin_names(robots_dir)) {
    const std::shared_ptr<const robot::Robot> r = builtin_robot(name, robots_dir, "robot");
    json elements = json::array();
    for (const robot::LinkPrimitive& p : r->primitives())
      elements.push_back({{"name", p.name}, {"link", r->links()[static_cast<std::size_t>(p.link)]}});
    list.push_back({{"name", name},
                    {"dof", r->dof()},
                    {"joint_names", r->joint_names()},
                    {"links", r->links()},
                    {"elements", std::move(elements)},
                    {"self_pairs", r->self_pairs().size()}});
  }
  return {{"robots", std::move(list)}};
}

}  // namespace distlab::server
