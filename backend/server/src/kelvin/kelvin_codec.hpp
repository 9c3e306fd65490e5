#pragma once
// The codec of the Kelvin object routes (routes_kelvin.cpp): decode_* read a request into a typed
// input and are the only place that validates it (the WebSocket's "sigma" and "watch" use the same
// decode_sigma and decode_levels); encode_* write a handler's typed result as the answer.
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "distlab/kelvin/field.hpp"
#include "distlab/mesh/checks.hpp"
#include "distlab/mesh/repair.hpp"
#include "distlab/mesh/surface.hpp"
#include "distlab/server/config.hpp"
#include "distlab/server/http.hpp"
#include "distlab/server/jobs.hpp"
#include "distlab/server/kelvin_json.hpp"
#include "distlab/server/kelvin_objects.hpp"
#include "distlab/server/route_table.hpp"
#include "prepare_estimate.hpp"

namespace distlab::server {

// A number as the JSON answers write it (the shortest that reads back the same), for messages.
inline std::string number_text(double v) { return nlohmann::json(v).dump(); }

// An object of the caller's session: the path's {id}.
struct ObjectRef {
  std::string id;
};
ObjectRef decode_object_ref(const Request& request, const Limits& limits);

// σ as a client sets it: the spec, and its JSON as given (compact), which GET .../sigma echoes.
struct SigmaEdit {
  kelvin::SigmaSpec spec;
  std::string given;
};
// The σ of PUT .../sigma's body, of the WebSocket's "sigma" and of a create request's "sigma".
SigmaEdit decode_sigma(const nlohmann::json& sigma);
// The watched levels of PUT .../levels, of the WebSocket's "watch" and of a create request: at
// most max_levels numbers (413 too_many_levels).
std::vector<double> decode_levels(const nlohmann::json& levels, const Limits& limits);
// message[key], or InvalidInput "<key> is required".
const nlohmann::json& required_field(const nlohmann::json& message, const char* key);

// POST /api/kelvin/objects and /api/kelvin/estimate.
struct CreateObjectRequest {
  std::string asset, upload;              // the asset's name or the upload's id, when given
  std::optional<mesh::SurfaceMesh> mesh;  // an inline mesh
  kelvin::PrepareOptions options;         // lx is 0 while given as lx_fraction
  std::optional<double> lx_fraction, far_radius;
  ReshapeRequest reshape;
  std::optional<SigmaEdit> sigma;
  std::optional<std::vector<double>> levels;
  const char* source_field() const { return !asset.empty() ? "asset" : !upload.empty() ? "upload"
                                                                                       : "mesh"; }
  const char* lx_field() const { return lx_fraction ? "lx_fraction" : "lx"; }
};
CreateObjectRequest decode_create_object(const Request& request, const Limits& limits);

struct CreatedObject {
  std::shared_ptr<KelvinObject> object;
  std::shared_ptr<Job> job;
};
Response encode_created_object(const CreatedObject& created);

// What creating would cost (KelvinModule::estimate).
struct ObjectEstimate {
  long long vertex_estimate = 0;  // the closed form
  long long budget_vertices = 0;  // the count the budget holds (VertexCount::count)
  std::size_t max_vertex_estimate = 0;
  double min_lx = 0, diagonal = 0, lx_for_budget = 0;
  std::optional<std::pair<std::string, std::string>> problem;  // field, message
  std::optional<std::string> prediction_note;
  std::optional<kelvin::PreparePrediction> prediction;
  PrepareRate::Rate rate;  // at the predicted vertices
  std::optional<mesh::WrapEstimate> repair;
};
Response encode_estimate(const ObjectEstimate& estimate);

struct ObjectList {
  std::vector<std::shared_ptr<KelvinObject>> objects;
};
Response encode_object_list(const ObjectList& list);
Response encode_object(const std::shared_ptr<KelvinObject>& object);
Response encode_deleted(const Nothing& nothing);

struct SigmaRequest {
  std::string id;
  SigmaEdit sigma;
};
SigmaRequest decode_put_sigma(const Request& request, const Limits& limits);
struct SigmaState {
  std::string given;  // SigmaEdit::given
  std::uint64_t version = 0;
};
Response encode_sigma(const SigmaState& sigma);

struct LevelsRequest {
  std::string id;
  std::vector<double> levels;
};
LevelsRequest decode_put_levels(const Request& request, const Limits& limits);
Response encode_levels(const std::vector<double>& levels);

struct QueryRequest {
  std::string id;
  std::vector<Vec3> points;
};
QueryRequest decode_query(const Request& request, const Limits& limits);
struct QueryResult {
  std::vector<kelvin::Sample> samples;
  std::uint64_t sigma_version = 0;
};
Response encode_query(const QueryResult& result);

// GET .../isosurface and .../export: one level (query_level), and the export's file format.
struct LevelRequest {
  std::string id;
  double level = 0;
  std::string format;  // export only: stl (default), obj, ply or glb
};
LevelRequest decode_isosurface(const Request& request, const Limits& limits);
LevelRequest decode_export(const Request& request, const Limits& limits);
struct Isosurface {
  std::string object;
  double level = 0;
  std::uint64_t sigma_version = 0;
  mesh::SurfaceMesh mesh;
};
Response encode_isosurface(const Isosurface& iso);
struct ExportFile {
  std::string object, format, bytes, digest;
  mesh::SurfaceReport check;
};
Response encode_export(const ExportFile& file);

// GET .../surface?of=input|repaired.
struct SurfaceRequest {
  std::string id;
  bool repaired = false;  // of=repaired
};
SurfaceRequest decode_surface(const Request& request, const Limits& limits);
struct SurfaceView {
  std::shared_ptr<const KelvinObject> object;  // holds `shown`
  const mesh::SurfaceMesh* shown = nullptr;
  bool repaired = false;
  std::uint64_t sigma_version = 0;
  std::vector<double> sigma;  // per vertex of `shown`
};
Response encode_surface(const SurfaceView& view);

}  // namespace distlab::server
