// The Service's streaming of a Kelvin object's msgpack frames to its session's sockets: one
// computation at a time per object, restarted while σ or the levels change (frames.hpp).
#include <chrono>
#include <cstdio>

#include "distlab/geometry/error.hpp"
#include "distlab/server/frames.hpp"
#include "kelvin_module.hpp"

namespace distlab::server {

using json = nlohmann::json;

void KelvinModule::schedule_frames(const std::shared_ptr<Session>& session, const std::shared_ptr<KelvinObject>& object) {
  {
    std::lock_guard lock(object->mutex);
    if (object->state != Lifecycle::succeeded || object->computing) return;
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
        } catch (const std::exception&) {
          const ErrorAnswer a = error_answer(std::current_exception(), "frame_failed", "internal error (logged on the server)", "frames failed");
          s->broadcast(json{{"type", "error"}, {"status", a.status}, {"error", a.body()}}.dump(), false);
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

void KelvinModule::send_frames(const std::shared_ptr<Session>& session, const std::shared_ptr<KelvinObject>& object,
                               WsSink* only) {
  using Ms = std::chrono::duration<double, std::milli>;
  std::shared_ptr<PreparedField> prepared;
  kelvin::SigmaSpec sigma, solved;  // per user vertex (values out), per welded vertex (field)
  std::string key;
  std::vector<double> levels;
  std::uint64_t version, frames_version;
  std::chrono::steady_clock::time_point sigma_at;
  bool send_surface = only != nullptr, send_sigma = false;
  {
    std::lock_guard lock(object->mutex);
    if (!object->ready()) return;
    prepared = object->prepared;
    sigma = object->sigma;
    solved = object->field_sigma;
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
    const std::vector<double> sigma_values = kelvin::evaluate_at_vertices(sigma, object->surface.vertices);
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
    double minimum = 0;
    mesh::SurfaceMesh iso = prepared->with_sigma(solved, key, false, [&](const kelvin::Field& f) {
      t1 = std::chrono::steady_clock::now();
      mesh::SurfaceMesh out = f.isosurface(levels[i]);
      if (out.faces.rows() == 0) minimum = f.minimum();
      return out;
    });
    const auto t2 = std::chrono::steady_clock::now();
    json frame = mesh_frame(iso, {{"type", "isosurface"}, {"object", object->id}, {"level", levels[i]}, {"index", i}, {"count", levels.size()}, {"sigma_version", version}, {"digest", kelvin::surface_digest(iso)}});
    // A level the field never takes: no geometry, and the smallest h it does take.
    if (iso.faces.rows() == 0) frame["empty"] = true, frame["h_min"] = minimum;
    frame["server_ms"] = {{"solve", Ms(t1 - t0).count()}, {"isosurface", Ms(t2 - t1).count()}};
    // From the σ edit's arrival to this frame (queueing included); 0 for the initial σ.
    if (version > 0) frame["server_ms"]["since_edit"] = Ms(std::chrono::steady_clock::now() - sigma_at).count();
    send(frame);
  }
  // The full solve a stroke a few edits later starts from (Field::background_work): its own
  // task, after these frames, beside the next edit's rather than inside it. Dropped when the
  // queue is full; that edit then solves it itself (same answer).
  if (auto work = prepared->background_work())
    compute_.post([prepared, work = std::move(work)] { work(); }, config_.limits.max_pending_requests);
}

}  // namespace distlab::server
