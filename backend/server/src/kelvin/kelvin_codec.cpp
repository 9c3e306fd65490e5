// The Kelvin object routes' codec (kelvin_codec.hpp): each input checked here, once.
#include "kelvin_codec.hpp"

#include <cmath>
#include <map>
#include <set>

#include "distlab/geometry/error.hpp"
#include "distlab/kelvin/sigma.hpp"
#include "distlab/server/frames.hpp"
#include "distlab/server/gap_json.hpp"
#include "distlab/server/json_fields.hpp"
#include "distlab/server/request_params.hpp"
#include "kelvin_inputs.hpp"

namespace distlab::server {

using json = nlohmann::json;

namespace {

// The export formats and their content types.
const std::map<std::string, std::string>& export_types() {
  static const std::map<std::string, std::string> types = {
      {"stl", "model/stl"}, {"obj", "model/obj"}, {"ply", "application/octet-stream"}, {"glb", "model/gltf-binary"}};
  return types;
}

// The preparation's options of a create request: lx or lx_fraction, center, far_radius, grading,
// mesh_threads.
void decode_options(const json& body, CreateObjectRequest& in) {
  if (body.contains("lx") == body.contains("lx_fraction"))
    throw InvalidInput("lx", "give lx (metres) or lx_fraction (of the bounding box's diagonal), exactly one");
  kelvin::PrepareOptions& options = in.options;
  if (body.contains("lx")) {
    options.lx = json_number(body["lx"], "lx");
    if (!(options.lx > 0)) throw InvalidInput("lx", "lx must be positive");
  } else {
    in.lx_fraction = json_number(body["lx_fraction"], "lx_fraction");
    if (!(*in.lx_fraction > 0) || *in.lx_fraction > 1) throw InvalidInput("lx_fraction", "lx_fraction must be in (0, 1]");
  }
  if (body.contains("center")) options.centre = json_vec3(body["center"], "center", kMaxCoordinate);
  if (body.contains("far_radius")) {
    options.far_radius = json_number(body["far_radius"], "far_radius", kelvin::kMaxFarRadius);
    if (!(options.far_radius >= 0.5)) throw InvalidInput("far_radius", "far_radius must be in [0.5, " + json(kelvin::kMaxFarRadius).dump() + "]");
    in.far_radius = options.far_radius;
  }
  if (body.contains("grading")) {  // absent: prepare chooses
    options.grading = json_number(body["grading"], "grading", kelvin::kMaxGrading);
    if (!(*options.grading >= 0)) throw InvalidInput("grading", "grading must be in [0, " + json(kelvin::kMaxGrading).dump() + "]");
  }
  // Checked against this server's cores by KelvinModule::check_preparable.
  if (body.contains("mesh_threads")) options.mesh_threads = json_integer(body["mesh_threads"], "mesh_threads", 0, kelvin::kMaxMeshThreads);
}

// One of asset (a name), upload (an id) and mesh (inline, at most max_upload_triangles).
void decode_source(const json& body, const Limits& limits, CreateObjectRequest& in) {
  if (body.contains("asset")) {
    if (!body["asset"].is_string() || !valid_name(body["asset"])) throw InvalidInput("asset", "asset must be an asset name");
    in.asset = body["asset"];
  } else if (body.contains("upload")) {
    if (!body["upload"].is_string()) throw InvalidInput("upload", "upload must be an upload id");
    in.upload = body["upload"];
  } else {
    in.mesh = inline_mesh(body["mesh"], limits.max_upload_triangles);
  }
}

}  // namespace

ObjectRef decode_object_ref(const Request& request, const Limits& /*limits*/) { return {request.params.at("id")}; }

SigmaEdit decode_sigma(const json& sigma) { return {parse_sigma(sigma), sigma.dump()}; }

std::vector<double> decode_levels(const json& levels, const Limits& limits) {
  return parse_levels(levels, "levels", limits.max_levels);
}

const json& required_field(const json& message, const char* key) {
  if (!message.contains(key)) throw InvalidInput(key, std::string(key) + " is required");
  return message[key];
}

CreateObjectRequest decode_create_object(const Request& request, const Limits& limits) {
  const json body = parse_body(request);
  if (!body.is_object()) throw InvalidInput("", "the request must be an object");
  static const std::set<std::string> keys = {"asset", "upload", "mesh", "lx", "lx_fraction", "center", "far_radius", "grading",
                                             "mesh_threads", "sigma", "levels", "repair", "repair_options", "simplify", "components", "comment"};
  for (const auto& [k, v] : body.items())
    if (!keys.count(k)) throw InvalidInput(k, "unknown key \"" + k.substr(0, 64) + "\"");
  const int sources = static_cast<int>(body.contains("asset")) + static_cast<int>(body.contains("upload")) +
                      static_cast<int>(body.contains("mesh"));
  if (sources != 1) throw InvalidInput("", "give exactly one of asset, upload and mesh");
  CreateObjectRequest in;
  decode_options(body, in);
  in.reshape = parse_reshape(body, limits);
  decode_source(body, limits, in);
  if (body.contains("sigma")) in.sigma = decode_sigma(body["sigma"]);
  if (body.contains("levels")) in.levels = decode_levels(body["levels"], limits);
  return in;
}

Response encode_created_object(const CreatedObject& created) {
  return json_response(202, {{"object", created.object->status_json()}, {"job", created.job->to_json()}});
}

Response encode_estimate(const ObjectEstimate& e) {
  json out = {{"vertex_estimate", e.vertex_estimate},
              {"budget_vertices", e.budget_vertices},
              {"max_vertex_estimate", e.max_vertex_estimate},
              {"min_lx", e.min_lx},
              {"diagonal", e.diagonal},
              {"lx_for_budget", e.lx_for_budget},
              {"problem", nullptr},
              {"prediction_note", nullptr}};
  if (e.problem) out["problem"] = {{"field", e.problem->first}, {"message", e.problem->second}};
  if (e.prediction_note) out["prediction_note"] = *e.prediction_note;
  out.update(prediction_json(e.prediction, e.rate));
  if (e.repair)
    out["repair_estimate"] = {{"alpha", e.repair->alpha}, {"offset", e.repair->offset}, {"faces", std::round(e.repair->faces)}, {"megabytes", e.repair->megabytes}, {"seconds", e.repair->seconds}};
  return json_response(200, out);
}

Response encode_object_list(const ObjectList& list) {
  json objects = json::array();
  for (const auto& o : list.objects) objects.push_back(o->status_json());
  return json_response(200, {{"objects", objects}});
}

Response encode_object(const std::shared_ptr<KelvinObject>& object) { return json_response(200, object->status_json()); }

Response encode_deleted(const Nothing& /*nothing*/) { return no_content_response(); }

SigmaRequest decode_put_sigma(const Request& request, const Limits& /*limits*/) {
  return {request.params.at("id"), decode_sigma(parse_body(request))};
}

Response encode_sigma(const SigmaState& sigma) {
  return json_response(200, {{"sigma", json::parse(sigma.given)}, {"sigma_version", sigma.version}});
}

LevelsRequest decode_put_levels(const Request& request, const Limits& limits) {
  const json body = parse_body(request);
  json_require_object(body, "");
  json_check_keys(body, "", {"levels", "comment"});
  return {request.params.at("id"), decode_levels(required_field(body, "levels"), limits)};
}

Response encode_levels(const std::vector<double>& levels) { return json_response(200, {{"levels", levels}}); }

QueryRequest decode_query(const Request& request, const Limits& limits) {
  const json body = parse_body(request);
  json_require_object(body, "");
  json_check_keys(body, "", {"points", "comment"});
  if (!body.contains("points") || !body["points"].is_array()) throw InvalidInput("points", "points must be an array of [x, y, z]");
  const json& pts = body["points"];
  if (pts.size() > limits.max_query_points)
    throw ApiError(413, "too_many_points", "at most " + std::to_string(limits.max_query_points) + " points", "points");
  QueryRequest in{request.params.at("id"), {}};
  in.points.reserve(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) in.points.push_back(json_vec3(pts[i], "points[" + std::to_string(i) + "]"));
  return in;
}

Response encode_query(const QueryResult& result) {
  json h = json::array(), grad = json::array(), inside = json::array();
  for (const auto& s : result.samples) {
    const bool ok = s.status == kelvin::Status::ok && std::isfinite(s.h);
    h.push_back(ok ? json(s.h) : json(nullptr));
    grad.push_back(ok ? vec_json(s.gradient) : json(nullptr));
    inside.push_back(s.status == kelvin::Status::inside);
  }
  return json_response(200, {{"h", h}, {"gradient", grad}, {"inside", inside}, {"sigma_version", result.sigma_version}});
}

LevelRequest decode_isosurface(const Request& request, const Limits& /*limits*/) {
  return {request.params.at("id"), query_level(request), ""};
}

LevelRequest decode_export(const Request& request, const Limits& /*limits*/) {
  LevelRequest in{request.params.at("id"), query_level(request), "stl"};
  single_query(request, "format");
  if (const auto it = request.query.find("format"); it != request.query.end()) in.format = it->second;
  if (!export_types().count(in.format)) throw InvalidInput("format", "format must be stl, obj, ply or glb");
  return in;
}

Response encode_isosurface(const Isosurface& iso) {
  Response r;
  r.content_type = "application/msgpack";
  r.body = to_msgpack(mesh_frame(iso.mesh, {{"type", "isosurface"}, {"object", iso.object}, {"level", iso.level}, {"index", 0}, {"count", 1}, {"sigma_version", iso.sigma_version}, {"digest", kelvin::surface_digest(iso.mesh)}, {"check", surface_check_json(mesh::inspect_surface(iso.mesh))}}));
  return r;
}

Response encode_export(const ExportFile& file) {
  Response r;
  r.body = file.bytes;
  r.content_type = export_types().at(file.format);
  // Equal digests: the same surface (e.g. two levels of one export session); see openapi.json.
  r.headers.emplace_back("X-Distlab-Isosurface-Digest", file.digest);
  r.headers.emplace_back("X-Distlab-Surface-Check", surface_check_json(file.check).dump());
  r.headers.emplace_back("Content-Disposition", "attachment; filename=\"isosurface-" + file.object.substr(0, 8) + "." + file.format + "\"");
  return r;
}

// of=input (default): the user's mesh; of=repaired: the surface the field is prepared on (after
// "fix" or "wrap").
SurfaceRequest decode_surface(const Request& request, const Limits& /*limits*/) {
  single_query(request, "of");
  const auto of_it = request.query.find("of");
  const std::string of = of_it == request.query.end() ? "input" : of_it->second;
  if (of != "input" && of != "repaired") throw InvalidInput("of", "of must be input or repaired");
  return {request.params.at("id"), of == "repaired"};
}

Response encode_surface(const SurfaceView& view) {
  Response r;
  r.content_type = "application/msgpack";
  r.body = to_msgpack(mesh_frame(*view.shown, {{"type", "surface"}, {"object", view.object->id}, {"of", view.repaired ? "repaired" : "input"}, {"sigma_version", view.sigma_version}}, &view.sigma));
  return r;
}

}  // namespace distlab::server
