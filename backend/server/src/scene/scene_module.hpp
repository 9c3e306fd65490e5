#pragma once
// The user's own geometry in the views (issue 37 item 7): meshes, points, line segments and
// coordinate frames a client (distlab.Client.scene) puts into its session's pages by name, relayed
// as msgpack frames (frames.hpp) on the session's WebSocket; and recordings of a view
// (Client.record), which a page of the session makes and uploads here for the client to fetch
// (routes_scene.cpp).
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "distlab/server/client_share.hpp"
#include "distlab/server/module.hpp"
#include "scene_codec.hpp"

namespace distlab::server {

class SceneModule final : public Module {
 public:
  using Module::Module;
  std::string name() const override { return "scene"; }
  void register_routes() override;
  // A joining socket (a page opened later, a reconnection) gets every item of the session.
  void joined(const std::shared_ptr<Session>& session, const std::shared_ptr<WsSink>& socket) override;
  void describe_session(Session& session, nlohmann::json& out) override;

 private:
  // The handlers of the table (routes_scene.cpp).
  SceneList items(const Nothing& in, const Caller& caller);
  ItemSummary put_item(const ItemUpload& upload, const Caller& caller);
  ItemSummary set_pose(const ItemPose& in, const Caller& caller);
  Nothing remove_item(const ItemRef& in, const Caller& caller);
  Nothing clear(const Nothing& in, const Caller& caller);
  RecordingStatus start_recording(const RecordingSpec& in, const Caller& caller);
  RecordingStatus recording(const RecordingRef& in, const Caller& caller);
  RecordingStatus add_part(const PartUpload& in, const Caller& caller);
  RecordingStatus finish_recording(const RecordingEnd& in, const Caller& caller);
  RecordingPart part(const PartRef& in, const Caller& caller);
  Nothing remove_recording(const RecordingRef& in, const Caller& caller);

  // Items' and recordings' bytes, per client address and in all.
  ClientShare held_bytes_{"bytes", "max_held_bytes_per_address", config_.limits.max_held_bytes_per_address, "max_held_bytes",
                          config_.limits.max_held_bytes, "scene items or recordings (DELETE /api/scene/items, /api/scene/recordings/{id})"};
};

}  // namespace distlab::server
