// Kelvin object endpoints: objects (prepare as a job), σ, levels, queries, iso-surfaces (msgpack
// frames as downloads), exports; the uploads are routes_kelvin_uploads.cpp's. The objects' methods
// are in kelvin_service.cpp.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "distlab/geometry/error.hpp"
#include "distlab/mesh/checks.hpp"
#include "distlab/mesh/repair.hpp"
#include "distlab/mesh/weld.hpp"
#include "distlab/server/deadline.hpp"
#include "distlab/server/frames.hpp"
#include "distlab/server/gap_json.hpp"
#include "distlab/server/json_fields.hpp"
#include "distlab/server/request_params.hpp"
#include "kelvin_inputs.hpp"
#include "kelvin_module.hpp"

namespace distlab::server {

using json = nlohmann::json;
namespace fs = std::filesystem;

void KelvinModule::register_routes() {
  register_upload_routes();

  Route create{"POST", "/api/kelvin/objects", [this](Request& req) {
                 auto session = require_session(req);
                 return json_response(202, create_object(session, parse_body(req)));
               }};
  create.heavy = true;
  create.bounds = {"max_body_bytes", "max_upload_triangles", "max_object_triangles", "max_held_triangles_per_address", "max_held_triangles", "min_lx", "max_vertex_estimate", "max_objects_per_session", "max_jobs_per_session", "max_jobs_total", "max_hole_edges", "max_repair_faces"};
  router_.add(std::move(create));

  Route estimate{"POST", "/api/kelvin/estimate", [this](Request& req) {
                   auto session = require_session(req);
                   return json_response(200, create_object(session, parse_body(req), true));
                 }};
  estimate.heavy = true;
  estimate.bounds = {"max_body_bytes", "max_upload_triangles", "max_object_triangles", "min_lx", "max_vertex_estimate"};
  router_.add(std::move(estimate));

  router_.add({"GET", "/api/kelvin/objects", [this](Request& req) {
                 auto session = require_session(req);
                 std::vector<std::shared_ptr<KelvinObject>> objects;
                 {
                   std::lock_guard lock(session->mutex);
                   for (const auto& [id, o] : kelvin_state(*session).objects) objects.push_back(o);
                 }
                 json list = json::array();
                 for (const auto& o : objects) list.push_back(o->status_json());
                 return json_response(200, {{"objects", list}});
               }});
  router_.add({"GET", "/api/kelvin/objects/{id}", [this](Request& req) {
                 auto session = require_session(req);
                 return json_response(200, require_object(*session, req)->status_json());
               }});
  router_.add({"DELETE", "/api/kelvin/objects/{id}", [this](Request& req) {
                 auto session = require_session(req);
                 auto object = require_object(*session, req);
                 std::string job;
                 {
                   std::lock_guard lock(object->mutex);
                   job = object->job;
                 }
                 if (auto j = jobs_.find(session->id, job)) j->cancel = true;
                 {
                   std::lock_guard lock(session->mutex);
                   kelvin_state(*session).objects.erase(object->id);
                 }
                 return no_content_response();
               }});
  router_.add({"GET", "/api/kelvin/objects/{id}/sigma", [this](Request& req) {
                 auto session = require_session(req);
                 auto object = require_object(*session, req);
                 std::lock_guard lock(object->mutex);
                 return json_response(200, {{"sigma", object->sigma_json}, {"sigma_version", object->sigma_version}});
               }});
  router_.add({"PUT", "/api/kelvin/objects/{id}/sigma", [this](Request& req) {
                 auto session = require_session(req);
                 auto object = require_object(*session, req);
                 set_sigma(session, object, parse_body(req));
                 std::lock_guard lock(object->mutex);
                 return json_response(200, {{"sigma", object->sigma_json}, {"sigma_version", object->sigma_version}});
               }});
  router_.add({"PUT", "/api/kelvin/objects/{id}/levels", [this](Request& req) {
                 auto session = require_session(req);
                 auto object = require_object(*session, req);
                 const json body = parse_body(req);
                 json_require_object(body, "");
                 json_check_keys(body, "", {"levels", "comment"});
                 if (!body.contains("levels")) throw InvalidInput("levels", "levels is required");
                 set_levels(session, object, body["levels"]);
                 std::lock_guard lock(object->mutex);
                 return json_response(200, {{"levels", object->levels}});
               }});

  auto ready = [](const std::shared_ptr<KelvinObject>& o, kelvin::SigmaSpec& sigma, std::string& key,
                  std::uint64_t& version) {
    std::lock_guard lock(o->mutex);
    if (o->state != "ready" || !o->prepared)
      throw ApiError(409, "not_ready", "the object is " + o->state + ", not ready");
    sigma = o->field_sigma;
    key = o->sigma_key;
    version = o->sigma_version;
    return o->prepared;
  };

  // The iso-surface of one level, or 422 empty_isosurface when the field never takes it.
  auto isosurface = [](PreparedField& prepared, const kelvin::SigmaSpec& sigma, const std::string& key, double level) {
    double minimum = 0;
    mesh::SurfaceMesh m = prepared.with_sigma(sigma, key, false, [&](const kelvin::Field& f) {
      mesh::SurfaceMesh out = f.isosurface(level);
      if (out.faces.rows() == 0) minimum = f.minimum();
      return out;
    });
    if (m.faces.rows() == 0)
      throw ApiError(422, "empty_isosurface",
                     "the field never takes h = " + json(level).dump() + ": its smallest value is h = " + json(minimum).dump() +
                         " (where σ is smallest on the surface), and {h = level} is empty for every level below it",
                     "level");
    return m;
  };

  Route query{"POST", "/api/kelvin/objects/{id}/query", [this, ready](Request& req) {
                auto session = require_session(req);
                auto object = require_object(*session, req);
                const json body = parse_body(req);
                json_require_object(body, "");
                json_check_keys(body, "", {"points", "comment"});
                if (!body.contains("points") || !body["points"].is_array())
                  throw InvalidInput("points", "points must be an array of [x, y, z]");
                const json& pts = body["points"];
                if (pts.size() > config_.limits.max_query_points)
                  throw ApiError(413, "too_many_points", "at most " + std::to_string(config_.limits.max_query_points) + " points", "points");
                std::vector<Vec3> points;
                points.reserve(pts.size());
                for (std::size_t i = 0; i < pts.size(); ++i) points.push_back(json_vec3(pts[i], "points[" + std::to_string(i) + "]"));
                kelvin::SigmaSpec sigma;
                std::string key;
                std::uint64_t version;
                auto prepared = ready(object, sigma, key, version);
                // In chunks, so the time limit is checked while a large query runs.
                const Deadline deadline(config_.limits.max_request_seconds);
                const std::size_t chunk = std::max<std::size_t>(1, config_.limits.query_chunk_points);
                const auto samples = prepared->with_sigma(sigma, key, true, [&](const kelvin::Field& f) {
                  std::vector<kelvin::Sample> out;
                  out.reserve(points.size());
                  for (std::size_t begin = 0; begin < points.size(); begin += chunk) {
                    deadline.check("query fewer points per request");
                    const std::vector<Vec3> part(points.begin() + static_cast<std::ptrdiff_t>(begin),
                                                 points.begin() + static_cast<std::ptrdiff_t>(std::min(points.size(), begin + chunk)));
                    for (const kelvin::Sample& x : f.query(part)) out.push_back(x);
                  }
                  return out;
                });
                json h = json::array(), grad = json::array(), inside = json::array();
                for (const auto& s : samples) {
                  const bool ok = s.status == kelvin::Status::ok && std::isfinite(s.h);
                  h.push_back(ok ? json(s.h) : json(nullptr));
                  grad.push_back(ok ? vec_json(s.gradient) : json(nullptr));
                  inside.push_back(s.status == kelvin::Status::inside);
                }
                return json_response(200, {{"h", h}, {"gradient", grad}, {"inside", inside}, {"sigma_version", version}});
              }};
  query.heavy = true;
  query.bounds = {"max_body_bytes", "max_query_points", "max_request_seconds"};
  router_.add(std::move(query));

  Route iso{"GET", "/api/kelvin/objects/{id}/isosurface", [this, ready, isosurface](Request& req) {
              auto session = require_session(req);
              auto object = require_object(*session, req);
              const double level = query_level(req);
              kelvin::SigmaSpec sigma;
              std::string key;
              std::uint64_t version;
              auto prepared = ready(object, sigma, key, version);
              const mesh::SurfaceMesh m = isosurface(*prepared, sigma, key, level);
              Response r;
              r.content_type = "application/msgpack";
              r.body = to_msgpack(mesh_frame(m, {{"type", "isosurface"}, {"object", object->id}, {"level", level}, {"index", 0}, {"count", 1}, {"sigma_version", version}, {"digest", kelvin::surface_digest(m)}, {"check", surface_check_json(mesh::inspect_surface(m))}}));
              return r;
            }};
  iso.heavy = true;
  iso.bounds = {"max_vertex_estimate", "isosurface_levels_per_request"};
  router_.add(std::move(iso));

  router_.add({"GET", "/api/kelvin/objects/{id}/surface", [this](Request& req) {
                 auto session = require_session(req);
                 auto object = require_object(*session, req);
                 // of=input (default): the user's mesh; of=repaired: the surface the field is
                 // prepared on (after "fix" or "wrap"), with σ as the field solves it.
                 single_query(req, "of");
                 const auto of_it = req.query.find("of");
                 const std::string of = of_it == req.query.end() ? "input" : of_it->second;
                 if (of != "input" && of != "repaired") throw InvalidInput("of", "of must be input or repaired");
                 kelvin::SigmaSpec sigma, solved;
                 std::uint64_t version;
                 bool repaired = false;
                 {
                   std::lock_guard lock(object->mutex);
                   sigma = object->sigma;
                   solved = object->field_sigma;
                   version = object->sigma_version;
                   // None while repairing, nor after a repair that failed or was cancelled.
                   repaired = object->reshaped() && object->repaired.faces.rows() > 0;
                 }
                 if (of == "repaired" && !repaired)
                   throw ApiError(409, "not_repaired",
                                  "this object has no repaired surface (repair none, still repairing, or the repair failed or was cancelled)", "of");
                 // A repaired object's σ at the user's vertices is what the field solves, read back
                 // by the same nearest-face rule that carried it there (repair.hpp).
                 std::vector<double> values;
                 if (!repaired) values = kelvin::evaluate_at_vertices(sigma, object->surface.vertices);
                 else if (of == "repaired") values = kelvin::evaluate_at_vertices(solved, object->repaired.vertices);
                 else values = mesh::nearest_face_transfer(object->repaired, object->surface.vertices).apply(kelvin::evaluate_at_vertices(solved, object->repaired.vertices));
                 const mesh::SurfaceMesh& shown = of == "repaired" ? object->repaired : object->surface;
                 Response r;
                 r.content_type = "application/msgpack";
                 r.body = to_msgpack(mesh_frame(shown, {{"type", "surface"}, {"object", object->id}, {"of", of}, {"sigma_version", version}}, &values));
                 return r;
               }});

  Route exp{"GET", "/api/kelvin/objects/{id}/export", [this, ready, isosurface](Request& req) {
              auto session = require_session(req);
              auto object = require_object(*session, req);
              const double level = query_level(req);
              single_query(req, "format");
              auto it = req.query.find("format");
              const std::string format = it == req.query.end() ? "stl" : it->second;
              static const std::map<std::string, std::string> types = {
                  {"stl", "model/stl"}, {"obj", "model/obj"}, {"ply", "application/octet-stream"}, {"glb", "model/gltf-binary"}};
              if (!types.count(format)) throw InvalidInput("format", "format must be stl, obj, ply or glb");
              kelvin::SigmaSpec sigma;
              std::string key;
              std::uint64_t version;
              auto prepared = ready(object, sigma, key, version);
              const mesh::SurfaceMesh m = isosurface(*prepared, sigma, key, level);
              const mesh::SurfaceReport check = mesh::inspect_surface(m);
              if (!check.manifold())
                throw ApiError(422, "not_manifold",
                               "the iso-surface at h = " + json(level).dump() + " is not a closed 2-manifold (" +
                                   mesh::surface_defects(check) + "); not exported",
                               "level");
              const fs::path dir = fs::path(registry_cache_dir()) / ("export-" + random_id());
              fs::create_directories(dir);
              Response r;
              try {
                const fs::path file = dir / ("isosurface." + format);
                mesh::save_mesh(m, file.string(), format, "format");
                std::ifstream in(file, std::ios::binary);
                std::ostringstream ss;
                ss << in.rdbuf();
                r.body = ss.str();
              } catch (...) {
                std::error_code ec;
                fs::remove_all(dir, ec);
                throw;
              }
              std::error_code ec;
              fs::remove_all(dir, ec);
              r.content_type = types.at(format);
              // Equal digests: the same surface (e.g. two levels of one export session); see openapi.json.
              r.headers.emplace_back("X-Distlab-Isosurface-Digest", kelvin::surface_digest(m));
              r.headers.emplace_back("X-Distlab-Surface-Check", surface_check_json(check).dump());
              r.headers.emplace_back("Content-Disposition", "attachment; filename=\"isosurface-" + object->id.substr(0, 8) + "." + format + "\"");
              return r;
            }};
  exp.heavy = true;
  exp.bounds = {"max_vertex_estimate", "isosurface_levels_per_request"};
  router_.add(std::move(exp));
}

}  // namespace distlab::server
