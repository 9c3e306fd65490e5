// The Service's streaming of a Kelvin object's msgpack frames to its session's sockets: one
// computation at a time per object, restarted while σ or the levels change (frames.hpp).
#include <chrono>
#include <cstdio>
#include <optional>

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

namespace {

using Ms = std::chrono::duration<double, std::milli>;

// What one round of frames sends, read under the object's lock; none while it is not ready.
struct FrameRound {
  std::shared_ptr<PreparedField> prepared;
  kelvin::SigmaSpec sigma, solved;  // per user vertex (values out), per welded vertex (field)
  std::string key;
  std::vector<double> levels;
  std::uint64_t version = 0, frames_version = 0;
  std::chrono::steady_clock::time_point sigma_at;
  bool send_surface = false, send_sigma = false;
};

std::optional<FrameRound> frame_round(KelvinObject& object, bool to_one_socket) {
  std::lock_guard lock(object.mutex);
  if (!object.ready()) return std::nullopt;
  FrameRound r{object.prepared, object.sigma, object.field_sigma, object.sigma_key, object.levels,
               object.sigma_version, object.frames_version, object.sigma_at, to_one_socket, false};
  // The geometry goes out once; then a new σ version sends σ per vertex only, and a change of the
  // watched levels alone sends neither.
  if (!to_one_socket) {
    if (!object.surface_sent) {
      r.send_surface = object.surface_sent = true;
      object.sigma_sent = static_cast<std::int64_t>(r.version);
    } else if (object.sigma_sent != static_cast<std::int64_t>(r.version)) {
      r.send_sigma = true;
      object.sigma_sent = static_cast<std::int64_t>(r.version);
    }
  }
  return r;
}

// The frame of watched level i: its iso-surface, or for a level the field never takes no
// geometry and the smallest h it does take; with the server's milliseconds.
json level_frame(const FrameRound& r, const std::string& object, std::size_t i) {
  const auto t0 = std::chrono::steady_clock::now();
  auto t1 = t0;
  double minimum = 0;
  mesh::SurfaceMesh iso = r.prepared->with_sigma(r.solved, r.key, false, [&](const kelvin::Field& f) {
    t1 = std::chrono::steady_clock::now();
    mesh::SurfaceMesh out = f.isosurface(r.levels[i]);
    if (out.faces.rows() == 0) minimum = f.minimum();
    return out;
  });
  const auto t2 = std::chrono::steady_clock::now();
  json frame = mesh_frame(iso, {{"type", "isosurface"}, {"object", object}, {"level", r.levels[i]}, {"index", i}, {"count", r.levels.size()}, {"sigma_version", r.version}, {"digest", kelvin::surface_digest(iso)}});
  if (iso.faces.rows() == 0) frame["empty"] = true, frame["h_min"] = minimum;
  frame["server_ms"] = {{"solve", Ms(t1 - t0).count()}, {"isosurface", Ms(t2 - t1).count()}};
  // From the σ edit's arrival to this frame (queueing included); 0 for the initial σ.
  if (r.version > 0) frame["server_ms"]["since_edit"] = Ms(std::chrono::steady_clock::now() - r.sigma_at).count();
  return frame;
}

}  // namespace

void KelvinModule::send_frames(const std::shared_ptr<Session>& session, const std::shared_ptr<KelvinObject>& object,
                               WsSink* only) {
  const std::optional<FrameRound> round = frame_round(*object, only != nullptr);
  if (!round) return;
  auto send = [&](const json& frame) {
    const std::string bytes = to_msgpack(frame);
    if (only != nullptr)
      only->send(bytes, true);
    else
      session->broadcast(bytes, true);
  };
  if (round->send_surface || round->send_sigma) {
    const std::vector<double> sigma_values = kelvin::evaluate_at_vertices(round->sigma, object->surface.vertices);
    if (round->send_surface)
      send(mesh_frame(object->surface, {{"type", "surface"}, {"object", object->id}, {"sigma_version", round->version}}, &sigma_values));
    else
      send(scalars_frame(sigma_values, {{"type", "surface_sigma"}, {"object", object->id}, {"sigma_version", round->version}}));
  }
  for (std::size_t i = 0; i < round->levels.size(); ++i) {
    // A newer σ or level set supersedes this one: stop, the scheduler computes the latest.
    {
      std::lock_guard lock(object->mutex);
      if (object->frames_version != round->frames_version) return;
    }
    send(level_frame(*round, object->id, i));
  }
  // The full solve a stroke a few edits later starts from (Field::background_work): its own
  // task, after these frames, beside the next edit's rather than inside it. Dropped when the
  // queue is full; that edit then solves it itself (same answer).
  if (auto work = round->prepared->background_work())
    compute_.post([prepared = round->prepared, work = std::move(work)] { work(); }, config_.limits.max_pending_requests);
}

}  // namespace distlab::server
