// Kelvin upload endpoints: the built-in assets, uploads (parsed in the isolated child), their reuse
// by digest, surfaces and defects, as a table (route_table.hpp) of the codec's decode and encode
// (kelvin_upload_codec.hpp) around these handlers. Objects are routes_kelvin.cpp's.
#include <algorithm>
#include <array>
#include <filesystem>

#include "distlab/geometry/types.hpp"
#include "distlab/mesh/checks.hpp"
#include "distlab/mesh/weld.hpp"
#include "distlab/server/kelvin_json.hpp"
#include "distlab/server/request_params.hpp"
#include "kelvin_module.hpp"

namespace distlab::server {

namespace fs = std::filesystem;

void KelvinModule::register_upload_routes() {
  using M = KelvinModule;
  const Limits& lim = config_.limits;
  add_routes<M>(router_, *this, lim,
                {{"GET", "/api/kelvin/assets", Work::light, {}, codec(decode_nothing, &M::list_assets, encode_assets)},
                 {"POST", "/api/kelvin/uploads", Work::heavy, {"max_upload_bytes", "max_upload_triangles", "max_uploads_per_session", "max_held_triangles_per_address", "max_held_triangles", "import_memory_bytes", "import_seconds"}, codec(decode_upload, &M::create_upload, encode_upload), lim.max_upload_bytes},
                 // Heavy: the answer welds the mesh (up to max_upload_triangles).
                 {"POST", "/api/kelvin/uploads/reuse", Work::heavy, {"max_body_bytes", "max_uploads_per_session", "max_held_triangles_per_address", "max_held_triangles"}, codec(decode_reuse, &M::reuse_upload, encode_upload)},
                 {"DELETE", "/api/kelvin/uploads/{id}", Work::light, {}, codec(decode_upload_id, &M::delete_upload, encode_no_content)},
                 {"GET", "/api/kelvin/uploads/{id}/surface", Work::light, {}, codec(decode_upload_id, &M::upload_surface, encode_upload_surface)},
                 {"GET", "/api/kelvin/uploads/{id}/defects", Work::heavy, {"max_upload_triangles", "max_defect_items"}, codec(decode_upload_id, &M::upload_defects, encode_upload_defects)}});
}

namespace {

// The welded surface's bounding box and the l_x that fit it (SizeReport).
SizeReport size_report(const mesh::SurfaceMesh& welded, const Limits& limits) {
  const Vec3 lo = welded.vertices.colwise().minCoeff().transpose();
  const Vec3 hi = welded.vertices.colwise().maxCoeff().transpose();
  SizeReport size{{lo.x(), lo.y(), lo.z()}, {hi.x(), hi.y(), hi.z()}, (hi - lo).norm(), std::nullopt};
  const double smallest = std::max(limits.min_lx, smallest_lx_within(welded, static_cast<double>(limits.max_vertex_estimate)));
  // The range's top is half the largest extent, not the diagonal: preparation refuses l_x beyond
  // the object's radius about its centre, which is at least half the largest extent (two surface
  // points that far apart are both within the radius).
  const double largest = 0.5 * (hi - lo).maxCoeff();
  if (smallest <= largest && size.diagonal > 0) size.lx_range = std::array<double, 2>{smallest, largest};
  return size;
}

}  // namespace

AssetNames KelvinModule::list_assets(const Nothing& /*none*/, const Caller& /*caller*/) {
  AssetNames assets;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(config_.assets_dir, ec)) {
    const std::string ext = e.path().extension().string();
    for (const char* known : kMeshExtensions)
      if (ext == known && valid_name(e.path().stem().string())) assets.names.push_back(e.path().stem().string());
  }
  std::sort(assets.names.begin(), assets.names.end());
  assets.names.erase(std::unique(assets.names.begin(), assets.names.end()), assets.names.end());
  return assets;
}

// The session and its room are checked before the parse, so that a refused caller costs none;
// add_upload checks the room again, under the lock that adds it.
UploadDescription KelvinModule::create_upload(const UploadFile& file, const Caller& caller) {
  auto session = require_session(caller);
  {
    std::lock_guard lock(session->mutex);
    require_upload_room(*session);
  }
  return add_upload(*session, read_upload(file, config_.limits));
}

void KelvinModule::require_upload_room(Session& session) const {
  if (uploads(session).uploads.size() >= config_.limits.max_uploads_per_session)
    throw ApiError(429, "too_many_uploads", "this session has too many uploads");
}

// A mesh this server holds (an upload of any session), by its digest, as an upload of this
// session: the answer says only whether it is held, and gives what the digest names.
UploadDescription KelvinModule::reuse_upload(const UploadDigest& in, const Caller& caller) {
  auto session = require_session(caller);
  std::shared_ptr<const Upload> up = held(in.digest);
  if (!up)
    throw ApiError(404, "upload_not_held", "this server holds no uploaded mesh with the digest " + in.digest + ": upload the file again", "digest");
  UploadDescription added = add_upload(*session, up);
  added.reused = true;
  return added;
}

// Gives the upload's triangles back to the client's share (objects made from it keep their own).
Nothing KelvinModule::delete_upload(const UploadId& in, const Caller& caller) {
  auto session = require_session(caller);
  std::lock_guard lock(session->mutex);
  if (uploads(*session).uploads.erase(in.id) == 0) throw ApiError(404, "unknown_upload", "no such upload in this session", "id");
  uploads(*session).held.erase(in.id);
  return {};
}

UploadSurface KelvinModule::upload_surface(const UploadId& in, const Caller& caller) {
  return {in.id, require_upload(*require_session(caller), in.id)};
}

UploadDefects KelvinModule::upload_defects(const UploadId& in, const Caller& caller) {
  const auto up = require_upload(*require_session(caller), in.id);
  const std::size_t max_items = config_.limits.max_defect_items;
  return {in.id, mesh::find_defects(up->surface, max_items), max_items};
}

std::shared_ptr<const Upload> KelvinModule::require_upload(Session& session, const std::string& id) {
  std::lock_guard lock(session.mutex);
  const auto& held = uploads(session).uploads;
  const auto it = held.find(id);
  if (it == held.end()) throw ApiError(404, "unknown_upload", "no such upload in this session", "id");
  return it->second;
}

// Adds the upload to the session (and to the server's index by digest); its description.
UploadDescription KelvinModule::add_upload(Session& session, const std::shared_ptr<const Upload>& up) {
  const Limits& lim = config_.limits;
  const std::string id = random_id();
  {
    std::lock_guard lock(session.mutex);
    require_upload_room(session);
    uploads(session).held.emplace(id, held_triangles_.reserve(session.address, static_cast<std::size_t>(up->surface.faces.rows()), "body"));
    uploads(session).uploads.emplace(id, up);
  }
  {
    std::lock_guard lock(held_mutex_);
    for (auto it = held_.begin(); it != held_.end();) it = it->second.expired() ? held_.erase(it) : std::next(it);
    held_[up->digest] = up;
  }
  return {id, up, size_report(mesh::weld(up->surface).surface, lim), false};
}

std::shared_ptr<const Upload> KelvinModule::held(const std::string& digest) {
  std::lock_guard lock(held_mutex_);
  const auto it = held_.find(digest);
  return it == held_.end() ? nullptr : it->second.lock();
}

}  // namespace distlab::server
