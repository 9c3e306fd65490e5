// GAP endpoints: distances (the CLI's schema) and level sets of e_S / E_S.

#include "distlab/gap/point_to_set.hpp"
#include "distlab/geometry/error.hpp"
#include "distlab/levelset/gap_fields.hpp"
#include "distlab/server/deadline.hpp"
#include "distlab/server/frames.hpp"
#include "distlab/server/gap_json.hpp"
#include "distlab/server/json_fields.hpp"
#include "gap_module.hpp"

namespace distlab::server {

using json = nlohmann::json;

namespace {

void only_keys(const json& j, const std::string& field, std::initializer_list<std::string_view> keys) {
  json_require_object(j, field);
  json_check_keys(j, field, keys);
}

std::vector<double> levels(const json& j, const std::string& field, std::size_t max) {
  if (!j.is_array()) throw InvalidInput(field, field + " must be an array of numbers");
  if (j.size() > max) throw ApiError(413, "too_many_levels", field + " has more than " + std::to_string(max) + " levels", field);
  std::vector<double> out;
  for (std::size_t i = 0; i < j.size(); ++i) out.push_back(json_number(j[i], field + "[" + std::to_string(i) + "]"));
  return out;
}

}  // namespace

void GapModule::register_routes() {
  Route distance{"POST", "/api/gap/distance", [this](Request& req) {
                   const json body = parse_body(req);
                   const Limits& lim = config_.limits;
                   const Deadline deadline(lim.max_request_seconds);
                   return json_response(200, run_gap_request(
                                                 body, [&] {
                                                   deadline.check("send fewer pairs per request");
                                                 },
                                                 lim));
                 }};
  distance.heavy = true;
  distance.bounds = {"max_body_bytes", "max_gap_pairs", "max_gap_iterations", "max_request_seconds"};
  router_.add(std::move(distance));

  Route levelsets{"POST", "/api/gap/levelsets", [this](Request& req) {
                    const json body = parse_body(req);
                    const Limits& lim = config_.limits;
                    only_keys(body, "", {"shape", "params", "levels", "grid", "plane", "format", "comment"});
                    if (!body.contains("shape")) throw InvalidInput("shape", "shape is required");
                    const ShapeSpec spec = parse_shape(body["shape"], "shape", lim);
                    const GapRequestParams gp = parse_params(body.contains("params") ? body["params"] : json(nullptr), "params", lim);
                    levelset::GapLevelsetOptions o;
                    if (body.contains("levels")) {
                      only_keys(body["levels"], "levels", {"weak", "strict"});
                      if (body["levels"].contains("weak")) o.weak_levels = levels(body["levels"]["weak"], "levels.weak", lim.max_levels);
                      if (body["levels"].contains("strict"))
                        o.strict_levels = levels(body["levels"]["strict"], "levels.strict", lim.max_levels);
                    }
                    if (body.contains("grid")) {
                      const json& g = body["grid"];
                      only_keys(g, "grid", {"resolution", "padding", "bounds"});
                      if (g.contains("resolution")) o.resolution = json_integer(g["resolution"], "grid.resolution", 4, lim.max_grid_resolution);
                      if (g.contains("padding")) o.padding = json_number(g["padding"], "grid.padding", lim.max_grid_padding);
                      if (g.contains("bounds")) {
                        only_keys(g["bounds"], "grid.bounds", {"min", "max"});
                        if (!g["bounds"].contains("min") || !g["bounds"].contains("max"))
                          throw InvalidInput("grid.bounds", "grid.bounds needs min and max");
                        o.bounds = std::make_pair(json_vec3(g["bounds"]["min"], "grid.bounds.min", kMaxCoordinate), json_vec3(g["bounds"]["max"], "grid.bounds.max", kMaxCoordinate));
                      }
                    }
                    json plane_meta;
                    if (body.contains("plane")) {
                      const json& p = body["plane"];
                      only_keys(p, "plane", {"center", "normal", "size", "resolution"});
                      const Vec3 c = p.contains("center") ? json_vec3(p["center"], "plane.center", kMaxCoordinate) : spec.pose.position;
                      const Vec3 n = p.contains("normal") ? json_vec3(p["normal"], "plane.normal", kMaxCoordinate) : Vec3::UnitZ();
                      double su = 2, sv = 2;
                      if (p.contains("size")) {
                        if (!p["size"].is_array() || p["size"].size() != 2) throw InvalidInput("plane.size", "plane.size must be [width, height]");
                        su = json_number(p["size"][0], "plane.size[0]");
                        sv = json_number(p["size"][1], "plane.size[1]");
                        if (!(su > 0 && sv > 0 && su < kMaxCoordinate && sv < kMaxCoordinate)) throw InvalidInput("plane.size", "plane.size must be two numbers in (0, " + json(kMaxCoordinate).dump() + ")");
                      }
                      int nu = 128, nv = 128;
                      if (p.contains("resolution")) {
                        if (!p["resolution"].is_array() || p["resolution"].size() != 2)
                          throw InvalidInput("plane.resolution", "plane.resolution must be [nu, nv]");
                        nu = json_integer(p["resolution"][0], "plane.resolution[0]", 2, lim.max_plane_resolution);
                        nv = json_integer(p["resolution"][1], "plane.resolution[1]", 2, lim.max_plane_resolution);
                      }
                      o.plane = levelset::plane_from_normal(c, n, su, sv, nu, nv);
                      plane_meta = {{"center", {c.x(), c.y(), c.z()}},
                                    {"u", {o.plane->u.x(), o.plane->u.y(), o.plane->u.z()}},
                                    {"v", {o.plane->v.x(), o.plane->v.y(), o.plane->v.z()}},
                                    {"size", {su, sv}},
                                    {"resolution", {nu, nv}}};
                    }
                    std::string format = "msgpack";
                    if (body.contains("format")) {
                      if (!body["format"].is_string() || (body["format"] != "msgpack" && body["format"] != "json"))
                        throw InvalidInput("format", "format must be \"msgpack\" or \"json\"");
                      format = body["format"];
                    }
                    P2SOptions p2s_options = spec.options;
                    p2s_options.weight_margin = gp.params.weight_margin;
                    PointToSet p2s(spec.shape, BaseFunction(gp.params.h, gp.params.k), StrictParams{gp.params.eps, gp.params.sigma},
                                   p2s_options, "shape");
                    p2s.set_pose(spec.pose);

                    // Time per request: the sampling stops (408) once the deadline passes.
                    const Deadline deadline(lim.max_request_seconds);
                    Progress progress;
                    progress.report = [&deadline](const std::string&, double) { deadline.check("use a coarser grid"); };
                    const levelset::GapLevelsets result = levelset::gap_levelsets(p2s, o, progress);

                    json out = {{"type", "gap_levelsets"},
                                {"bounds", {{"min", {result.lo.x(), result.lo.y(), result.lo.z()}}, {"max", {result.hi.x(), result.hi.y(), result.hi.z()}}}},
                                {"grid", {result.n[0], result.n[1], result.n[2]}}};
                    json surfaces = json::array();
                    for (const auto& s : result.surfaces) {
                      json meta = {{"field", s.strict ? "strict" : "weak"}, {"level", s.level}};
                      if (format == "json") {
                        meta["n_vertices"] = s.mesh.vertices.rows();
                        meta["n_faces"] = s.mesh.faces.rows();
                        surfaces.push_back(meta);
                      } else {
                        surfaces.push_back(mesh_frame(s.mesh, meta));
                      }
                    }
                    out["surfaces"] = surfaces;
                    if (o.plane) {
                      if (format == "msgpack") {
                        plane_meta["weak"] = json::binary(float32_bytes(result.plane_weak));
                        plane_meta["strict"] = json::binary(float32_bytes(result.plane_strict));
                      } else {
                        auto range = [](const std::vector<double>& v) {
                          double lo = INFINITY, hi = -INFINITY;
                          for (double x : v)
                            if (std::isfinite(x)) {
                              lo = std::min(lo, x);
                              hi = std::max(hi, x);
                            }
                          return json{lo, hi};
                        };
                        plane_meta["weak_range"] = range(result.plane_weak);
                        plane_meta["strict_range"] = range(result.plane_strict);
                      }
                      out["plane"] = plane_meta;
                    }
                    if (format == "json") return json_response(200, out);
                    Response r;
                    r.content_type = "application/msgpack";
                    r.body = to_msgpack(out);
                    return r;
                  }};
  levelsets.heavy = true;
  levelsets.bounds = {"max_body_bytes", "max_levels", "max_grid_resolution", "max_plane_resolution", "max_request_seconds"};
  router_.add(std::move(levelsets));
}

}  // namespace distlab::server
