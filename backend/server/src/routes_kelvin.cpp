// Kelvin endpoints: assets, uploads, objects (prepare as a job), σ, queries, iso-surfaces
// (msgpack frames over the WebSocket and as downloads), exports.
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "distlab/geometry/error.hpp"
#include "distlab/kelvin/progress.hpp"
#include "distlab/kelvin/sigma.hpp"
#include "distlab/mesh/primitives.hpp"
#include "distlab/server/json_fields.hpp"
#include "distlab/server/deadline.hpp"
#include "distlab/server/frames.hpp"
#include "distlab/server/gap_json.hpp"
#include "distlab/server/kelvin_json.hpp"
#include "distlab/server/service.hpp"

namespace distlab::server {

using json = nlohmann::json;
namespace fs = std::filesystem;

namespace {

const char* kMeshExtensions[] = {".stl", ".ply", ".obj", ".glb", ".off"};

bool valid_name(const std::string& s) {
  if (s.empty() || s.size() > 64) return false;
  for (char c : s)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-') return false;
  return true;
}

std::vector<double> parse_levels(const json& j, const std::string& field, std::size_t max) {
  if (!j.is_array()) throw InvalidInput(field, field + " must be an array of numbers");
  if (j.size() > max) throw ApiError(413, "too_many_levels", "at most " + std::to_string(max) + " levels", field);
  std::vector<double> out;
  for (std::size_t i = 0; i < j.size(); ++i) out.push_back(json_number(j[i], field + "[" + std::to_string(i) + "]"));
  return out;
}

// A query parameter given more than once is refused, not silently reduced to its first value.
void single_query(const Request& req, const std::string& name) {
  if (req.repeated_query.count(name))
    throw InvalidInput(name, "query parameter " + name + " is given more than once");
}

double query_number(const Request& req, const std::string& name) {
  single_query(req, name);
  auto it = req.query.find(name);
  if (it == req.query.end()) throw InvalidInput(name, "query parameter " + name + " is required");
  try {
    std::size_t used = 0;
    const double v = std::stod(it->second, &used);
    if (used != it->second.size() || !std::isfinite(v)) throw std::invalid_argument("");
    return v;
  } catch (const std::exception&) {
    throw InvalidInput(name, "query parameter " + name + " must be a finite number");
  }
}

// The one level of GET .../isosurface and .../export (kIsosurfaceLevelsPerRequest): several levels
// are refused with the field, pointing to PUT .../levels (max_levels), whose frames carry them all.
double query_level(const Request& req) {
  static_assert(kIsosurfaceLevelsPerRequest == 1);
  if (req.repeated_query.count("level"))
    throw ApiError(413, "too_many_levels",
                   "one level per request; for several, PUT .../levels (at most max_levels) and read the "
                   "WebSocket's isosurface frames",
                   "level");
  return query_number(req, "level");
}

// Reads a mesh file through assimp (it needs a path): written to a private temporary file.
mesh::SurfaceMesh load_bytes(const std::string& bytes, const std::string& format, const std::string& dir) {
  const fs::path path = fs::path(dir) / ("upload-" + random_id() + "." + format);
  {
    std::ofstream f(path, std::ios::binary);
    f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    if (!f) throw std::runtime_error("cannot write a temporary upload file");
  }
  try {
    mesh::SurfaceMesh m = mesh::load_mesh(path.string(), "body");
    fs::remove(path);
    return m;
  } catch (...) {
    std::error_code ec;
    fs::remove(path, ec);
    throw;
  }
}

mesh::SurfaceMesh inline_mesh(const json& j, std::size_t max_triangles) {
  if (!j.is_object() || !j.contains("vertices") || !j.contains("faces"))
    throw InvalidInput("mesh", "mesh needs vertices [[x, y, z], ...] and faces [[i, j, k], ...]");
  const json& v = j["vertices"];
  const json& f = j["faces"];
  if (!v.is_array() || v.size() < 4) throw InvalidInput("mesh.vertices", "mesh.vertices must be an array of at least 4 points");
  if (!f.is_array() || f.size() < 4) throw InvalidInput("mesh.faces", "mesh.faces must be an array of at least 4 triangles");
  if (f.size() > max_triangles)
    throw ApiError(413, "too_many_triangles", "at most " + std::to_string(max_triangles) + " triangles", "mesh.faces");
  mesh::SurfaceMesh m;
  m.vertices.resize(static_cast<Eigen::Index>(v.size()), 3);
  for (std::size_t i = 0; i < v.size(); ++i) {
    const Vec3 p = json_vec3(v[i], "mesh.vertices[" + std::to_string(i) + "]");
    if (p.cwiseAbs().maxCoeff() > kMaxCoordinate) throw InvalidInput("mesh.vertices[" + std::to_string(i) + "]", "coordinate out of range");
    m.vertices.row(static_cast<Eigen::Index>(i)) = p.transpose();
  }
  m.faces.resize(static_cast<Eigen::Index>(f.size()), 3);
  for (std::size_t i = 0; i < f.size(); ++i) {
    const std::string field = "mesh.faces[" + std::to_string(i) + "]";
    if (!f[i].is_array() || f[i].size() != 3) throw InvalidInput(field, field + " must be 3 vertex indices");
    for (int c = 0; c < 3; ++c) {
      const json& x = f[i][static_cast<std::size_t>(c)];
      if (!x.is_number_integer() || x.get<std::int64_t>() < 0 || x.get<std::int64_t>() >= static_cast<std::int64_t>(v.size()))
        throw InvalidInput(field, field + " has an index out of range");
      m.faces(static_cast<Eigen::Index>(i), c) = static_cast<int>(x.get<std::int64_t>());
    }
  }
  return m;
}

}  // namespace

std::shared_ptr<KelvinObject> Service::require_object(const Session& session, const Request& request) {
  auto& s = const_cast<Session&>(session);
  std::lock_guard lock(s.mutex);
  auto it = s.objects.find(request.params.at("id"));
  if (it == s.objects.end()) throw ApiError(404, "unknown_object", "no such object in this session");
  return it->second;
}

json Service::create_object(const std::shared_ptr<Session>& session, const json& body) {
  const Limits& lim = config_.limits;
  if (!body.is_object()) throw InvalidInput("", "the request must be an object");
  for (const auto& [k, v] : body.items())
    if (k != "asset" && k != "upload" && k != "mesh" && k != "lx" && k != "center" && k != "far_radius" &&
        k != "sigma" && k != "levels" && k != "comment")
      throw InvalidInput(k, "unknown key \"" + k.substr(0, 64) + "\"");
  const int sources = static_cast<int>(body.contains("asset")) + static_cast<int>(body.contains("upload")) +
                      static_cast<int>(body.contains("mesh"));
  if (sources != 1) throw InvalidInput("", "give exactly one of asset, upload and mesh");
  if (!body.contains("lx")) throw InvalidInput("lx", "lx is required");
  kelvin::PrepareOptions options;
  options.lx = json_number(body["lx"], "lx");
  if (!(options.lx > 0)) throw InvalidInput("lx", "lx must be positive");
  if (options.lx < lim.min_lx)
    throw ApiError(422, "over_budget", "lx must be at least " + std::to_string(lim.min_lx) + " on this server", "lx");
  if (body.contains("center")) options.centre = json_vec3(body["center"], "center");
  if (body.contains("far_radius")) options.far_radius = json_number(body["far_radius"], "far_radius");
  json source = {{"lx", options.lx}};
  if (options.centre) source["center"] = {options.centre->x(), options.centre->y(), options.centre->z()};
  if (body.contains("far_radius")) source["far_radius"] = options.far_radius;

  mesh::SurfaceMesh surface;
  if (body.contains("asset")) {
    if (!body["asset"].is_string() || !valid_name(body["asset"])) throw InvalidInput("asset", "asset must be an asset name");
    const std::string name = body["asset"];
    std::string path;
    for (const char* ext : kMeshExtensions) {
      const fs::path p = fs::path(config_.assets_dir) / (name + ext);
      std::error_code ec;
      if (fs::is_regular_file(p, ec)) {
        path = p.string();
        break;
      }
    }
    if (path.empty()) throw ApiError(404, "unknown_asset", "no asset named \"" + name + "\"", "asset");
    surface = mesh::load_mesh(path, "asset");
    source["asset"] = name;
  } else if (body.contains("upload")) {
    if (!body["upload"].is_string()) throw InvalidInput("upload", "upload must be an upload id");
    std::lock_guard lock(session->mutex);
    auto it = session->uploads.find(body["upload"].get<std::string>());
    if (it == session->uploads.end()) throw ApiError(404, "unknown_upload", "no such upload in this session", "upload");
    surface = it->second->surface;
    source["upload"] = it->first;
  } else {
    surface = inline_mesh(body["mesh"], lim.max_upload_triangles);
    source["mesh"] = "inline";
  }
  if (static_cast<std::size_t>(surface.faces.rows()) > lim.max_upload_triangles)
    throw ApiError(413, "too_many_triangles", "at most " + std::to_string(lim.max_upload_triangles) + " triangles", "mesh");
  const double estimate = estimate_vertices(surface, options.lx);
  if (estimate > static_cast<double>(lim.max_vertex_estimate))
    throw ApiError(422, "over_budget",
                   "lx " + std::to_string(options.lx) + " would make about " + std::to_string(static_cast<long>(estimate)) +
                       " vertices, over this server's budget of " + std::to_string(lim.max_vertex_estimate) + "; use a larger lx",
                   "lx");
  source["vertex_estimate"] = static_cast<long>(estimate);

  auto object = std::make_shared<KelvinObject>();
  object->id = random_id();
  object->key = content_key(surface, options);
  object->source = source;
  object->surface = surface;
  if (body.contains("sigma")) {
    object->sigma = parse_sigma(body["sigma"]);
    kelvin::validate(object->sigma, surface.vertices.rows());
    object->sigma_json = body["sigma"];
    object->sigma_key = body["sigma"].dump();
  }
  if (body.contains("levels")) object->levels = parse_levels(body["levels"], "levels", lim.max_levels);
  {
    std::lock_guard lock(session->mutex);
    if (session->objects.size() >= lim.max_objects_per_session)
      throw ApiError(429, "too_many_objects",
                     "this session already has " + std::to_string(lim.max_objects_per_session) + " objects; delete one first");
    session->objects.emplace(object->id, object);
  }
  std::weak_ptr<Session> weak_session = session;
  std::shared_ptr<Job> job;
  try {
    job = jobs_.submit(session->id, "kelvin_prepare", {{"object", object->id}}, [this, object, options, weak_session](Job& j) {
      auto announce = [&] {
        if (auto s = weak_session.lock()) s->broadcast(json{{"type", "object"}, {"object", object->status_json()}}.dump(), false);
      };
      try {
        kelvin::Progress progress;
        progress.report = [&j](const std::string& stage, double fraction) { j.report(stage, fraction); };
        progress.cancel = &j.cancel;
        j.report("load", 0.0);
        bool from_memory = false;
        auto prepared = registry_.acquire(object->surface, options, progress, &from_memory);
        {
          std::lock_guard lock(object->mutex);
          object->prepared = prepared;
          object->shared = from_memory;
          object->state = "ready";
        }
        j.report("ready", 1.0);
        announce();
        if (auto s = weak_session.lock()) schedule_frames(s, object);
        const json status = object->status_json();
        return json{{"object", object->id}, {"stats", status.value("stats", json::object())}};
      } catch (const kelvin::Cancelled&) {
        {
          std::lock_guard lock(object->mutex);
          object->state = "cancelled";
        }
        announce();
        throw;
      } catch (const InvalidInput& e) {
        {
          std::lock_guard lock(object->mutex);
          object->state = j.cancelled() ? "cancelled" : "failed";
          object->error = {{"code", "invalid_input"}, {"message", e.what()}, {"field", e.field()}};
        }
        announce();
        throw;
      } catch (const std::exception& e) {
        {
          std::lock_guard lock(object->mutex);
          object->state = j.cancelled() ? "cancelled" : "failed";
          object->error = {{"code", "job_failed"}, {"message", e.what()}, {"field", ""}};
        }
        announce();
        throw;
      }
    });
  } catch (...) {
    std::lock_guard lock(session->mutex);
    session->objects.erase(object->id);
    throw;
  }
  {
    std::lock_guard lock(object->mutex);
    object->job = job->id;
  }
  return {{"object", object->status_json()}, {"job", job->to_json()}};
}

void Service::set_sigma(const std::shared_ptr<Session>& session, const std::shared_ptr<KelvinObject>& object,
                        const json& sigma_json, WsSink* origin, const json& request) {
  kelvin::SigmaSpec spec = parse_sigma(sigma_json);
  kelvin::validate(spec, object->surface.vertices.rows());
  std::uint64_t version;
  {
    std::lock_guard lock(object->mutex);
    object->sigma = std::move(spec);
    object->sigma_json = sigma_json;
    object->sigma_key = sigma_json.dump();
    version = ++object->sigma_version;
    object->sigma_at = std::chrono::steady_clock::now();
    ++object->frames_version;
  }
  json ack{{"type", "sigma"}, {"object", object->id}, {"sigma_version", version}};
  // The other sockets of the session learn of the new version; the sender's acknowledgement
  // echoes its request id (ids are the sender's own: another tab may use the same ones).
  session->broadcast(ack.dump(), false, origin);
  if (origin != nullptr) {
    if (!request.is_null()) ack["request"] = request;
    origin->send(ack.dump(), false);
  }
  schedule_frames(session, object);
}

void Service::set_levels(const std::shared_ptr<Session>& session, const std::shared_ptr<KelvinObject>& object,
                         const json& levels) {
  std::vector<double> parsed = parse_levels(levels, "levels", config_.limits.max_levels);
  {
    std::lock_guard lock(object->mutex);
    object->levels = std::move(parsed);
    ++object->frames_version;
  }
  schedule_frames(session, object);
}

void Service::schedule_frames(const std::shared_ptr<Session>& session, const std::shared_ptr<KelvinObject>& object) {
  {
    std::lock_guard lock(object->mutex);
    if (object->state != "ready" || object->computing) return;
    object->computing = true;
  }
  std::weak_ptr<Session> weak = session;
  const bool posted = compute_.post([this, weak, object] {
    for (;;) {
      std::uint64_t version;
      {
        std::lock_guard lock(object->mutex);
        version = object->frames_version;
      }
      if (auto s = weak.lock()) {
        try {
          send_frames(s, object);
        } catch (const std::exception& e) {
          s->broadcast(json{{"type", "error"}, {"status", 500},
                            {"error", {{"code", "frame_failed"}, {"message", e.what()}, {"field", ""}}}}.dump(), false);
        }
      }
      std::lock_guard lock(object->mutex);
      if (object->frames_version == version || weak.expired()) {
        object->computing = false;
        return;
      }
    }
  });
  if (!posted) {
    std::lock_guard lock(object->mutex);
    object->computing = false;
  }
}

void Service::send_frames(const std::shared_ptr<Session>& session, const std::shared_ptr<KelvinObject>& object,
                          WsSink* only) {
  using Ms = std::chrono::duration<double, std::milli>;
  std::shared_ptr<PreparedField> prepared;
  kelvin::SigmaSpec sigma;
  std::string key;
  std::vector<double> levels;
  std::uint64_t version, frames_version;
  std::chrono::steady_clock::time_point sigma_at;
  bool send_surface = only != nullptr, send_sigma = false;
  {
    std::lock_guard lock(object->mutex);
    if (object->state != "ready" || !object->prepared) return;
    prepared = object->prepared;
    sigma = object->sigma;
    key = object->sigma_key;
    levels = object->levels;
    version = object->sigma_version;
    frames_version = object->frames_version;
    sigma_at = object->sigma_at;
    // The geometry goes out once; then a new σ version sends σ per vertex only, and a change of
    // the watched levels alone sends neither.
    if (only == nullptr) {
      if (!object->surface_sent) {
        send_surface = object->surface_sent = true;
        object->sigma_sent = static_cast<std::int64_t>(version);
      } else if (object->sigma_sent != static_cast<std::int64_t>(version)) {
        send_sigma = true;
        object->sigma_sent = static_cast<std::int64_t>(version);
      }
    }
  }
  auto send = [&](const json& frame) {
    const std::string bytes = to_msgpack(frame);
    if (only != nullptr)
      only->send(bytes, true);
    else
      session->broadcast(bytes, true);
  };
  auto stale = [&] {
    std::lock_guard lock(object->mutex);
    return object->frames_version != frames_version;
  };
  if (send_surface || send_sigma) {
    const std::vector<double> sigma_values = sigma_at_vertices(sigma, object->surface);
    if (send_surface)
      send(mesh_frame(object->surface, {{"type", "surface"}, {"object", object->id}, {"sigma_version", version}}, &sigma_values));
    else
      send(scalars_frame(sigma_values, {{"type", "surface_sigma"}, {"object", object->id}, {"sigma_version", version}}));
  }
  for (std::size_t i = 0; i < levels.size(); ++i) {
    // A newer σ or level set supersedes this one: stop, the scheduler computes the latest.
    if (stale()) return;
    const auto t0 = std::chrono::steady_clock::now();
    auto t1 = t0;
    mesh::SurfaceMesh iso = prepared->with_sigma(sigma, key, false, [&](const kelvin::Field& f) {
      t1 = std::chrono::steady_clock::now();
      return f.isosurface(levels[i]);
    });
    const auto t2 = std::chrono::steady_clock::now();
    json frame = mesh_frame(iso, {{"type", "isosurface"}, {"object", object->id}, {"level", levels[i]}, {"index", i},
                                  {"count", levels.size()}, {"sigma_version", version}});
    frame["server_ms"] = {{"solve", Ms(t1 - t0).count()}, {"isosurface", Ms(t2 - t1).count()}};
    // From the σ edit's arrival to this frame (queueing included); 0 for the initial σ.
    if (version > 0) frame["server_ms"]["since_edit"] = Ms(std::chrono::steady_clock::now() - sigma_at).count();
    send(frame);
  }
}

void Service::register_kelvin_routes() {
  router_.add({"GET", "/api/kelvin/assets", [this](Request&) {
                 json list = json::array();
                 std::error_code ec;
                 std::vector<std::string> names;
                 for (const auto& e : fs::directory_iterator(config_.assets_dir, ec)) {
                   const std::string ext = e.path().extension().string();
                   for (const char* known : kMeshExtensions)
                     if (ext == known && valid_name(e.path().stem().string())) names.push_back(e.path().stem().string());
                 }
                 std::sort(names.begin(), names.end());
                 names.erase(std::unique(names.begin(), names.end()), names.end());
                 for (const auto& n : names) list.push_back(n);
                 return json_response(200, {{"assets", list}});
               }});

  Route upload{"POST", "/api/kelvin/uploads", [this](Request& req) {
                 auto session = require_session(req);
                 const Limits& lim = config_.limits;
                 auto it = req.query.find("format");
                 if (it == req.query.end()) throw InvalidInput("format", "query parameter format is required (stl, obj, ply, glb, off)");
                 const std::string format = it->second;
                 if (format != "stl" && format != "obj" && format != "ply" && format != "glb" && format != "off")
                   throw InvalidInput("format", "format must be stl, obj, ply, glb or off");
                 if (req.body.empty()) throw ApiError(400, "empty_body", "the upload is empty");
                 // Binary STL states its triangle count up front: refuse before parsing (after the
                 // size check, so that garbage is called invalid rather than too large).
                 if (format == "stl")
                   if (const auto n = mesh::binary_stl_triangles(req.body, "body"); n && *n > lim.max_upload_triangles)
                     throw ApiError(413, "too_many_triangles", "at most " + std::to_string(lim.max_upload_triangles) + " triangles", "body");
                 {
                   std::lock_guard lock(session->mutex);
                   if (session->uploads.size() >= lim.max_uploads_per_session)
                     throw ApiError(429, "too_many_uploads", "this session has too many uploads");
                 }
                 auto up = std::make_shared<Upload>();
                 up->surface = load_bytes(req.body, format, registry_cache_dir());
                 up->format = format;
                 up->bytes = req.body.size();
                 if (static_cast<std::size_t>(up->surface.faces.rows()) > lim.max_upload_triangles)
                   throw ApiError(413, "too_many_triangles", "at most " + std::to_string(lim.max_upload_triangles) + " triangles", "body");
                 const std::string id = random_id();
                 {
                   std::lock_guard lock(session->mutex);
                   session->uploads.emplace(id, up);
                 }
                 return json_response(201, {{"upload", id}, {"n_vertices", up->surface.vertices.rows()},
                                            {"n_faces", up->surface.faces.rows()}});
               }};
  upload.heavy = true;
  upload.bounds = {"max_upload_bytes", "max_upload_triangles", "max_uploads_per_session"};
  upload.body_limit = config_.limits.max_upload_bytes;
  router_.add(std::move(upload));

  Route create{"POST", "/api/kelvin/objects", [this](Request& req) {
                 auto session = require_session(req);
                 return json_response(202, create_object(session, parse_body(req)));
               }};
  create.heavy = true;
  create.bounds = {"max_body_bytes", "max_upload_triangles", "min_lx", "max_vertex_estimate", "max_objects_per_session", "max_jobs_per_session", "max_jobs_total"};
  router_.add(std::move(create));

  router_.add({"GET", "/api/kelvin/objects", [this](Request& req) {
                 auto session = require_session(req);
                 std::vector<std::shared_ptr<KelvinObject>> objects;
                 {
                   std::lock_guard lock(session->mutex);
                   for (const auto& [id, o] : session->objects) objects.push_back(o);
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
                   session->objects.erase(object->id);
                 }
                 Response r;
                 r.status = 204;
                 r.content_type.clear();
                 return r;
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
                 if (!body.is_object() || !body.contains("levels")) throw InvalidInput("levels", "levels is required");
                 set_levels(session, object, body["levels"]);
                 std::lock_guard lock(object->mutex);
                 return json_response(200, {{"levels", object->levels}});
               }});

  auto ready = [](const std::shared_ptr<KelvinObject>& o, kelvin::SigmaSpec& sigma, std::string& key,
                  std::uint64_t& version) {
    std::lock_guard lock(o->mutex);
    if (o->state != "ready" || !o->prepared)
      throw ApiError(409, "not_ready", "the object is " + o->state + ", not ready");
    sigma = o->sigma;
    key = o->sigma_key;
    version = o->sigma_version;
    return o->prepared;
  };

  Route query{"POST", "/api/kelvin/objects/{id}/query", [this, ready](Request& req) {
                auto session = require_session(req);
                auto object = require_object(*session, req);
                const json body = parse_body(req);
                if (!body.is_object() || !body.contains("points") || !body["points"].is_array())
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
                  grad.push_back(ok ? json::array({s.gradient.x(), s.gradient.y(), s.gradient.z()}) : json(nullptr));
                  inside.push_back(s.status == kelvin::Status::inside);
                }
                return json_response(200, {{"h", h}, {"gradient", grad}, {"inside", inside}, {"sigma_version", version}});
              }};
  query.heavy = true;
  query.bounds = {"max_body_bytes", "max_query_points", "max_request_seconds"};
  router_.add(std::move(query));

