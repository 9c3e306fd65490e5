// A scenario's Kelvin objects and control points as JSON (cbf_fields.hpp).
#include "cbf_fields.hpp"

#include <optional>

#include "distlab/geometry/polytope.hpp"
#include "distlab/mesh/weld.hpp"
#include "distlab/server/data_dirs.hpp"
#include "distlab/server/json_fields.hpp"
#include "distlab/server/kelvin_json.hpp"

namespace distlab::server {
namespace {

using json = nlohmann::json;

// Runs fn, prefixing the field of an InvalidInput it throws ("sigma.d0" → "scenario.fields[0].sigma.d0").
template <class Fn>
auto prefixed(const std::string& prefix, Fn&& fn) {
  try {
    return fn();
  } catch (const InvalidInput& e) {
    throw InvalidInput(json_key_path(prefix, e.field()), e.what());
  }
}

std::string mesh_path(const json& m, const std::string& field, const std::string& assets_dir) {
  json_require_object(m, field);
  json_check_keys(m, field, {"asset", "path"});
  if (m.contains("path") == m.contains("asset")) throw InvalidInput(field, field + " needs exactly one of path and asset");
  if (m.contains("path")) return json_string(m["path"], json_key_path(field, "path"));
  const std::string name = json_string(m["asset"], json_key_path(field, "asset"));
  try {
    return asset_path(name, assets_dir);
  } catch (const InvalidInput& e) {  // named "mesh.asset"
    throw InvalidInput(json_key_path(field, "asset"), e.what());
  }
}

kelvin::Field prepare_default(const mesh::SurfaceMesh& surface, const kelvin::PrepareOptions& options, const std::string&) {
  const std::string cache = default_cache_dir();
  return cache.empty() ? kelvin::Field::prepare(surface, options) : kelvin::Field::prepare_cached(surface, options, cache);
}

// Reads and checks field entry j up to its repair and preparation. field_mode "hull": the
// object's convex hull goes into hull_obstacles instead (nothing to prepare; returns nullopt).
std::optional<PlannedField> plan_field(const json& j, std::size_t index, const std::string& f, const std::string& assets_dir,
                                       std::vector<cbf::Obstacle>* hull_obstacles) {
  json_require_object(j, f);
  json_check_keys(j, f, {"name", "mesh", "lx", "lx_fraction", "grading", "center", "far_radius", "feature_angle", "components", "simplify", "repair", "repair_options", "pose", "sigma", "delta", "comment"});
  PlannedField p;
  p.field = f;
  cbf::SceneField& out = p.scene;
  out.name = j.contains("name") ? json_string(j["name"], json_key_path(f, "name")) : "field" + std::to_string(index);
  if (j.contains("pose")) out.pose = json_pose(j["pose"], json_key_path(f, "pose"));
  if (j.contains("delta")) out.margin = json_number(j["delta"], json_key_path(f, "delta"), kelvin::kMaxAbsSigma);
  const std::string path = mesh_path(json_required(j, f, "mesh"), json_key_path(f, "mesh"), assets_dir);
  p.key = j.dump() + "\n" + path;
  p.surface = mesh::load_mesh(path, json_key_path(f, "mesh"));
  mesh::Welded welded = mesh::weld(p.surface);
  if (hull_obstacles) {  // field_mode "hull": the object's convex hull as an obstacle, no field
    std::vector<Vec3> points(static_cast<std::size_t>(welded.surface.vertices.rows()));
    for (std::size_t i = 0; i < points.size(); ++i) points[i] = welded.surface.vertices.row(static_cast<Eigen::Index>(i)).transpose();
    hull_obstacles->push_back({out.name, polytope_from_points(points, json_key_path(f, "mesh")), out.pose, P2SOptions{}});
    return std::nullopt;
  }
  kelvin::PrepareOptions& options = p.options;
  if (j.contains("lx") == j.contains("lx_fraction"))
    throw InvalidInput(json_key_path(f, "lx"), "give lx (metres) or lx_fraction (of the bounding box's diagonal), exactly one");
  if (j.contains("lx")) {
    p.lx_field = json_key_path(f, "lx");
    options.lx = json_positive(j["lx"], p.lx_field, kMaxCoordinate);
  } else {
    p.lx_field = json_key_path(f, "lx_fraction");
    const double fraction = json_number(j["lx_fraction"], p.lx_field, 1);
    if (!(fraction > 0)) throw InvalidInput(p.lx_field, "lx_fraction must be in (0, 1]");
    const auto& v = welded.surface.vertices;
    options.lx = fraction * (v.colwise().maxCoeff() - v.colwise().minCoeff()).norm();
  }
  if (j.contains("grading")) options.grading = json_number(j["grading"], json_key_path(f, "grading"), kelvin::kMaxGrading);
  if (j.contains("center")) options.centre = json_vec3(j["center"], json_key_path(f, "center"), kMaxCoordinate);
  if (j.contains("far_radius")) options.far_radius = json_number(j["far_radius"], json_key_path(f, "far_radius"), kelvin::kMaxFarRadius);
  if (j.contains("feature_angle")) options.feature_angle = json_number(j["feature_angle"], json_key_path(f, "feature_angle"), 180);
  p.reshape = prefixed(f, [&] { return parse_reshape(j, Limits{}); });
  p.user_sigma = j.contains("sigma") ? prefixed(f, [&] { return parse_sigma(j["sigma"]); }) : kelvin::SigmaSpec{};
  // σ per file vertex → per welded vertex (carried to the repaired surface when it is made).
  out.sigma = prefixed(f, [&] { return kelvin::field_sigma(p.user_sigma, p.surface.vertices, welded.to_welded, welded.surface.vertices.rows()); });
  p.prepared = std::move(welded.surface);
  return p;
}

std::vector<cbf::ControlPoint> parse_control_point(const json& j, const std::string& f, const cbf::Robot& robot, const Limits& limits) {
  json_require_object(j, f);
  json_check_keys(j, f, {"name", "link", "point", "element", "sample"});
  const std::string link = json_string(json_required(j, f, "link"), json_key_path(f, "link"));
  if (j.contains("sample")) {
    if (j.contains("point") || j.contains("name"))
      throw InvalidInput(json_key_path(f, "sample"), "a sampled entry has no point or name (its points are named LINK/ELEMENT#i)");
    const std::string element = j.contains("element") ? json_string(j["element"], json_key_path(f, "element")) : "";
    return cbf::sample_control_points(robot, link, element, json_integer(j["sample"], json_key_path(f, "sample"), 1, static_cast<int>(limits.max_cbf_control_points)), f);
  }
  if (j.contains("element")) throw InvalidInput(json_key_path(f, "element"), "element goes with sample");
  const int l = robot.link_index(link);
  if (l < 0) throw InvalidInput(json_key_path(f, "link"), "no link \"" + link.substr(0, 64) + "\" in robot \"" + robot.name() + "\"");
  cbf::ControlPoint c{link, l, json_vec3(json_required(j, f, "point"), json_key_path(f, "point"), kMaxCoordinate)};
  if (j.contains("name")) c.name = json_string(j["name"], json_key_path(f, "name"));
  return {c};
}

}  // namespace

void apply_field_params(json& scenario, const json& params) {
  if (!scenario.is_object() || !params.is_object()) return;
  if (auto it = params.find("fields"); it != params.end()) {
    if (!it->is_array()) throw InvalidInput("params.fields", "params.fields must be an array (one entry per scenario field)");
    json& fields = scenario["fields"];
    if (!fields.is_array() || it->size() != fields.size())
      throw InvalidInput("params.fields", "params.fields needs one entry per field of the scenario (" +
                                              std::to_string(fields.is_array() ? fields.size() : 0) + ")");
    for (std::size_t i = 0; i < it->size(); ++i) {
      const std::string f = json_index_path("params.fields", i);
      json_require_object((*it)[i], f);
      json_check_keys((*it)[i], f, {"sigma", "delta"});
      for (const auto& [k, v] : (*it)[i].items()) fields[i][k] = v;
    }
  }
  if (auto it = params.find("field_mode"); it != params.end()) {
    const std::string mode = json_string(*it, "params.field_mode");
    if (mode != "barrier" && mode != "hull") throw InvalidInput("params.field_mode", "field_mode is \"barrier\" or \"hull\"");
    scenario["field_mode"] = mode;
  }
}

void plan_scenario_fields(const json& j, const std::string& field, const std::string& assets_dir, const Limits& limits, FieldPlan& plan,
                          cbf::Scenario& s) {
  const bool hull = j.contains("field_mode") && j["field_mode"] == "hull";
  if (auto it = j.find("fields"); it != j.end()) {
    const std::string ff = json_key_path(field, "fields");
    if (!it->is_array() || it->size() > limits.max_cbf_fields)
      throw InvalidInput(ff, "fields must be an array of at most " + std::to_string(limits.max_cbf_fields) + " Kelvin objects");
    for (std::size_t i = 0; i < it->size(); ++i)
      if (auto p = plan_field((*it)[i], i, json_index_path(ff, i), assets_dir, hull ? &s.obstacles : nullptr)) plan.fields.push_back(std::move(*p));
  }
  if (auto it = j.find("control_points"); it != j.end()) {
    const std::string cf = json_key_path(field, "control_points");
    if (!it->is_array()) throw InvalidInput(cf, "control_points must be an array");
    for (std::size_t i = 0; i < it->size(); ++i) {
      for (cbf::ControlPoint& c : parse_control_point((*it)[i], json_index_path(cf, i), *s.robot, limits)) {
        if (c.name.empty()) c.name = "point" + std::to_string(plan.control_points.size());
        plan.control_points.push_back(std::move(c));
      }
      if (plan.control_points.size() > limits.max_cbf_control_points)
        throw InvalidInput(cf, "at most " + std::to_string(limits.max_cbf_control_points) + " control points");
    }
    if (hull) plan.control_points.clear();  // checked, unused: the hulls are obstacles
  }
  // What cbf::validate says of the prepared scenario, said before anything is prepared.
  if (plan.fields.empty() != plan.control_points.empty())
    throw InvalidInput(json_key_path(field, plan.fields.empty() ? "control_points" : "fields"),
                       "fields and control_points go together: a field constrains the control points, and "
                       "control points without a field constrain nothing");
}

void prepare_planned_fields(cbf::Scenario& s, const FieldPlan& plan, const FieldPreparer& prepare, const Progress& progress,
                            std::map<std::string, cbf::SceneField>* prepared) {
  for (const PlannedField& p : plan.fields) {
    if (prepared != nullptr)
      if (auto it = prepared->find(p.key); it != prepared->end()) {
        s.fields.push_back(it->second);
        continue;
      }
    cbf::SceneField out = p.scene;
    mesh::SurfaceMesh surface = p.prepared;
    if (p.reshape.any()) {
      Reshaped r = prefixed(p.field, [&] { return reshape_surface(p.surface, p.prepared, p.reshape, Limits{}, progress); });
      out.sigma = carry_sigma(std::move(out.sigma), p.user_sigma, mesh::nearest_face_transfer(p.surface, r.surface.vertices, progress));
      surface = std::move(r.surface);
    }
    kelvin::Field field = prefixed(p.field, [&] { return (prepare ? prepare : prepare_default)(surface, p.options, p.field); });
    progress("solve", 0);
    field.set_sigma(out.sigma);
    out.field = std::make_shared<const kelvin::Field>(std::move(field));
    if (prepared != nullptr) prepared->emplace(p.key, out);
    s.fields.push_back(std::move(out));
  }
  s.control_points = plan.control_points;
}

void parse_scenario_fields(const json& j, const std::string& field, const std::string& assets_dir, const FieldPreparer& prepare,
                           cbf::Scenario& s, const Limits& limits) {
  FieldPlan plan;
  plan_scenario_fields(j, field, assets_dir, limits, plan, s);
  prepare_planned_fields(s, plan, prepare);
}

json encode_control_points(const std::vector<cbf::ControlPoint>& points) {
  json out = json::array();
  for (const cbf::ControlPoint& c : points) out.push_back({{"name", c.name}, {"link", c.link}, {"point", vec_json(c.point)}});
  return out;
}

json encode_field_step(const cbf::StepRecord& s, std::size_t f, std::size_t points) {
  json h = json::array();
  for (std::size_t p = 0; p < points; ++p) h.push_back(finite_or_null(s.field_points[f * points + p].h));
  const cbf::FieldContact& c = s.field_contacts[f];
  return {{"h", std::move(h)},
          {"closest", vec_json(c.closest)},
          {"closest_sigma", c.sigma},
          {"distance", finite_or_null(c.distance)},
          {"closest_control_point", c.point},
          {"allowed_distance", finite_or_null(c.allowed_distance)},
          {"forbidden_distance", finite_or_null(c.forbidden_distance)}};
}

json encode_fields(const cbf::RolloutRecord& rec) {
  json fields = json::array();
  const std::size_t np = rec.control_points.size();
  for (std::size_t f = 0; f < rec.field_names.size(); ++f) {
    // The steps' values as columns: one array per key of encode_field_step.
    json field = {{"name", rec.field_names[f]}, {"delta", rec.field_margins[f]}, {"safety_distance", finite_or_null(rec.safety_distances[f])}};
    for (const char* key : {"h", "closest", "closest_sigma", "distance", "closest_control_point", "allowed_distance", "forbidden_distance"})
      field[key] = json::array();
    // The outcomes over the run: the smallest h (and its margin over δ), the control points'
    // final distance to the object and to its allowed faces, the closest they came to its
    // forbidden ones.
    double min_h = INFINITY, min_forbidden = INFINITY;
    for (const cbf::StepRecord& s : rec.steps) {
      json step = encode_field_step(s, f, np);
      for (auto& [key, value] : step.items()) field[key].push_back(std::move(value));
      for (std::size_t p = 0; p < np; ++p) min_h = std::min(min_h, s.field_points[f * np + p].h);
      min_forbidden = std::min(min_forbidden, s.field_contacts[f].forbidden_distance);
    }
    const cbf::FieldContact* last = rec.steps.empty() ? nullptr : &rec.steps.back().field_contacts[f];
    field["summary"] = {{"min_h", finite_or_null(min_h)},
                        {"min_h_over_delta", finite_or_null(min_h - rec.field_margins[f])},
                        {"final_distance", last ? finite_or_null(last->distance) : json(nullptr)},
                        {"final_allowed_distance", last ? finite_or_null(last->allowed_distance) : json(nullptr)},
                        {"min_forbidden_distance", finite_or_null(min_forbidden)}};
    fields.push_back(std::move(field));
  }
  json out = {{"control_points", encode_control_points(rec.control_points)}, {"fields", fields}};
  if (!rec.failure.empty()) out["failure"] = {{"step", rec.failure_step}, {"message", rec.failure}};
  return out;
}

}  // namespace distlab::server
