#pragma once
// The service's side of a scenario's Kelvin fields (cbf_fields.hpp): what it refuses before a job
// starts (mesh paths, the vertex budget), how its jobs prepare (the service's cache directory, the
// job's progress), the prepared fields shared while anyone holds them, and the objects and
// iso-surfaces of GET /api/cbf/rollouts/{id}/fields.
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "cbf_fields.hpp"
#include "distlab/server/cbf_rollouts.hpp"
#include "distlab/server/config.hpp"

namespace distlab::server {

// An inline scenario's "mesh": {"path"} names a file on the server: 400 naming it (the service
// reads built-in assets; the scenario files in assets/ may use paths).
void refuse_mesh_paths(const nlohmann::json& request);

// What POST /api/kelvin/objects refuses, refused for a planned field: l_x below min_lx or a vertex
// estimate over max_vertex_estimate (422 over_budget naming p.lx_field), and the surface checks of
// prepare (400 naming the field) unless a repair comes first.
void check_field_budget(const PlannedField& p, const Limits& limits);

// Prepared fields by PlannedField::key, held weakly: a rollout, sweep or feasibility check asking
// for a field another one holds gets it at once instead of a second copy. And one preparation
// per content at a time: a second one of the same content (a rollout and a feasibility check
// of one scenario) waits and reads the first one's cache file instead of meshing and factoring
// it again beside it (twice the time and memory).
class SharedFields {
 public:
  // The planned fields someone holds now, by key (prepare_planned_fields' `prepared`).
  std::map<std::string, cbf::SceneField> held(const FieldPlan& plan) const;
  void remember(const std::map<std::string, cbf::SceneField>& prepared);
  // The lock of a preparation's content (surface and options).
  std::shared_ptr<std::timed_mutex> preparation_lock(const mesh::SurfaceMesh& surface, const kelvin::PrepareOptions& options);

 private:
  mutable std::mutex mutex_;
  std::map<std::string, std::pair<cbf::SceneField, std::weak_ptr<const kelvin::Field>>> fields_;  // SceneField without its field
  std::map<std::string, std::weak_ptr<std::timed_mutex>> preparing_;
};

// kelvin::Field::prepare_cached in the service's cache directory, meshing capped at the vertex
// budget, one preparation per content at a time (waiting cancellably), Kelvin's stages reported
// to progress (which also cancels). A repaired surface is checked against the budget first.
FieldPreparer service_preparer(const std::string& cache_dir, const Limits& limits, const Progress& progress, SharedFields& shared);

// The objects of a plan as the viewer draws them: each surface as given and σ at its vertices.
std::vector<CbfRolloutField> rollout_fields(const FieldPlan& plan);

// The iso-surfaces of a rollout's prepared fields, per field: levels the same for every field, or
// (nullopt) 0 and the field's δ. 404 without fields; 409 while they are prepared or if that failed;
// 410 once released (Limits::cbf_fields_kept_total).
struct CbfIsosurface {
  double level = 0;
  mesh::SurfaceMesh mesh;
  double h_min = 0;  // the field's minimum (an empty mesh: a level the field never takes)
};
struct CbfFieldSurfaces {
  std::shared_ptr<const CbfRollout> rollout;
  std::vector<std::vector<CbfIsosurface>> isosurfaces;  // per field
};
CbfFieldSurfaces field_surfaces(const std::shared_ptr<const CbfRollout>& rollout, const std::optional<std::vector<double>>& levels);
// GET /api/cbf/rollouts/{id}/fields (msgpack): {"type": "cbf_fields", "rollout", "fields":
// [{"index", "name", "delta", "pose", "frame": "object", "surface": mesh frame (frames.hpp) with σ
// per vertex as its scalars, "isosurfaces": [mesh frame + "level" (+ "empty", "h_min" for a level
// the field never takes)]}]}. Geometry is in the object's frame: world = pose · x.
nlohmann::json fields_frame(const CbfFieldSurfaces& surfaces);

}  // namespace distlab::server
