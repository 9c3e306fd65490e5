// The Kelvin object routes' handlers besides creation (kelvin_service.cpp): lookup, deletion, σ
// and levels edits (the WebSocket's too), queries, iso-surfaces, the surface and exports.
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "distlab/geometry/error.hpp"
#include "distlab/kelvin/sigma.hpp"
#include "distlab/mesh/checks.hpp"
#include "distlab/mesh/repair.hpp"
#include "distlab/server/deadline.hpp"
#include "distlab/server/request_params.hpp"
#include "kelvin_module.hpp"

namespace distlab::server {

namespace fs = std::filesystem;

namespace {

// The iso-surface of one level, or 422 empty_isosurface when the field never takes it.
mesh::SurfaceMesh nonempty_isosurface(PreparedField& prepared, const kelvin::SigmaSpec& sigma, const std::string& key, double level) {
  double minimum = 0;
  mesh::SurfaceMesh m = prepared.with_sigma(sigma, key, false, [&](const kelvin::Field& f) {
    mesh::SurfaceMesh out = f.isosurface(level);
    if (out.faces.rows() == 0) minimum = f.minimum();
    return out;
  });
  if (m.faces.rows() == 0)
    throw ApiError(422, "empty_isosurface",
                   "the field never takes h = " + number_text(level) + ": its smallest value is h = " + number_text(minimum) +
                       " (where σ is smallest on the surface), and {h = level} is empty for every level below it",
                   "level");
  return m;
}

// The file's bytes as mesh::save_mesh writes them (through a private directory of the cache).
std::string mesh_file_bytes(const mesh::SurfaceMesh& m, const std::string& format, const std::string& cache_dir) {
  const fs::path dir = fs::path(cache_dir) / ("export-" + random_id());
  fs::create_directories(dir);
  std::ostringstream ss;
  try {
    const fs::path file = dir / ("isosurface." + format);
    mesh::save_mesh(m, file.string(), format, "format");
    std::ifstream in(file, std::ios::binary);
    ss << in.rdbuf();
  } catch (...) {
    std::error_code ec;
    fs::remove_all(dir, ec);
    throw;
  }
  std::error_code ec;
  fs::remove_all(dir, ec);
  return ss.str();
}

}  // namespace

std::shared_ptr<KelvinObject> KelvinModule::require_object(Session& session, const std::string& id) {
  std::lock_guard lock(session.mutex);
  auto it = kelvin_state(session).objects.find(id);
  if (it == kelvin_state(session).objects.end()) throw ApiError(404, "unknown_object", "no such object in this session");
  return it->second;
}

KelvinModule::ReadyField KelvinModule::ready_field(KelvinObject& object) {
  std::lock_guard lock(object.mutex);
  if (!object.ready())
    throw ApiError(409, "not_ready", std::string("the object is ") + object_state_name(object.state, object.stage) + ", not ready");
  return {object.prepared, object.field_sigma, object.sigma_key, object.sigma_version};
}

ObjectList KelvinModule::list_objects(const Nothing& /*none*/, const Caller& caller) {
  auto session = require_session(caller);
  ObjectList list;
  std::lock_guard lock(session->mutex);
  for (const auto& [id, o] : kelvin_state(*session).objects) list.objects.push_back(o);
  return list;
}

std::shared_ptr<KelvinObject> KelvinModule::get_object(const ObjectRef& in, const Caller& caller) {
  return require_object(*require_session(caller), in.id);
}

Nothing KelvinModule::delete_object(const ObjectRef& in, const Caller& caller) {
  auto session = require_session(caller);
  auto object = require_object(*session, in.id);
  std::string job;
  {
    std::lock_guard lock(object->mutex);
    job = object->job;
  }
  if (auto j = jobs_.find(session->id, job)) j->cancel = true;
  std::lock_guard lock(session->mutex);
  kelvin_state(*session).objects.erase(object->id);
  return {};
}

SigmaState KelvinModule::get_sigma(const ObjectRef& in, const Caller& caller) {
  auto object = require_object(*require_session(caller), in.id);
  std::lock_guard lock(object->mutex);
  return {object->sigma_given, object->sigma_version};
}

SigmaState KelvinModule::put_sigma(const SigmaRequest& in, const Caller& caller) {
  auto session = require_session(caller);
  auto object = require_object(*session, in.id);
  set_sigma(session, object, in.sigma);
  std::lock_guard lock(object->mutex);
  return {object->sigma_given, object->sigma_version};
}

std::vector<double> KelvinModule::put_levels(const LevelsRequest& in, const Caller& caller) {
  auto session = require_session(caller);
  auto object = require_object(*session, in.id);
  set_levels(session, object, in.levels);
  std::lock_guard lock(object->mutex);
  return object->levels;
}

QueryResult KelvinModule::query(const QueryRequest& in, const Caller& caller) {
  auto object = require_object(*require_session(caller), in.id);
  const ReadyField ready = ready_field(*object);
  // In chunks, so the time limit is checked while a large query runs.
  const Deadline deadline(config_.limits.max_request_seconds);
  const std::size_t chunk = std::max<std::size_t>(1, config_.limits.query_chunk_points);
  const auto& points = in.points;
  QueryResult out{{}, ready.version};
  out.samples = ready.prepared->with_sigma(ready.sigma, ready.key, true, [&](const kelvin::Field& f) {
    std::vector<kelvin::Sample> samples;
    samples.reserve(points.size());
    for (std::size_t begin = 0; begin < points.size(); begin += chunk) {
      deadline.check("query fewer points per request");
      const std::vector<Vec3> part(points.begin() + static_cast<std::ptrdiff_t>(begin),
                                   points.begin() + static_cast<std::ptrdiff_t>(std::min(points.size(), begin + chunk)));
      for (const kelvin::Sample& x : f.query(part)) samples.push_back(x);
    }
    return samples;
  });
  return out;
}

Isosurface KelvinModule::isosurface(const LevelRequest& in, const Caller& caller) {
  auto object = require_object(*require_session(caller), in.id);
  const ReadyField ready = ready_field(*object);
  return {object->id, in.level, ready.version, nonempty_isosurface(*ready.prepared, ready.sigma, ready.key, in.level)};
}

ExportFile KelvinModule::export_isosurface(const LevelRequest& in, const Caller& caller) {
  auto object = require_object(*require_session(caller), in.id);
  const ReadyField ready = ready_field(*object);
  const mesh::SurfaceMesh m = nonempty_isosurface(*ready.prepared, ready.sigma, ready.key, in.level);
  const mesh::SurfaceReport check = mesh::inspect_surface(m);
  if (!check.manifold())
    throw ApiError(422, "not_manifold",
                   "the iso-surface at h = " + number_text(in.level) + " is not a closed 2-manifold (" + mesh::surface_defects(check) +
                       "); not exported",
                   "level");
  return {object->id, in.format, mesh_file_bytes(m, in.format, registry_cache_dir()), kelvin::surface_digest(m), check};
}

SurfaceView KelvinModule::surface(const SurfaceRequest& in, const Caller& caller) {
  auto object = require_object(*require_session(caller), in.id);
  kelvin::SigmaSpec sigma, solved;
  SurfaceView view{object, &object->surface, in.repaired, 0, {}};
  bool repaired = false;
  {
    std::lock_guard lock(object->mutex);
    sigma = object->sigma;
    solved = object->field_sigma;
    view.sigma_version = object->sigma_version;
    // None while repairing, nor after a repair that failed or was cancelled.
    repaired = object->reshaped() && object->repaired.faces.rows() > 0;
  }
  if (in.repaired && !repaired)
    throw ApiError(409, "not_repaired",
                   "this object has no repaired surface (repair none, still repairing, or the repair failed or was cancelled)", "of");
  // A repaired object's σ at the user's vertices is what the field solves, read back by the same
  // nearest-face rule that carried it there (repair.hpp).
  if (!repaired) view.sigma = kelvin::evaluate_at_vertices(sigma, object->surface.vertices);
  else if (in.repaired) view.sigma = kelvin::evaluate_at_vertices(solved, object->repaired.vertices);
  else view.sigma = mesh::nearest_face_transfer(object->repaired, object->surface.vertices).apply(kelvin::evaluate_at_vertices(solved, object->repaired.vertices));
  if (in.repaired) view.shown = &object->repaired;
  return view;
}

void KelvinModule::set_sigma(const std::shared_ptr<Session>& session, const std::shared_ptr<KelvinObject>& object,
                             const SigmaEdit& sigma, WsSink* origin, const nlohmann::json& request) {
  kelvin::SigmaSpec spec = sigma.spec;
  // surface, welded and to_welded are set at creation and never change: no lock needed.
  kelvin::SigmaSpec solved = kelvin::field_sigma(spec, object->surface.vertices, object->to_welded, object->welded.vertices.rows());
  std::uint64_t version;
  {
    std::lock_guard lock(object->mutex);
    // A repaired object carries σ to its repaired surface once that exists (the job does it then).
    if (object->reshaped() && object->repaired.faces.rows() > 0) solved = field_sigma(spec, *object);
    object->sigma = std::move(spec);
    object->field_sigma = std::move(solved);
    object->sigma_given = sigma.given;
    object->sigma_key = sigma_key(*object, sigma.given);
    version = ++object->sigma_version;
    object->sigma_at = std::chrono::steady_clock::now();
    ++object->frames_version;
  }
  nlohmann::json ack{{"type", "sigma"}, {"object", object->id}, {"sigma_version", version}};
  // The other sockets of the session learn of the new version; the sender's acknowledgement
  // echoes its request id (ids are the sender's own: another tab may use the same ones).
  session->broadcast(ack.dump(), false, origin);
  if (origin != nullptr) {
    if (!request.is_null()) ack["request"] = request;
    origin->send(ack.dump(), false);
  }
  schedule_frames(session, object);
}

void KelvinModule::set_levels(const std::shared_ptr<Session>& session, const std::shared_ptr<KelvinObject>& object,
                              std::vector<double> levels) {
  {
    std::lock_guard lock(object->mutex);
    object->levels = std::move(levels);
    ++object->frames_version;
  }
  schedule_frames(session, object);
}

}  // namespace distlab::server
