#pragma once
// The scene routes' codec (routes_scene.cpp): the typed input each decode_* reads from a request,
// the only place that checks it; the typed results the handlers return; the encode_* that write
// them; and the frames and messages the session's sockets receive.
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "distlab/geometry/pose.hpp"
#include "distlab/server/config.hpp"
#include "distlab/server/http.hpp"
#include "distlab/server/lifecycle.hpp"

namespace distlab::server {

// -- items --------------------------------------------------------------------------------------

struct ItemSummary {
  std::string name, kind, view;
  std::size_t n_vertices = 0;
  std::optional<std::size_t> n_faces;     // a mesh's
  std::optional<std::size_t> n_segments;  // lines'
  std::optional<Pose> pose;
  std::size_t bytes = 0;  // its msgpack frame's
};

// An item as kept: its summary and the frame relayed to the pages (whose "pose" is summary.pose).
// NOLINT below (and NewItem's): the throw the check finds is nlohmann::json's unreachable
// internal-error branch of its noexcept default constructor.
struct SceneItem {  // NOLINT(bugprone-exception-escape)
  ItemSummary summary;
  nlohmann::json frame;
};

// PUT /api/scene/items/{name}: the checked item and its frame's bytes, relayed as they are.
struct NewItem {  // NOLINT(bugprone-exception-escape)
  SceneItem item;
  std::string msgpack;
};

struct ItemRef {
  std::string name;
};

// PUT /api/scene/items/{name} as received: the name checked, the frame's bytes moved from the
// request. read_item checks the frame once the handler has the caller's session (a caller without
// one costs no parse of up to max_scene_bytes).
struct ItemUpload {
  std::string name;
  mutable std::string body;
};

struct ItemPose {
  std::string name;
  Pose pose;
};

struct SceneList {
  std::vector<ItemSummary> items;
  std::size_t bytes = 0;
};

ItemRef decode_item_ref(const Request& request, const Limits& limits);
ItemUpload decode_item_upload(Request& request, const Limits& limits);
NewItem read_item(const ItemUpload& upload, const Limits& limits);
ItemPose decode_item_pose(const Request& request, const Limits& limits);
Response encode_scene(const SceneList& scene);
Response encode_item(const ItemSummary& item);

// The item's frame with its current pose (for a socket that joins later).
std::string item_frame(SceneItem& item);
std::string pose_message(const ItemPose& pose);
std::string remove_message(const std::string& name);
std::string clear_message();

// -- recordings ---------------------------------------------------------------------------------

struct RecordingSpec {
  std::string view, format;  // gap | kelvin | cbf; webm | png
  double fps = 30;
  std::size_t frames = 0;
  double seconds = 0;
  std::size_t parts() const { return format == "png" ? frames : 1; }  // PNG frames, or one WebM
};

// The page's camera when it recorded.
struct Camera {
  Eigen::Matrix<double, 16, 1> matrix;  // clip from world, column-major
  int width = 0, height = 0;
};

// The frames the page drew into the recording and their span.
struct Recorded {
  int frames = 0;
  double seconds = 0;
};

// A recording's state: queued (waiting for a page), running (parts arriving), succeeded (done) or
// failed; the API names them waiting, recording, done, failed.
struct RecordingStatus {
  std::string id;
  RecordingSpec spec;
  Lifecycle state = Lifecycle::queued;
  std::size_t parts = 0, bytes = 0;
  std::optional<Camera> camera;
  std::optional<Recorded> recorded;
  std::string error;  // a failed recording's reason, from the page
};
const char* recording_state_name(Lifecycle state);

struct RecordingRef {
  std::string id;
};

struct PartRef {
  std::string id;
  std::size_t index = 0;
};

// PUT .../parts/{index}: the part's bytes, moved from the request and on into the recording.
struct PartUpload {
  PartRef ref;
  mutable std::string bytes;
};

// POST .../finish: the page's camera and what it recorded, or the error that stopped it.
struct RecordingEnd {
  std::string id;
  std::optional<Camera> camera;
  std::optional<Recorded> recorded;
  std::string error;
};

struct RecordingPart {
  std::string format;
  std::string bytes;
};

RecordingSpec decode_recording_spec(const Request& request, const Limits& limits);
RecordingRef decode_recording_ref(const Request& request, const Limits& limits);
PartRef decode_part_ref(const Request& request, const Limits& limits);
PartUpload decode_part_upload(Request& request, const Limits& limits);
RecordingEnd decode_recording_end(const Request& request, const Limits& limits);
Response encode_new_recording(const RecordingStatus& recording);  // 201
Response encode_recording(const RecordingStatus& recording);
Response encode_part(const RecordingPart& part);

}  // namespace distlab::server
