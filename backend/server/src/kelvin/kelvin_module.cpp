// The Kelvin module's part of the WebSocket protocol and of the session's state.
#include "kelvin_module.hpp"

#include "distlab/geometry/error.hpp"
#include "distlab/kelvin/sigma.hpp"
#include "distlab/server/json_fields.hpp"

namespace distlab::server {

using json = nlohmann::json;

// {"type": "watch", "object", "levels"} | {"type": "sigma", "object", "sigma"}.
void KelvinModule::ws_message(const std::shared_ptr<Session>& session, const std::shared_ptr<WsSink>& socket,
                              const json& msg, const json& request) {
  const std::string type = msg["type"];
  auto object = [&]() {
    if (!msg.contains("object") || !msg["object"].is_string()) throw InvalidInput("object", "object must be an object id");
    std::lock_guard lock(session->mutex);
    auto it = kelvin_state(*session).objects.find(msg["object"].get<std::string>());
    if (it == kelvin_state(*session).objects.end()) throw ApiError(404, "unknown_object", "no such object in this session", "object");
    return it->second;
  };
  // The same checks as PUT .../levels and .../sigma (kelvin_codec.hpp), after the object's.
  if (type == "watch") {
    json_check_keys(msg, "", {"type", "request", "object", "levels"});
    const json& levels = required_field(msg, "levels");
    const auto o = object();
    set_levels(session, o, decode_levels(levels, config_.limits));
  } else {  // "sigma"
    json_check_keys(msg, "", {"type", "request", "object", "sigma"});
    const json& sigma = required_field(msg, "sigma");
    const auto o = object();
    set_sigma(session, o, decode_sigma(sigma), socket.get(), request);
  }
}

void KelvinModule::add_limits(json& limits) const {
  limits["isosurface_levels_per_request"] = kIsosurfaceLevelsPerRequest;
  limits["max_abs_sigma"] = kelvin::kMaxAbsSigma;  // a property of the method (sigma.hpp)
}

void KelvinModule::add_state(Session& session, json& hello) {
  std::vector<std::shared_ptr<KelvinObject>> objects;
  {
    std::lock_guard lock(session.mutex);
    for (const auto& [id, o] : kelvin_state(session).objects) objects.push_back(o);
  }
  json objs = json::array();
  for (const auto& o : objects) objs.push_back(o->status_json());
  hello["objects"] = objs;
}

// Every ready object's surface with the current σ, and the frames of its watched levels.
void KelvinModule::joined(const std::shared_ptr<Session>& session, const std::shared_ptr<WsSink>& socket) {
  std::vector<std::shared_ptr<KelvinObject>> objects;
  {
    std::lock_guard lock(session->mutex);
    for (const auto& [id, o] : kelvin_state(*session).objects) objects.push_back(o);
  }
  for (const auto& o : objects) {
    bool ready;
    {
      std::lock_guard lock(o->mutex);
      ready = o->state == Lifecycle::succeeded;
    }
    if (ready) {
      auto weak = std::weak_ptr<WsSink>(socket);
      post_compute([this, session, o, weak] {
        if (auto s = weak.lock()) send_frames(session, o, s.get());
      });
    }
  }
}

void KelvinModule::describe_session(Session& session, json& out) {
  std::lock_guard lock(session.mutex);
  out["objects"] = kelvin_state(session).objects.size();
  out["uploads"] = uploads(session).uploads.size();
}

}  // namespace distlab::server
