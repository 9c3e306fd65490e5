// The scene routes' codec (scene_codec.hpp). An item arrives as one msgpack frame: its kind,
// vertices (little-endian float32 rows) and indices are checked against the scene limits here,
// once; a recording's spec and the page's end of it are JSON.
#include "scene_codec.hpp"

#include <cmath>
#include <cstring>
#include <limits>

#include "distlab/geometry/error.hpp"
#include "distlab/server/frames.hpp"
#include "distlab/server/json_fields.hpp"
#include "distlab/server/json_text.hpp"
#include "distlab/server/request_params.hpp"

namespace distlab::server {

using json = nlohmann::json;

namespace {

const std::vector<std::string> kViews = {"all", "gap", "kelvin", "cbf"};
const std::vector<std::string> kKinds = {"mesh", "points", "lines", "frame"};
// A property of the item format, not a server limit: a "size" beyond this is no longer a point's
// pixels nor a frame's axis length in metres.
constexpr double kMaxItemSize = 1000;

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

// The per-vertex fields of a mesh, points or lines item: its vertex count.
std::size_t check_positions(const json& item, const Limits& lim) {
  json_required(item, "", "positions");
  const auto positions = bin_values<float>(item, "positions", 3);
  const std::size_t n = positions.size() / 3;
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
  return n;
}

// A mesh's faces or lines' segments (width 3 or 2 indices each) into n vertices: their count.
std::size_t check_indices(const json& item, const std::string& kind, std::size_t width, std::size_t n) {
  json_required(item, "", "indices");
  const auto indices = bin_values<std::uint32_t>(item, "indices", width);
  if (indices.empty()) throw InvalidInput("indices", kind == "mesh" ? "a mesh needs at least one face" : "lines need at least one segment");
  for (std::size_t i = 0; i < indices.size(); ++i)
    if (indices[i] >= n)
      throw InvalidInput(json_index_path(json_index_path("indices", i / width), i % width),
                         "index " + std::to_string(indices[i]) + " is out of range (" + std::to_string(n) + " vertices)");
  return indices.size() / width;
}

// The item's fields besides its geometry (kind, view, color, size, pose), into `summary`.
void check_look(json& item, ItemSummary& summary) {
  json_require_object(item, "");
  json_check_keys(item, "", {"kind", "view", "positions", "indices", "colors", "scalars", "color", "size", "pose"});
  summary.kind = one_of(json_required(item, "", "kind"), "kind", kKinds);
  summary.view = json_optional(item, "view") ? one_of(item["view"], "view", kViews) : "all";
  item["view"] = summary.view;
  if (const json* c = json_optional(item, "color")) {
    const Vec3 rgb = json_vec3(*c, "color");
    for (int k = 0; k < 3; ++k)
      if (rgb[k] < 0 || rgb[k] > 1) throw InvalidInput(json_index_path("color", static_cast<std::size_t>(k)), "color is [r, g, b] in [0, 1]");
  }
  if (const json* s = json_optional(item, "size")) json_positive(*s, "size", kMaxItemSize);
  if (const json* p = json_optional(item, "pose")) {
    summary.pose = json_pose(*p, "pose");
    item["pose"] = pose_json(*summary.pose);
  }
}

json summary_json(const ItemSummary& s) {
  json j{{"name", s.name}, {"kind", s.kind}, {"view", s.view}, {"n_vertices", s.n_vertices}, {"bytes", s.bytes}};
  if (s.n_faces) j["n_faces"] = *s.n_faces;
  if (s.n_segments) j["n_segments"] = *s.n_segments;
  if (s.pose) j["pose"] = pose_json(*s.pose);
  return j;
}

std::optional<Camera> decode_camera(const json& body) {
  const json* c = json_optional(body, "camera");
  if (!c) return std::nullopt;
  json_require_object(*c, "camera");
  json_check_keys(*c, "camera", {"matrix", "width", "height"});
  return Camera{json_vec<16>(json_required(*c, "camera", "matrix"), "camera.matrix"),
                json_integer(json_required(*c, "camera", "width"), "camera.width", 1, 16384),
                json_integer(json_required(*c, "camera", "height"), "camera.height", 1, 16384)};
}

std::optional<Recorded> decode_recorded(const json& body, const Limits& limits) {
  const json* d = json_optional(body, "recorded");
  if (!d) return std::nullopt;
  json_require_object(*d, "recorded");
  json_check_keys(*d, "recorded", {"frames", "seconds"});
  return Recorded{json_integer(json_required(*d, "recorded", "frames"), "recorded.frames", 1, static_cast<long long>(limits.max_record_frames)),
                  json_positive(json_required(*d, "recorded", "seconds"), "recorded.seconds")};
}

json recording_json(const RecordingStatus& r) {
  json j{{"view", r.spec.view}, {"format", r.spec.format}, {"fps", r.spec.fps}, {"frames", r.spec.frames}, {"seconds", r.spec.seconds}};
  j["id"] = r.id;
  j["state"] = recording_state_name(r.state);
  j["parts"] = r.parts;
  j["bytes"] = r.bytes;
  j["camera"] = r.camera ? json{{"matrix", vec_json(r.camera->matrix)}, {"width", r.camera->width}, {"height", r.camera->height}} : json(nullptr);
  j["recorded"] = r.recorded ? json{{"frames", r.recorded->frames}, {"seconds", r.recorded->seconds}} : json(nullptr);
  if (!r.error.empty()) j["error"] = r.error;
  return j;
}

}  // namespace

// -- items --------------------------------------------------------------------------------------

ItemRef decode_item_ref(const Request& request, const Limits& /*limits*/) { return {item_name(request.params.at("name"))}; }

ItemUpload decode_item_upload(Request& request, const Limits& /*limits*/) {
  return {item_name(request.params.at("name")), std::move(request.body)};
}

// The body is the item's msgpack frame: what the client sent plus type, name, n_vertices (and
// n_faces or n_segments) is what the pages get.
NewItem read_item(const ItemUpload& upload, const Limits& limits) {
  NewItem out;
  ItemSummary& summary = out.item.summary;
  summary.name = upload.name;
  json item = parse_msgpack(upload.body);
  check_look(item, summary);
  if (summary.kind == "frame") {
    for (const char* key : {"positions", "indices", "colors", "scalars"})
      if (item.contains(key)) throw InvalidInput(key, std::string("a frame item has no ") + key + " (its pose and size say it all)");
  } else {
    summary.n_vertices = check_positions(item, limits);
    const std::size_t width = summary.kind == "mesh" ? 3 : summary.kind == "lines" ? 2
                                                                                   : 0;
    if (width == 0 && item.contains("indices")) throw InvalidInput("indices", "a points item has no indices");
    if (width != 0) {
      const std::size_t count = check_indices(item, summary.kind, width, summary.n_vertices);
      (width == 3 ? summary.n_faces : summary.n_segments) = count;
      item[width == 3 ? "n_faces" : "n_segments"] = count;
    }
  }
  item["type"] = "scene_item";
  item["name"] = summary.name;
  item["n_vertices"] = summary.n_vertices;
  out.msgpack = to_msgpack(item);
  summary.bytes = out.msgpack.size();
  out.item.frame = std::move(item);
  return out;
}

ItemPose decode_item_pose(const Request& request, const Limits& /*limits*/) {
  ItemPose out{item_name(request.params.at("name")), Pose{}};
  const json body = parse_body(request);
  json_require_object(body, "");
  json_check_keys(body, "", {"pose"});
  out.pose = json_pose(json_required(body, "", "pose"), "pose");
  return out;
}

Response encode_scene(const SceneList& scene) {
  json items = json::array();
  for (const ItemSummary& s : scene.items) items.push_back(summary_json(s));
  return json_response(200, {{"items", items}, {"bytes", scene.bytes}});
}

Response encode_item(const ItemSummary& item) { return json_response(200, summary_json(item)); }

std::string item_frame(SceneItem& item) {
  if (item.summary.pose) item.frame["pose"] = pose_json(*item.summary.pose);
  return to_msgpack(item.frame);
}

std::string pose_message(const ItemPose& pose) { return json{{"type", "scene_pose"}, {"name", pose.name}, {"pose", pose_json(pose.pose)}}.dump(); }
std::string remove_message(const std::string& name) { return json{{"type", "scene_remove"}, {"name", name}}.dump(); }
std::string clear_message() { return json{{"type", "scene_clear"}}.dump(); }

// -- recordings ---------------------------------------------------------------------------------

const char* recording_state_name(Lifecycle state) {
  switch (state) {
    case Lifecycle::queued:
      return "waiting";
    case Lifecycle::running:
      return "recording";
    case Lifecycle::succeeded:
      return "done";
    default:
      return "failed";
  }
}

RecordingSpec decode_recording_spec(const Request& request, const Limits& lim) {
  const json body = parse_body(request);
  json_require_object(body, "");
  json_check_keys(body, "", {"view", "format", "seconds", "frames", "fps"});
  RecordingSpec spec;
  spec.view = one_of(json_required(body, "", "view"), "view", {"gap", "kelvin", "cbf"});
  spec.format = one_of(json_required(body, "", "format"), "format", {"webm", "png"});
  const double fps = body.contains("fps") ? json_positive(body["fps"], "fps") : 30.0;
  if (fps > lim.max_record_fps)
    throw ApiError(413, "too_fast", "fps above the limit of " + json(lim.max_record_fps).dump() + " (max_record_fps)", "fps");
  if (body.contains("seconds") == body.contains("frames")) throw InvalidInput("seconds", "give seconds or frames, exactly one");
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
  spec.fps = fps;
  spec.frames = static_cast<std::size_t>(frames);
  spec.seconds = seconds;
  return spec;
}

RecordingRef decode_recording_ref(const Request& request, const Limits& /*limits*/) { return {request.params.at("id")}; }

PartRef decode_part_ref(const Request& request, const Limits& /*limits*/) {
  return {request.params.at("id"), part_index(request.params.at("index"))};
}

PartUpload decode_part_upload(Request& request, const Limits& limits) {
  PartUpload out{decode_part_ref(request, limits), {}};
  if (request.body.empty()) throw InvalidInput("body", "a part has bytes");
  out.bytes = std::move(request.body);
  return out;
}

// The page's end: {"camera": {"matrix": 16 numbers (clip from world, column-major), "width",
// "height"}, "recorded": {"frames", "seconds"}} when it recorded, or {"error": "why not"}.
RecordingEnd decode_recording_end(const Request& request, const Limits& limits) {
  const json body = parse_body(request);
  json_require_object(body, "");
  json_check_keys(body, "", {"camera", "recorded", "error"});
  RecordingEnd end{request.params.at("id"), decode_camera(body), decode_recorded(body, limits), ""};
  if (body.contains("error")) end.error = shorten(json_string(body["error"], "error"), 500);
  return end;
}

Response encode_new_recording(const RecordingStatus& recording) { return json_response(201, recording_json(recording)); }
Response encode_recording(const RecordingStatus& recording) { return json_response(200, recording_json(recording)); }

Response encode_part(const RecordingPart& part) {
  Response out;
  out.content_type = part.format == "png" ? "image/png" : "video/webm";
  out.body = part.bytes;
  return out;
}

}  // namespace distlab::server