  Route iso{"GET", "/api/kelvin/objects/{id}/isosurface", [this, ready](Request& req) {
              auto session = require_session(req);
              auto object = require_object(*session, req);
              const double level = query_level(req);
              kelvin::SigmaSpec sigma;
              std::string key;
              std::uint64_t version;
              auto prepared = ready(object, sigma, key, version);
              const mesh::SurfaceMesh m = prepared->with_sigma(sigma, key, false, [&](const kelvin::Field& f) { return f.isosurface(level); });
              Response r;
              r.content_type = "application/msgpack";
              r.body = to_msgpack(mesh_frame(m, {{"type", "isosurface"}, {"object", object->id}, {"level", level},
                                                 {"index", 0}, {"count", 1}, {"sigma_version", version}}));
              return r;
            }};
  iso.heavy = true;
  iso.bounds = {"max_vertex_estimate", "isosurface_levels_per_request"};
  router_.add(std::move(iso));

  router_.add({"GET", "/api/kelvin/objects/{id}/surface", [this](Request& req) {
                 auto session = require_session(req);
                 auto object = require_object(*session, req);
                 kelvin::SigmaSpec sigma;
                 std::uint64_t version;
                 {
                   std::lock_guard lock(object->mutex);
                   sigma = object->sigma;
                   version = object->sigma_version;
                 }
                 const std::vector<double> values = sigma_at_vertices(sigma, object->surface);
                 Response r;
                 r.content_type = "application/msgpack";
                 r.body = to_msgpack(mesh_frame(object->surface, {{"type", "surface"}, {"object", object->id}, {"sigma_version", version}}, &values));
                 return r;
               }});

  Route exp{"GET", "/api/kelvin/objects/{id}/export", [this, ready](Request& req) {
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
              const mesh::SurfaceMesh m = prepared->with_sigma(sigma, key, false, [&](const kelvin::Field& f) { return f.isosurface(level); });
              if (m.faces.rows() == 0) throw ApiError(422, "empty_isosurface", "the iso-surface at this level is empty", "level");
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
              r.headers.emplace_back("Content-Disposition", "attachment; filename=\"isosurface-" + object->id.substr(0, 8) + "." + format + "\"");
              return r;
            }};
  exp.heavy = true;
  exp.bounds = {"max_vertex_estimate", "isosurface_levels_per_request"};
  router_.add(std::move(exp));
}

}  // namespace distlab::server
