// Scene items and recordings of a session. An item arrives as one msgpack frame (the codec of
// frames.hpp, PUT /api/scene/items/{name}), is checked against the scene limits, kept in the
// session and relayed to the session's sockets as a "scene_item" frame; pose changes, removals and
// clearing go out as small text messages. A recording is a request a page of the session answers:
// it records its canvas and uploads the parts (PNG frames, or one WebM) for the client to fetch.
#include <cmath>
#include <cstring>
#include <map>
#include <mutex>

#include "distlab/geometry/error.hpp"
#include "distlab/server/frames.hpp"
#include "distlab/server/json_fields.hpp"
#include "distlab/server/json_text.hpp"
#include "distlab/server/request_params.hpp"
#include "scene_module.hpp"

namespace distlab::server {

using json = nlohmann::json;

namespace {

const std::vector<std::string> kViews = {"all", "gap", "kelvin", "cbf"};
const std::vector<std::string> kKinds = {"mesh", "points", "lines", "frame"};
// A "size" beyond this is no longer a point's pixels nor a frame's axis length in metres.
constexpr double kMaxItemSize = 1000;

// NOLINT below: the throw the check finds is nlohmann::json's unreachable internal-error branch of
// its noexcept default constructor.
struct Recording {  // NOLINT(bugprone-exception-escape)
  std::string id;
  json spec;          // view, format, fps, frames, seconds
  std::string state;  // waiting, recording, done, failed
  std::vector<std::string> parts;
  std::size_t bytes = 0;
  json camera;                                 // the page's camera when it recorded (null until done)
  json recorded;                               // the frames the page drew into it and their span (null until done)
  std::vector<ClientShare::Reservation> held;  // the parts' bytes, in the client's share
  std::string error;                           // a failed recording's reason, from the page
  json to_json() const {
    json j = spec;
    j["id"] = id;
    j["state"] = state;
    j["parts"] = parts.size();
    j["bytes"] = bytes;
    j["camera"] = camera;
    j["recorded"] = recorded;
    if (!error.empty()) j["error"] = error;
    return j;
  }
};

struct SceneState final : ModuleState {
  std::map<std::string, json> items;  // name -> its frame, as relayed
  std::map<std::string, std::size_t> item_bytes;
  std::map<std::string, ClientShare::Reservation> held;  // the items' bytes, in the client's share
  std::size_t bytes = 0;
  std::shared_ptr<Recording> recording;  // one per session; a new one replaces it
};

std::string item_name(const std::string& name) {
  if (!valid_name(name))
    throw InvalidInput("name", "an item's name has 1 to 64 letters, digits, '_' and '-', got \"" + shorten(name) + "\"");
  return name;
}

// A part's index in the path: a whole number below 10^9.
std::size_t part_index(const std::string& s) {
  if (s.empty() || s.size() > 9 || s.find_first_not_of("0123456789") != std::string::npos)
    throw InvalidInput("index", "a part's index is a whole number, got \"" + shorten(s) + "\"");
  return std::stoul(s);
}

std::string one_of(const json& j, const std::string& field, const std::vector<std::string>& allowed) {
  std::string v = json_string(j, field);
  for (const auto& a : allowed)
    if (v == a) return v;
  std::string list;
  for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
  throw InvalidInput(field, field + " must be one of " + list + ", got \"" + shorten(v) + "\"");
}

// The values of a "bin" field of 4-byte little-endian entries, `width` per row.
template <class T>
std::vector<T> bin_values(const json& item, const std::string& field, std::size_t width) {
  const json& v = item.at(field);
  // An ext value parses as binary with a subtype; it is no bin, and relayed it would reach the pages as an ext.
  if (!v.is_binary() || v.get_binary().has_subtype())
    throw InvalidInput(field, field + " must be msgpack bin (little-endian 4-byte values), got " +
                                  (v.is_binary() ? "ext type " + std::to_string(v.get_binary().subtype()) : std::string(v.type_name())));
  const auto& b = v.get_binary();
  if (b.size() % (4 * width) != 0)
    throw InvalidInput(field, field + " has " + std::to_string(b.size()) + " bytes, not a multiple of " + std::to_string(4 * width) + " (" +
                                  std::to_string(width) + " values of 4 bytes per row)");
  std::vector<T> out(b.size() / 4);
  if (!out.empty()) std::memcpy(out.data(), b.data(), b.size());
  return out;
}

void check_rows(const std::vector<float>& values, const std::string& field, std::size_t width, double lo, double hi) {
  for (std::size_t i = 0; i < values.size(); ++i)
    if (!(values[i] >= lo && values[i] <= hi))
      throw InvalidInput(json_index_path(json_index_path(field, i / width), i % width),
                         field + " values must be finite and in [" + json(lo).dump() + ", " + json(hi).dump() + "], got " +
                             (std::isfinite(values[i]) ? json(static_cast<double>(values[i])).dump() : std::to_string(values[i])));
}

// A checked item frame: what the client sent plus type, name, n_vertices (and n_faces).
json parse_item(const std::string& name, const std::string& body, const Limits& lim) {
  json item = parse_msgpack(body);
  json_require_object(item, "");
  json_check_keys(item, "", {"kind", "view", "positions", "indices", "colors", "scalars", "color", "size", "pose"});
  const std::string kind = one_of(json_required(item, "", "kind"), "kind", kKinds);
  item["view"] = json_optional(item, "view") ? one_of(item["view"], "view", kViews) : "all";
  if (const json* c = json_optional(item, "color")) {
    const Vec3 rgb = json_vec3(*c, "color");
    for (int k = 0; k < 3; ++k)
      if (rgb[k] < 0 || rgb[k] > 1) throw InvalidInput(json_index_path("color", static_cast<std::size_t>(k)), "color is [r, g, b] in [0, 1]");
  }
  if (const json* s = json_optional(item, "size")) json_positive(*s, "size", kMaxItemSize);
  if (const json* p = json_optional(item, "pose")) item["pose"] = pose_json(json_pose(*p, "pose"));

  std::size_t n = 0;
  if (kind == "frame") {
    for (const char* key : {"positions", "indices", "colors", "scalars"})
      if (item.contains(key)) throw InvalidInput(key, std::string("a frame item has no ") + key + " (its pose and size say it all)");
  } else {
    json_required(item, "", "positions");
    const auto positions = bin_values<float>(item, "positions", 3);
    n = positions.size() / 3;
    if (n == 0) throw InvalidInput("positions", "positions has no vertices");
    if (n > lim.max_scene_vertices)
      throw ApiError(413, "too_many_vertices",
                     "positions has " + std::to_string(n) + " vertices, above the limit of " + std::to_string(lim.max_scene_vertices) +
                         " (max_scene_vertices)",
                     "positions");
    check_rows(positions, "positions", 3, -kMaxCoordinate, kMaxCoordinate);
    if (item.contains("colors")) {
      const auto colors = bin_values<float>(item, "colors", 3);
      if (colors.size() != 3 * n) throw InvalidInput("colors", "colors needs 3 values per vertex (" + std::to_string(n) + " vertices)");
      check_rows(colors, "colors", 3, 0, 1);
    }
    if (item.contains("scalars")) {
      const auto scalars = bin_values<float>(item, "scalars", 1);
      if (scalars.size() != n) throw InvalidInput("scalars", "scalars needs 1 value per vertex (" + std::to_string(n) + " vertices)");
      check_rows(scalars, "scalars", 1, -std::numeric_limits<float>::max(), std::numeric_limits<float>::max());
    }
    const std::size_t width = kind == "mesh" ? 3 : kind == "lines" ? 2
                                                                   : 0;
    if (width == 0 && item.contains("indices")) throw InvalidInput("indices", "a points item has no indices");
    if (width != 0) {
      json_required(item, "", "indices");
      const auto indices = bin_values<std::uint32_t>(item, "indices", width);
      if (indices.empty()) throw InvalidInput("indices", kind == "mesh" ? "a mesh needs at least one face" : "lines need at least one segment");
      for (std::size_t i = 0; i < indices.size(); ++i)
        if (indices[i] >= n)
          throw InvalidInput(json_index_path(json_index_path("indices", i / width), i % width),
                             "index " + std::to_string(indices[i]) + " is out of range (" + std::to_string(n) + " vertices)");
      item[kind == "mesh" ? "n_faces" : "n_segments"] = indices.size() / width;
    }
  }
  item["type"] = "scene_item";
  item["name"] = name;
  item["n_vertices"] = n;
  return item;
}

SceneState& scene(Session& s) { return s.state<SceneState>(); }

json item_summary(const json& item, std::size_t bytes) {
  json j{{"name", item["name"]}, {"kind", item["kind"]}, {"view", item["view"]}, {"n_vertices", item["n_vertices"]}, {"bytes", bytes}};
  for (const char* key : {"n_faces", "n_segments", "pose"})
    if (item.contains(key)) j[key] = item[key];
  return j;
}

std::shared_ptr<Recording> find_recording(Session& s, const std::string& id) {
  auto& r = scene(s).recording;
  if (!r || r->id != id) throw ApiError(404, "unknown_recording", "no such recording in this session (a newer one replaces it)", "id");
  return r;
}

}  // namespace

void SceneModule::joined(const std::shared_ptr<Session>& session, const std::shared_ptr<WsSink>& socket) {
  std::vector<std::string> frames;
  {
    std::lock_guard lock(session->mutex);
    for (const auto& [name, item] : scene(*session).items) frames.push_back(to_msgpack(item));
  }
  for (auto& f : frames) socket->send(std::move(f), true);
}

void SceneModule::describe_session(Session& session, json& out) {
  std::lock_guard lock(session.mutex);
  out["scene_items"] = scene(session).items.size();
}

void SceneModule::register_routes() {
  const Limits& limits = config_.limits;  // the body limits; handlers read config_ when they run

  router_.add({"GET", "/api/scene/items", [this](Request& req) {
                 auto s = require_session(req);
                 std::lock_guard lock(s->mutex);
                 const SceneState& st = scene(*s);
                 json items = json::array();
                 for (const auto& [name, item] : st.items) items.push_back(item_summary(item, st.item_bytes.at(name)));
                 return json_response(200, {{"items", items}, {"bytes", st.bytes}});
               }});

  // The body is the item's msgpack frame; adding under an existing name replaces that item.
  Route put{"PUT", "/api/scene/items/{name}", [this](Request& req) {
              const Limits& lim = config_.limits;
              auto s = require_session(req);
              const std::string name = item_name(req.params["name"]);
              const json item = parse_item(name, req.body, lim);
              std::string frame = to_msgpack(item);
              json summary;
              {
                std::lock_guard lock(s->mutex);
                SceneState& st = scene(*s);
                const auto old = st.item_bytes.find(name);
                const std::size_t replaced = old == st.item_bytes.end() ? 0 : old->second;
                if (old == st.item_bytes.end() && st.items.size() >= lim.max_scene_items)
                  throw ApiError(413, "too_many_items",
                                 "this session's scene holds " + std::to_string(st.items.size()) + " items, the limit (max_scene_items)", "name");
                if (st.bytes - replaced + frame.size() > lim.max_scene_bytes)
                  throw ApiError(413, "too_many_bytes",
                                 "this item's " + std::to_string(frame.size()) + " bytes would take the session's scene to " +
                                     std::to_string(st.bytes - replaced + frame.size()) + ", above max_scene_bytes (" +
                                     std::to_string(lim.max_scene_bytes) + ")",
                                 "body");
                st.held[name] = held_bytes_.reserve(s->address, frame.size(), "body");
                st.bytes = st.bytes - replaced + frame.size();
                st.item_bytes[name] = frame.size();
                st.items[name] = item;
                summary = item_summary(item, frame.size());
              }
              s->broadcast(frame, true);
              return json_response(200, summary);
            }};
  put.body_limit = limits.max_scene_bytes + (std::size_t{64} << 10);  // room for the frame's keys
  router_.add(std::move(put));

  router_.add({"PUT", "/api/scene/items/{name}/pose", [this](Request& req) {
                 auto s = require_session(req);
                 const std::string name = item_name(req.params["name"]);
                 const json body = parse_body(req);
                 json_require_object(body, "");
                 json_check_keys(body, "", {"pose"});
                 const json pose = pose_json(json_pose(json_required(body, "", "pose"), "pose"));
                 json summary;
                 {
                   std::lock_guard lock(s->mutex);
                   SceneState& st = scene(*s);
                   const auto it = st.items.find(name);
                   if (it == st.items.end()) throw ApiError(404, "unknown_item", "no scene item \"" + name + "\" in this session", "name");
                   it->second["pose"] = pose;
                   summary = item_summary(it->second, st.item_bytes.at(name));
                 }
                 s->broadcast(json{{"type", "scene_pose"}, {"name", name}, {"pose", pose}}.dump(), false);
                 return json_response(200, summary);
               }});

  router_.add({"DELETE", "/api/scene/items/{name}", [this](Request& req) {
                 auto s = require_session(req);
                 const std::string name = item_name(req.params["name"]);
                 {
                   std::lock_guard lock(s->mutex);
                   SceneState& st = scene(*s);
                   if (!st.items.count(name)) throw ApiError(404, "unknown_item", "no scene item \"" + name + "\" in this session", "name");
                   st.bytes -= st.item_bytes.at(name);
                   st.item_bytes.erase(name);
                   st.held.erase(name);
                   st.items.erase(name);
                 }
                 s->broadcast(json{{"type", "scene_remove"}, {"name", name}}.dump(), false);
                 return no_content_response();
               }});

  router_.add({"DELETE", "/api/scene/items", [this](Request& req) {
                 auto s = require_session(req);
                 {
                   std::lock_guard lock(s->mutex);
                   SceneState& st = scene(*s);
                   st.items.clear();
                   st.item_bytes.clear();
                   st.held.clear();
                   st.bytes = 0;
                 }
                 s->broadcast(json{{"type", "scene_clear"}}.dump(), false);
                 return no_content_response();
               }});

  // -- recordings ------------------------------------------------------------------------------

  router_.add({"POST", "/api/scene/recordings", [this](Request& req) {
                 const Limits& lim = config_.limits;
                 auto s = require_session(req);
                 const json body = parse_body(req);
                 json_require_object(body, "");
                 json_check_keys(body, "", {"view", "format", "seconds", "frames", "fps"});
                 json spec;
                 spec["view"] = one_of(json_required(body, "", "view"), "view", {"gap", "kelvin", "cbf"});
                 spec["format"] = one_of(json_required(body, "", "format"), "format", {"webm", "png"});
                 const double fps = body.contains("fps") ? json_positive(body["fps"], "fps") : 30.0;
                 if (fps > lim.max_record_fps)
                   throw ApiError(413, "too_fast", "fps above the limit of " + json(lim.max_record_fps).dump() + " (max_record_fps)", "fps");
                 if (body.contains("seconds") == body.contains("frames"))
                   throw InvalidInput("seconds", "give seconds or frames, exactly one");
                 const std::string field = body.contains("seconds") ? "seconds" : "frames";
                 const double frames = body.contains("seconds") ? std::ceil(json_positive(body["seconds"], "seconds") * fps)
                                                                : json_integer(body["frames"], "frames", 1);
                 const double seconds = frames / fps;
                 // The duration first: within it, frames (seconds * fps, fps <= max_record_fps) fits the
                 // integer it is printed as; seconds 1e300 made a frame count no integer holds.
                 if (seconds > lim.max_record_seconds)
                   throw ApiError(413, "too_long", json(seconds).dump() + " s, above the limit of " + json(lim.max_record_seconds).dump() + " s (max_record_seconds)", field);
                 if (frames > static_cast<double>(lim.max_record_frames))
                   throw ApiError(413, "too_long", std::to_string(static_cast<long long>(frames)) + " frames, above the limit of " + std::to_string(lim.max_record_frames) + " (max_record_frames)", field);
                 spec["fps"] = fps;
                 spec["frames"] = static_cast<std::size_t>(frames);
                 spec["seconds"] = seconds;
                 auto r = std::make_shared<Recording>();
                 r->id = random_id().substr(0, 16);
                 r->spec = spec;
                 r->state = "waiting";
                 std::lock_guard lock(s->mutex);
                 scene(*s).recording = r;
                 return json_response(201, r->to_json());
               }});

  router_.add({"GET", "/api/scene/recordings/{id}", [this](Request& req) {
                 auto s = require_session(req);
                 std::lock_guard lock(s->mutex);
                 return json_response(200, find_recording(*s, req.params["id"])->to_json());
               }});

  // The page's parts in order: PNG frames 0, 1, ... (at most the recording's frames), or one WebM.
  Route part{"PUT", "/api/scene/recordings/{id}/parts/{index}", [this](Request& req) {
               const Limits& lim = config_.limits;
               auto s = require_session(req);
               const std::size_t index = part_index(req.params["index"]);
               std::lock_guard lock(s->mutex);
               const auto r = find_recording(*s, req.params["id"]);
               if (r->state != "waiting" && r->state != "recording")
                 throw ApiError(409, "recording_finished", "this recording is " + r->state, "id");
               if (index != r->parts.size())
                 throw InvalidInput("index", "the next part is " + std::to_string(r->parts.size()) + ", got " + std::to_string(index));
               const std::size_t max_parts = r->spec["format"] == "png" ? r->spec["frames"].get<std::size_t>() : 1;
               if (index >= max_parts) throw InvalidInput("index", "this recording has " + std::to_string(max_parts) + " parts");
               if (req.body.empty()) throw InvalidInput("body", "a part has bytes");
               if (r->bytes + req.body.size() > lim.max_record_bytes)
                 throw ApiError(413, "too_large", "the recording would exceed max_record_bytes (" + std::to_string(lim.max_record_bytes) + ")", "body");
               r->held.push_back(held_bytes_.reserve(s->address, req.body.size(), "body"));
               r->bytes += req.body.size();
               r->parts.push_back(std::move(req.body));
               r->state = "recording";
               return json_response(200, r->to_json());
             }};
  part.body_limit = limits.max_record_bytes;
  router_.add(std::move(part));

  // The page's end: {"camera": {"matrix": 16 numbers (clip from world, column-major), "width",
  // "height"}, "recorded": {"frames", "seconds"}} when it recorded, or {"error": "why not"}.
  router_.add({"POST", "/api/scene/recordings/{id}/finish", [this](Request& req) {
                 auto s = require_session(req);
                 const json body = parse_body(req);
                 json_require_object(body, "");
                 json_check_keys(body, "", {"camera", "recorded", "error"});
                 json camera = nullptr;
                 if (const json* c = json_optional(body, "camera")) {
                   json_require_object(*c, "camera");
                   json_check_keys(*c, "camera", {"matrix", "width", "height"});
                   const auto m = json_vec<16>(json_required(*c, "camera", "matrix"), "camera.matrix");
                   camera = {{"matrix", vec_json(m)},
                             {"width", json_integer(json_required(*c, "camera", "width"), "camera.width", 1, 16384)},
                             {"height", json_integer(json_required(*c, "camera", "height"), "camera.height", 1, 16384)}};
                 }
                 json recorded = nullptr;
                 if (const json* d = json_optional(body, "recorded")) {
                   json_require_object(*d, "recorded");
                   json_check_keys(*d, "recorded", {"frames", "seconds"});
                   recorded = {{"frames", json_integer(json_required(*d, "recorded", "frames"), "recorded.frames", 1, static_cast<long long>(config_.limits.max_record_frames))},
                               {"seconds", json_positive(json_required(*d, "recorded", "seconds"), "recorded.seconds")}};
                 }
                 const std::string error = body.contains("error") ? shorten(json_string(body["error"], "error"), 500) : "";
                 std::lock_guard lock(s->mutex);
                 const auto r = find_recording(*s, req.params["id"]);
                 if (r->state == "done" || r->state == "failed") throw ApiError(409, "recording_finished", "this recording is " + r->state, "id");
                 const std::size_t wanted = r->spec["format"] == "png" ? r->spec["frames"].get<std::size_t>() : 1;
                 if (error.empty() && r->parts.size() != wanted)
                   throw InvalidInput("id", "the recording has " + std::to_string(r->parts.size()) + " of its " + std::to_string(wanted) + " parts");
                 r->state = error.empty() ? "done" : "failed";
                 r->error = error;
                 r->camera = camera;
                 r->recorded = recorded;
                 return json_response(200, r->to_json());
               }});

  router_.add({"GET", "/api/scene/recordings/{id}/parts/{index}", [this](Request& req) {
                 auto s = require_session(req);
                 const std::size_t index = part_index(req.params["index"]);
                 std::lock_guard lock(s->mutex);
                 const auto r = find_recording(*s, req.params["id"]);
                 if (index >= r->parts.size()) throw ApiError(404, "unknown_part", "this recording has " + std::to_string(r->parts.size()) + " parts", "index");
                 Response out;
                 out.content_type = r->spec["format"] == "png" ? "image/png" : "video/webm";
                 out.body = r->parts[index];
                 return out;
               }});

  router_.add({"DELETE", "/api/scene/recordings/{id}", [this](Request& req) {
                 auto s = require_session(req);
                 std::lock_guard lock(s->mutex);
                 find_recording(*s, req.params["id"]);
                 scene(*s).recording.reset();
                 return no_content_response();
               }});
}

}  // namespace distlab::server
