// Kelvin upload endpoints: the built-in assets, uploads (parsed in the isolated child), their reuse
// by digest, surfaces and defects. Objects are routes_kelvin.cpp's.
#include <algorithm>
#include <filesystem>

#include "distlab/geometry/error.hpp"
#include "distlab/mesh/checks.hpp"
#include "distlab/mesh/weld.hpp"
#include "distlab/server/frames.hpp"
#include "distlab/server/json_fields.hpp"
#include "distlab/server/request_params.hpp"
#include "kelvin_inputs.hpp"
#include "kelvin_module.hpp"

namespace distlab::server {

using json = nlohmann::json;
namespace fs = std::filesystem;

namespace {

// A digest as the API writes it: 64 lower-case hex digits (kelvin::Sha256::hex).
std::string valid_digest(const std::string& text, const std::string& field) {
  const bool ok = text.size() == 64 && std::all_of(text.begin(), text.end(), [](char c) { return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'); });
  if (!ok) throw InvalidInput(field, field + " must be 64 lower-case hex digits (an upload's digest)");
  return text;
}

// GET /api/kelvin/uploads/{id}/defects: counts, then the lists (at most max_items entries each).
json defects_json(const std::string& id, const mesh::MeshDefects& d, std::size_t max_items) {
  json pieces = json::array();
  for (const auto& p : d.pieces) pieces.push_back({{"faces", p.faces}, {"volume", p.volume}, {"runs", p.runs}});
  return {{"upload", id},
          {"counts", {{"boundary_edges", d.boundary_edges}, {"non_manifold_edges", d.non_manifold_edges}, {"non_manifold_vertices", d.non_manifold_vertices}, {"degenerate_faces", d.degenerate_faces}, {"self_intersections", d.self_intersections}, {"components", d.pieces.size()}}},
          {"self_intersections_complete", d.self_intersections_complete},
          {"unchecked_faces", d.unchecked_faces},
          {"boundary_edges", d.boundary},
          {"non_manifold_edges", d.non_manifold},
          {"non_manifold_vertices", d.pinched},
          {"degenerate_faces", d.degenerate},
          {"self_intersections", d.intersecting},
          {"components", pieces},
          {"largest_component", d.largest},
          {"max_items", max_items},
          {"truncated", d.truncated}};
}

}  // namespace

std::shared_ptr<const Upload> KelvinModule::require_upload(Session& session, const Request& request) {
  std::lock_guard lock(session.mutex);
  const auto& held = uploads(session).uploads;
  const auto it = held.find(request.params.at("id"));
  if (it == held.end()) throw ApiError(404, "unknown_upload", "no such upload in this session", "id");
  return it->second;
}

// Adds the upload to the session (and to the server's index by digest); its description.
json KelvinModule::add_upload(Session& session, const std::shared_ptr<const Upload>& up) {
  const Limits& lim = config_.limits;
  const std::string id = random_id();
  {
    std::lock_guard lock(session.mutex);
    if (uploads(session).uploads.size() >= lim.max_uploads_per_session)
      throw ApiError(429, "too_many_uploads", "this session has too many uploads");
    uploads(session).held.emplace(id, held_triangles_.reserve(session.address, static_cast<std::size_t>(up->surface.faces.rows()), "body"));
    uploads(session).uploads.emplace(id, up);
  }
  {
    std::lock_guard lock(held_mutex_);
    for (auto it = held_.begin(); it != held_.end();) it = it->second.expired() ? held_.erase(it) : std::next(it);
    held_[up->digest] = up;
  }
  json answer = {{"upload", id}, {"n_vertices", up->surface.vertices.rows()}, {"n_faces", up->surface.faces.rows()}, {"scale", up->scale}, {"digest", up->digest}, {"bytes", up->bytes}, {"format", up->format}};
  if (!up->unit.empty()) answer["unit"] = up->unit;
  answer.update(size_report(mesh::weld(up->surface).surface, lim));
  return answer;
}

std::shared_ptr<const Upload> KelvinModule::held(const std::string& digest) {
  std::lock_guard lock(held_mutex_);
  const auto it = held_.find(digest);
  return it == held_.end() ? nullptr : it->second.lock();
}

void KelvinModule::register_upload_routes() {
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
                   if (uploads(*session).uploads.size() >= lim.max_uploads_per_session)
                     throw ApiError(429, "too_many_uploads", "this session has too many uploads");
                 }
                 // The file's unit: a name or a factor to metres (not both); metres by default.
                 if (req.query.count("unit") && req.query.count("scale"))
                   throw InvalidInput("scale", "give unit or scale, not both");
                 double scale = 1.0;
                 std::string unit = "m";
                 if (auto u = req.query.find("unit"); u != req.query.end()) {
                   single_query(req, "unit");
                   scale = unit_scale(u->second);
                   unit = u->second;
                 } else if (req.query.count("scale")) {
                   scale = query_number(req, "scale");
                   if (!(scale > 0) || scale > kMaxCoordinate) throw InvalidInput("scale", "scale must be in (0, 1e6] (metres per file unit)");
                   unit = "";
                 }
                 // A link's upload again (POST .../uploads/reuse answered 404): the mesh must be the
                 // one the link names.
                 std::string expected;
                 if (req.query.count("digest")) {
                   single_query(req, "digest");
                   expected = valid_digest(req.query.at("digest"), "digest");
                 }
                 auto up = std::make_shared<Upload>();
                 up->surface = load_bytes(req.body, format, lim, scale);
                 up->format = format;
                 up->bytes = req.body.size();
                 up->unit = unit;
                 up->scale = scale;
                 if (static_cast<std::size_t>(up->surface.faces.rows()) > lim.max_upload_triangles)
                   throw ApiError(413, "too_many_triangles", "at most " + std::to_string(lim.max_upload_triangles) + " triangles", "body");
                 up->digest = kelvin::surface_digest(up->surface);
                 if (!expected.empty() && up->digest != expected)
                   throw ApiError(422, "different_mesh",
                                  "this file's mesh has the digest " + up->digest + ", not the expected " + expected +
                                      ": it is another file, or the same file read in another unit",
                                  "body");
                 return json_response(201, add_upload(*session, up));
               }};
  upload.heavy = true;
  upload.bounds = {"max_upload_bytes", "max_upload_triangles", "max_uploads_per_session", "max_held_triangles_per_address", "max_held_triangles", "import_memory_bytes", "import_seconds"};
  upload.body_limit = config_.limits.max_upload_bytes;
  router_.add(std::move(upload));

