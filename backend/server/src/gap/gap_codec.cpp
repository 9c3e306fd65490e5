// The GAP routes' codec (gap_codec.hpp): the level sets' request and answer; the distance route
// reads and writes gap_json's schema.
#include "gap_codec.hpp"

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "distlab/server/frames.hpp"
#include "distlab/server/json_fields.hpp"

namespace distlab::server {

using json = nlohmann::json;

namespace {

void only_keys(const json& j, const std::string& field, std::initializer_list<std::string_view> keys) {
  json_require_object(j, field);
  json_check_keys(j, field, keys);
}

std::vector<double> read_levels(const json& j, const std::string& field, std::size_t max) {
  if (!j.is_array()) throw InvalidInput(field, field + " must be an array of numbers");
  if (j.size() > max) throw ApiError(413, "too_many_levels", field + " has more than " + std::to_string(max) + " levels", field);
  std::vector<double> out;
  for (std::size_t i = 0; i < j.size(); ++i) out.push_back(json_number(j[i], field + "[" + std::to_string(i) + "]"));
  return out;
}

void read_grid(const json& g, const Limits& limits, levelset::GapLevelsetOptions& o) {
  only_keys(g, "grid", {"resolution", "padding", "bounds"});
  if (g.contains("resolution")) o.resolution = json_integer(g["resolution"], "grid.resolution", 4, limits.max_grid_resolution);
  if (g.contains("padding")) o.padding = json_number(g["padding"], "grid.padding", limits.max_grid_padding);
  if (g.contains("bounds")) {
    only_keys(g["bounds"], "grid.bounds", {"min", "max"});
    if (!g["bounds"].contains("min") || !g["bounds"].contains("max"))
      throw InvalidInput("grid.bounds", "grid.bounds needs min and max");
    o.bounds = std::make_pair(json_vec3(g["bounds"]["min"], "grid.bounds.min", kMaxCoordinate),
                              json_vec3(g["bounds"]["max"], "grid.bounds.max", kMaxCoordinate));
  }
}

// The sampling plane; its centre defaults to the shape's position.
levelset::PlaneFrame read_plane(const json& p, const Vec3& position, const Limits& limits) {
  only_keys(p, "plane", {"center", "normal", "size", "resolution"});
  const Vec3 c = p.contains("center") ? json_vec3(p["center"], "plane.center", kMaxCoordinate) : position;
  const Vec3 n = p.contains("normal") ? json_vec3(p["normal"], "plane.normal", kMaxCoordinate) : Vec3::UnitZ();
  double su = 2, sv = 2;
  if (p.contains("size")) {
    if (!p["size"].is_array() || p["size"].size() != 2) throw InvalidInput("plane.size", "plane.size must be [width, height]");
    su = json_number(p["size"][0], "plane.size[0]");
    sv = json_number(p["size"][1], "plane.size[1]");
    if (!(su > 0 && sv > 0 && su < kMaxCoordinate && sv < kMaxCoordinate))
      throw InvalidInput("plane.size", "plane.size must be two numbers in (0, " + json(kMaxCoordinate).dump() + ")");
  }
  int nu = 128, nv = 128;
  if (p.contains("resolution")) {
    if (!p["resolution"].is_array() || p["resolution"].size() != 2)
      throw InvalidInput("plane.resolution", "plane.resolution must be [nu, nv]");
    nu = json_integer(p["resolution"][0], "plane.resolution[0]", 2, limits.max_plane_resolution);
    nv = json_integer(p["resolution"][1], "plane.resolution[1]", 2, limits.max_plane_resolution);
  }
  return levelset::plane_from_normal(c, n, su, sv, nu, nv);
}

// The finite values' [min, max] ([inf, -inf] when none is).
json finite_range(const std::vector<double>& v) {
  double lo = INFINITY, hi = -INFINITY;
  for (double x : v)
    if (std::isfinite(x)) {
      lo = std::min(lo, x);
      hi = std::max(hi, x);
    }
  return json{lo, hi};
}

json plane_json(const levelset::PlaneFrame& plane, const levelset::GapLevelsets& result, bool msgpack) {
  json out = {{"center", vec_json(plane.centre)},
              {"u", vec_json(plane.u)},
              {"v", vec_json(plane.v)},
              {"size", {plane.size_u, plane.size_v}},
              {"resolution", {plane.nu, plane.nv}}};
  if (msgpack) {
    out["weak"] = json::binary(float32_bytes(result.plane_weak));
    out["strict"] = json::binary(float32_bytes(result.plane_strict));
  } else {
    out["weak_range"] = finite_range(result.plane_weak);
    out["strict_range"] = finite_range(result.plane_strict);
  }
  return out;
}

}  // namespace

GapDistanceRequest decode_gap_distance(const Request& request, const Limits& limits) {
  return decode_gap_request(parse_body(request), limits);
}

Response encode_gap_distance(const GapDistanceResults& results) { return json_response(200, encode_gap_results(results)); }

GapLevelsetsRequest decode_gap_levelsets(const Request& request, const Limits& limits) {
  const json body = parse_body(request);
  only_keys(body, "", {"shape", "params", "levels", "grid", "plane", "format", "comment"});
  if (!body.contains("shape")) throw InvalidInput("shape", "shape is required");
  GapLevelsetsRequest out{parse_shape(body["shape"], "shape", limits),
                          parse_params(body.contains("params") ? body["params"] : json(nullptr), "params", limits),
                          {},
                          true};
  levelset::GapLevelsetOptions& o = out.options;
  if (body.contains("levels")) {
    only_keys(body["levels"], "levels", {"weak", "strict"});
    if (body["levels"].contains("weak")) o.weak_levels = read_levels(body["levels"]["weak"], "levels.weak", limits.max_levels);
    if (body["levels"].contains("strict")) o.strict_levels = read_levels(body["levels"]["strict"], "levels.strict", limits.max_levels);
  }
  if (body.contains("grid")) read_grid(body["grid"], limits, o);
  if (body.contains("plane")) o.plane = read_plane(body["plane"], out.shape.pose.position, limits);
  if (body.contains("format")) {
    if (!body["format"].is_string() || (body["format"] != "msgpack" && body["format"] != "json"))
      throw InvalidInput("format", "format must be \"msgpack\" or \"json\"");
    out.msgpack = body["format"] == "msgpack";
  }
  return out;
}

Response encode_gap_levelsets(const GapLevelsetsResult& result) {
  const levelset::GapLevelsets& r = result.levelsets;
  json out = {{"type", "gap_levelsets"},
              {"bounds", {{"min", vec_json(r.lo)}, {"max", vec_json(r.hi)}}},
              {"grid", {r.n[0], r.n[1], r.n[2]}}};
  json surfaces = json::array();
  for (const auto& s : r.surfaces) {
    json meta = {{"field", s.strict ? "strict" : "weak"}, {"level", s.level}};
    if (result.msgpack) {
      surfaces.push_back(mesh_frame(s.mesh, meta));
    } else {
      meta["n_vertices"] = s.mesh.vertices.rows();
      meta["n_faces"] = s.mesh.faces.rows();
      surfaces.push_back(meta);
    }
  }
  out["surfaces"] = surfaces;
  if (result.plane) out["plane"] = plane_json(*result.plane, r, result.msgpack);
  if (!result.msgpack) return json_response(200, out);
  Response response;
  response.content_type = "application/msgpack";
  response.body = to_msgpack(out);
  return response;
}

}  // namespace distlab::server
