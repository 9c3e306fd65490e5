// Scene items and recordings of a session, one row of the table each. An item (its frame checked
// by the codec, scene_codec.hpp) is kept in the session and relayed to the session's sockets as a
// "scene_item" frame; pose changes, removals and clearing go out as small text messages. A
// recording is a request a page of the session answers: it records its canvas and uploads the
// parts (PNG frames, or one WebM) for the client to fetch.
#include <map>
#include <mutex>

#include "scene_codec.hpp"
#include "scene_module.hpp"

namespace distlab::server {

namespace {

struct Recording {
  RecordingStatus status;
  std::vector<std::string> parts;
  std::vector<ClientShare::Reservation> held;  // the parts' bytes, in the client's share
};

struct SceneState final : ModuleState {
  std::map<std::string, SceneItem> items;
  std::map<std::string, ClientShare::Reservation> held;  // the items' bytes, in the client's share
  std::size_t bytes = 0;
  std::shared_ptr<Recording> recording;  // one per session; a new one replaces it
};

SceneState& scene(Session& s) { return s.state<SceneState>(); }

std::shared_ptr<Recording> find_recording(Session& s, const std::string& id) {
  auto& r = scene(s).recording;
  if (!r || r->status.id != id) throw ApiError(404, "unknown_recording", "no such recording in this session (a newer one replaces it)", "id");
  return r;
}

SceneItem& find_item(SceneState& st, const std::string& name) {
  const auto it = st.items.find(name);
  if (it == st.items.end()) throw ApiError(404, "unknown_item", "no scene item \"" + name + "\" in this session", "name");
  return it->second;
}

}  // namespace

void SceneModule::register_routes() {
  const Limits& limits = config_.limits;
  // An item's body is its msgpack frame, with room for the frame's keys.
  const std::size_t item_body = limits.max_scene_bytes + (std::size_t{64} << 10);
  add_routes<SceneModule>(
      router_, *this, limits,
      {
          {"GET", "/api/scene/items", Work::light, {}, codec(decode_nothing, &SceneModule::items, encode_scene)},
          {"PUT", "/api/scene/items/{name}", Work::light, {}, codec(decode_item_upload, &SceneModule::put_item, encode_item), item_body},
          {"PUT", "/api/scene/items/{name}/pose", Work::light, {}, codec(decode_item_pose, &SceneModule::set_pose, encode_item)},
          {"DELETE", "/api/scene/items/{name}", Work::light, {}, codec(decode_item_ref, &SceneModule::remove_item, encode_no_content)},
          {"DELETE", "/api/scene/items", Work::light, {}, codec(decode_nothing, &SceneModule::clear, encode_no_content)},
          {"POST", "/api/scene/recordings", Work::light, {}, codec(decode_recording_spec, &SceneModule::start_recording, encode_new_recording)},
          {"GET", "/api/scene/recordings/{id}", Work::light, {}, codec(decode_recording_ref, &SceneModule::recording, encode_recording)},
          {"PUT", "/api/scene/recordings/{id}/parts/{index}", Work::light, {}, codec(decode_part_upload, &SceneModule::add_part, encode_recording), limits.max_record_bytes},
          {"POST", "/api/scene/recordings/{id}/finish", Work::light, {}, codec(decode_recording_end, &SceneModule::finish_recording, encode_recording)},
          {"GET", "/api/scene/recordings/{id}/parts/{index}", Work::light, {}, codec(decode_part_ref, &SceneModule::part, encode_part)},
          {"DELETE", "/api/scene/recordings/{id}", Work::light, {}, codec(decode_recording_ref, &SceneModule::remove_recording, encode_no_content)},
      });
}

void SceneModule::joined(const std::shared_ptr<Session>& session, const std::shared_ptr<WsSink>& socket) {
  std::vector<std::string> frames;
  {
    std::lock_guard lock(session->mutex);
    for (auto& entry : scene(*session).items) frames.push_back(item_frame(entry.second));
  }
  for (auto& f : frames) socket->send(std::move(f), true);
}

void SceneModule::describe_session(Session& session, nlohmann::json& out) {
  std::lock_guard lock(session.mutex);
  out["scene_items"] = scene(session).items.size();
}

// -- items --------------------------------------------------------------------------------------

SceneList SceneModule::items(const Nothing& /*in*/, const Caller& caller) {
  auto s = require_session(caller);
  std::lock_guard lock(s->mutex);
  const SceneState& st = scene(*s);
  SceneList out{{}, st.bytes};
  for (const auto& entry : st.items) out.items.push_back(entry.second.summary);
  return out;
}

// Adding under an existing name replaces that item.
ItemSummary SceneModule::put_item(const ItemUpload& upload, const Caller& caller) {
  const Limits& lim = config_.limits;
  auto s = require_session(caller);
  const NewItem in = read_item(upload, lim);
  const ItemSummary& item = in.item.summary;
  {
    std::lock_guard lock(s->mutex);
    SceneState& st = scene(*s);
    const auto old = st.items.find(item.name);
    const std::size_t replaced = old == st.items.end() ? 0 : old->second.summary.bytes;
    if (old == st.items.end() && st.items.size() >= lim.max_scene_items)
      throw ApiError(413, "too_many_items", "this session's scene holds " + std::to_string(st.items.size()) + " items, the limit (max_scene_items)", "name");
    if (st.bytes - replaced + item.bytes > lim.max_scene_bytes)
      throw ApiError(413, "too_many_bytes",
                     "this item's " + std::to_string(item.bytes) + " bytes would take the session's scene to " +
                         std::to_string(st.bytes - replaced + item.bytes) + ", above max_scene_bytes (" + std::to_string(lim.max_scene_bytes) + ")",
                     "body");
    st.held[item.name] = held_bytes_.reserve(s->address, item.bytes, "body");
    st.bytes = st.bytes - replaced + item.bytes;
    st.items[item.name] = in.item;
  }
  s->broadcast(in.msgpack, true);
  return item;
}

ItemSummary SceneModule::set_pose(const ItemPose& in, const Caller& caller) {
  auto s = require_session(caller);
  ItemSummary summary;
  {
    std::lock_guard lock(s->mutex);
    SceneItem& item = find_item(scene(*s), in.name);
    item.summary.pose = in.pose;
    summary = item.summary;
  }
  s->broadcast(pose_message(in), false);
  return summary;
}

Nothing SceneModule::remove_item(const ItemRef& in, const Caller& caller) {
  auto s = require_session(caller);
  {
    std::lock_guard lock(s->mutex);
    SceneState& st = scene(*s);
    st.bytes -= find_item(st, in.name).summary.bytes;
    st.held.erase(in.name);
    st.items.erase(in.name);
  }
  s->broadcast(remove_message(in.name), false);
  return {};
}

Nothing SceneModule::clear(const Nothing& /*in*/, const Caller& caller) {
  auto s = require_session(caller);
  {
    std::lock_guard lock(s->mutex);
    SceneState& st = scene(*s);
    st.items.clear();
    st.held.clear();
    st.bytes = 0;
  }
  s->broadcast(clear_message(), false);
  return {};
}

// -- recordings ---------------------------------------------------------------------------------

RecordingStatus SceneModule::start_recording(const RecordingSpec& in, const Caller& caller) {
  auto s = require_session(caller);
  auto r = std::make_shared<Recording>();
  r->status.id = random_id().substr(0, 16);
  r->status.spec = in;
  std::lock_guard lock(s->mutex);
  scene(*s).recording = r;
  return r->status;
}

RecordingStatus SceneModule::recording(const RecordingRef& in, const Caller& caller) {
  auto s = require_session(caller);
  std::lock_guard lock(s->mutex);
  return find_recording(*s, in.id)->status;
}

// The page's parts in order: PNG frames 0, 1, ... (at most the recording's frames), or one WebM.
RecordingStatus SceneModule::add_part(const PartUpload& in, const Caller& caller) {
  const Limits& lim = config_.limits;
  auto s = require_session(caller);
  std::lock_guard lock(s->mutex);
  const auto r = find_recording(*s, in.ref.id);
  RecordingStatus& st = r->status;
  if (ended(st.state)) throw ApiError(409, "recording_finished", std::string("this recording is ") + recording_state_name(st.state), "id");
  if (in.ref.index != r->parts.size())
    throw InvalidInput("index", "the next part is " + std::to_string(r->parts.size()) + ", got " + std::to_string(in.ref.index));
  if (in.ref.index >= st.spec.parts()) throw InvalidInput("index", "this recording has " + std::to_string(st.spec.parts()) + " parts");
  if (st.bytes + in.bytes.size() > lim.max_record_bytes)
    throw ApiError(413, "too_large", "the recording would exceed max_record_bytes (" + std::to_string(lim.max_record_bytes) + ")", "body");
  r->held.push_back(held_bytes_.reserve(s->address, in.bytes.size(), "body"));
  st.bytes += in.bytes.size();
  r->parts.push_back(std::move(in.bytes));
  st.parts = r->parts.size();
  st.state = Lifecycle::running;
  return st;
}

RecordingStatus SceneModule::finish_recording(const RecordingEnd& in, const Caller& caller) {
  auto s = require_session(caller);
  std::lock_guard lock(s->mutex);
  const auto r = find_recording(*s, in.id);
  RecordingStatus& st = r->status;
  if (ended(st.state)) throw ApiError(409, "recording_finished", std::string("this recording is ") + recording_state_name(st.state), "id");
  if (in.error.empty() && r->parts.size() != st.spec.parts())
    throw InvalidInput("id", "the recording has " + std::to_string(r->parts.size()) + " of its " + std::to_string(st.spec.parts()) + " parts");
  st.state = in.error.empty() ? Lifecycle::succeeded : Lifecycle::failed;
  st.error = in.error;
  st.camera = in.camera;
  st.recorded = in.recorded;
  return st;
}

RecordingPart SceneModule::part(const PartRef& in, const Caller& caller) {
  auto s = require_session(caller);
  std::lock_guard lock(s->mutex);
  const auto r = find_recording(*s, in.id);
  if (in.index >= r->parts.size()) throw ApiError(404, "unknown_part", "this recording has " + std::to_string(r->parts.size()) + " parts", "index");
  return {r->status.spec.format, r->parts[in.index]};
}

Nothing SceneModule::remove_recording(const RecordingRef& in, const Caller& caller) {
  auto s = require_session(caller);
  std::lock_guard lock(s->mutex);
  find_recording(*s, in.id);
  scene(*s).recording.reset();
  return {};
}

}  // namespace distlab::server