  // A mesh this server holds (an upload of any session), by its digest, as an upload of this
  // session: the answer says only whether it is held, and gives what the digest names.
  Route reuse{"POST", "/api/kelvin/uploads/reuse", [this](Request& req) {
                auto session = require_session(req);
                const json body = parse_body(req);
                json_require_object(body, "");
                json_check_keys(body, "", {"digest", "comment"});
                if (!body.contains("digest") || !body["digest"].is_string()) throw InvalidInput("digest", "digest is required (64 hex digits)");
                const std::string digest = valid_digest(body["digest"].get<std::string>(), "digest");
                std::shared_ptr<const Upload> up = held(digest);
                if (!up)
                  throw ApiError(404, "upload_not_held",
                                 "this server holds no uploaded mesh with the digest " + digest + ": upload the file again", "digest");
                json answer = add_upload(*session, up);
                answer["reused"] = true;
                return json_response(201, answer);
              }};
  reuse.heavy = true;  // the answer welds the mesh (up to max_upload_triangles)
  reuse.bounds = {"max_body_bytes", "max_uploads_per_session", "max_held_triangles_per_address", "max_held_triangles"};
  router_.add(std::move(reuse));

  // Gives the upload's triangles back to the client's share (objects made from it keep their own).
  router_.add({"DELETE", "/api/kelvin/uploads/{id}", [this](Request& req) {
                 auto session = require_session(req);
                 std::lock_guard lock(session->mutex);
                 if (uploads(*session).uploads.erase(req.params.at("id")) == 0) throw ApiError(404, "unknown_upload", "no such upload in this session", "id");
                 uploads(*session).held.erase(req.params.at("id"));
                 return no_content_response();
               }});

  router_.add({"GET", "/api/kelvin/uploads/{id}/surface", [this](Request& req) {
                 auto session = require_session(req);
                 const auto up = require_upload(*session, req);
                 Response r;
                 r.content_type = "application/msgpack";
                 r.body = to_msgpack(mesh_frame(up->surface, {{"type", "surface"}, {"of", "upload"}, {"upload", req.params.at("id")}, {"digest", up->digest}}));
                 return r;
               }});

  Route defects{"GET", "/api/kelvin/uploads/{id}/defects", [this](Request& req) {
                  auto session = require_session(req);
                  const auto up = require_upload(*session, req);
                  return json_response(200, defects_json(req.params.at("id"), mesh::find_defects(up->surface, config_.limits.max_defect_items), config_.limits.max_defect_items));
                }};
  defects.heavy = true;
  defects.bounds = {"max_upload_triangles", "max_defect_items"};
  router_.add(std::move(defects));
}

}  // namespace distlab::server
