// The service's side of a scenario's Kelvin fields (cbf_field_service.hpp).
#include "cbf_field_service.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "distlab/geometry/error.hpp"
#include "distlab/server/deadline.hpp"
#include "distlab/server/frames.hpp"
#include "distlab/server/http.hpp"
#include "distlab/server/json_fields.hpp"
#include "distlab/server/kelvin_json.hpp"

namespace distlab::server {

using json = nlohmann::json;

namespace {

// The budget of POST /api/kelvin/objects: l_x at least min_lx and the vertex budget
// (kelvin_json.hpp: count_vertices; 422 over_budget naming lx_field, with an l_x that fits). The prediction,
// where the closed form is over and `surface` is the one prepared, stops at `cancel` (a
// request's deadline or the job's token).
void check_budget(const mesh::SurfaceMesh& surface, bool prepared, const kelvin::PrepareOptions& options, const std::string& lx_field,
                  const Limits& lim, const std::atomic<bool>* cancel, bool deadline) {
  if (options.lx < lim.min_lx)
    throw ApiError(422, "over_budget", lx_field + " gives lx " + json(options.lx).dump() + " m, but lx must be at least " + json(lim.min_lx).dump() + " m on this server",
                   lx_field);
  const auto predict = [cancel, deadline, &lim](const mesh::SurfaceMesh& s, const kelvin::PrepareOptions& o) {
    kelvin::Progress progress;
    progress.cancel = cancel;
    try {
      return kelvin::predict_preparation(s, o, progress).vertices;
    } catch (const kelvin::Cancelled&) {
      if (!deadline) throw;
      throw std::runtime_error("not predicted within this server's max_request_seconds (" + json(lim.max_request_seconds).dump() + " s)");
    }
  };
  const double closed_form = estimate_vertices(surface, options.lx, options.far_radius, sizing_for_budget(options));
  require_within_budget(count_vertices(closed_form, prepared ? &surface : nullptr, options, lim, predict), surface, options, lim, lx_field, lx_field);
}

}  // namespace

void refuse_mesh_paths(const json& request) {
  if (!request.is_object()) return;
  const auto sc = request.find("scenario");
  if (sc == request.end() || !sc->is_object()) return;  // a name: a file of the assets
  const auto fields = sc->find("fields");
  if (fields == sc->end() || !fields->is_array()) return;
  for (std::size_t i = 0; i < fields->size(); ++i) {
    const json& f = (*fields)[i];
    if (f.is_object() && f.contains("mesh") && f["mesh"].is_object() && f["mesh"].contains("path"))
      throw InvalidInput(json_key_path(json_index_path("scenario.fields", i), "mesh.path"),
                         "the service reads no file paths: give a built-in mesh as mesh.asset (GET /api/kelvin/assets)");
  }
}

void check_field_budget(const PlannedField& p, const Limits& lim) {
  kelvin::PrepareOptions options = p.options;
  options.max_vertices = std::max<std::size_t>(100, lim.max_vertex_estimate);
  try {
    const CancelAfter deadline(lim.max_request_seconds);
    // The reshaped surface is checked when it is made.
    check_budget(p.prepared, !p.reshape.any(), p.options, p.lx_field, lim, deadline.flag(), true);
    if (!p.reshape.any()) kelvin::check_prepare_inputs(p.prepared, options);
  } catch (const InvalidInput& e) {
    const std::string& f = e.field();
    throw InvalidInput(f == "lx" ? p.lx_field : json_key_path(p.field, f.empty() ? "mesh" : f), e.what());
  }
}

FieldPreparer service_preparer(const std::string& cache_dir, const Limits& lim, const Progress& progress, SharedFields& shared) {
  return [cache_dir, lim, progress, &shared](const mesh::SurfaceMesh& surface, const kelvin::PrepareOptions& options, const std::string& field) {
    check_budget(surface, true, options, json_key_path(field, "lx"), lim, progress.cancel, false);
    kelvin::PrepareOptions capped = options;
    capped.max_vertices = std::max<std::size_t>(100, lim.max_vertex_estimate);
    const std::shared_ptr<std::timed_mutex> content = shared.preparation_lock(surface, capped);
    std::unique_lock lock(*content, std::defer_lock);
    while (!lock.try_lock_for(std::chrono::milliseconds(100))) progress.check();
    return kelvin::Field::prepare_cached(surface, capped, field_store(cache_dir, lim), progress);
  };
}

std::shared_ptr<std::timed_mutex> SharedFields::preparation_lock(const mesh::SurfaceMesh& surface, const kelvin::PrepareOptions& o) {
  const std::string key = kelvin::prepare_key(surface, o);
  std::lock_guard lock(mutex_);
  for (auto it = preparing_.begin(); it != preparing_.end();) it = it->second.expired() ? preparing_.erase(it) : std::next(it);
  std::weak_ptr<std::timed_mutex>& slot = preparing_[key];
  auto m = slot.lock();
  if (!m) slot = m = std::make_shared<std::timed_mutex>();
  return m;
}

std::map<std::string, cbf::SceneField> SharedFields::held(const FieldPlan& plan) const {
  std::map<std::string, cbf::SceneField> out;
  std::lock_guard lock(mutex_);
  for (const PlannedField& p : plan.fields) {
    auto it = fields_.find(p.key);
    if (it == fields_.end()) continue;
    if (auto field = it->second.second.lock()) {
      cbf::SceneField sf = it->second.first;
      sf.field = std::move(field);
      out.emplace(p.key, std::move(sf));
    }
  }
  return out;
}

void SharedFields::remember(const std::map<std::string, cbf::SceneField>& prepared) {
  std::lock_guard lock(mutex_);
  for (auto it = fields_.begin(); it != fields_.end();) it = it->second.second.expired() ? fields_.erase(it) : std::next(it);
  for (const auto& [key, sf] : prepared) {
    cbf::SceneField light = sf;
    light.field.reset();
    fields_.insert_or_assign(key, std::make_pair(std::move(light), std::weak_ptr<const kelvin::Field>(sf.field)));
  }
}

std::vector<CbfRolloutField> rollout_fields(const FieldPlan& plan) {
  std::vector<CbfRolloutField> out;
  for (const PlannedField& p : plan.fields)
    out.push_back({p.scene.name, p.scene.margin, p.scene.pose, p.surface, kelvin::evaluate_at_vertices(p.user_sigma, p.surface.vertices), nullptr});
  return out;
}

CbfFieldSurfaces field_surfaces(const std::shared_ptr<const CbfRollout>& rollout, const std::optional<std::vector<double>>& levels) {
  const CbfRollout& r = *rollout;
  if (r.fields.empty()) throw ApiError(404, "no_fields", "this rollout's scenario has no Kelvin fields");
  std::vector<std::shared_ptr<const kelvin::Field>> prepared;
  std::string state;
  {
    std::lock_guard lock(r.mutex);
    state = r.fields_state_word();
    for (const CbfRolloutField& f : r.fields) prepared.push_back(f.field);
  }
  if (state == "preparing")
    throw ApiError(409, "not_ready", "the rollout's fields are being prepared (its job's stages); ask again once its frames arrive");
  if (state == "failed") throw ApiError(409, "fields_failed", "the rollout's fields could not be prepared (its job's error says why)");
  if (state == "released")
    throw ApiError(410, "fields_released",
                   "this rollout's prepared fields were released for newer rollouts' (cbf_fields_kept_total in GET /api/limits); run it again");
  CbfFieldSurfaces out{rollout, {}};
  for (std::size_t i = 0; i < r.fields.size(); ++i) {
    std::vector<double> wanted = levels ? *levels : std::vector<double>{0.0};
    if (!levels && r.fields[i].delta != 0) wanted.push_back(r.fields[i].delta);
    std::vector<CbfIsosurface>& isosurfaces = out.isosurfaces.emplace_back();
    for (const double level : wanted) {
      CbfIsosurface& iso = isosurfaces.emplace_back(CbfIsosurface{level, prepared[i]->isosurface(level), 0.0});
      if (iso.mesh.faces.rows() == 0) iso.h_min = prepared[i]->minimum();
    }
  }
  return out;
}

json fields_frame(const CbfFieldSurfaces& surfaces) {
  const CbfRollout& r = *surfaces.rollout;
  json fields = json::array();
  for (std::size_t i = 0; i < r.fields.size(); ++i) {
    const CbfRolloutField& f = r.fields[i];
    json isosurfaces = json::array();
    for (const CbfIsosurface& iso : surfaces.isosurfaces[i]) {
      json frame = mesh_frame(iso.mesh, {{"type", "isosurface"}, {"level", iso.level}});
      if (iso.mesh.faces.rows() == 0) frame["empty"] = true, frame["h_min"] = iso.h_min;
      isosurfaces.push_back(std::move(frame));
    }
    fields.push_back({{"index", i},
                      {"name", f.name},
                      {"delta", f.delta},
                      {"pose", pose_json(f.pose)},
                      {"frame", "object"},
                      {"surface", mesh_frame(f.surface, {{"type", "surface"}}, &f.sigma)},
                      {"isosurfaces", std::move(isosurfaces)}});
  }
  return {{"type", "cbf_fields"}, {"rollout", r.id}, {"fields", std::move(fields)}};
}

}  // namespace distlab::server
