#include "distlab/server/kelvin_objects.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "distlab/kelvin/digest.hpp"
#include "distlab/kelvin/progress.hpp"
#include "distlab/kelvin/sigma.hpp"

namespace distlab::server {

using json = nlohmann::json;

namespace {

bool same_options(const kelvin::PrepareOptions& a, const kelvin::PrepareOptions& b) {
  return a.lx == b.lx && a.far_radius == b.far_radius && a.feature_angle == b.feature_angle &&
         a.centre.has_value() == b.centre.has_value() && (!a.centre || *a.centre == *b.centre);
}

bool same_surface(const mesh::SurfaceMesh& a, const mesh::SurfaceMesh& b) {
  return a.vertices.rows() == b.vertices.rows() && a.faces.rows() == b.faces.rows() &&
         a.vertices == b.vertices && a.faces == b.faces;
}

// The surface, then (if given) the preparation options: the content key of the shared registry.
std::string surface_hash(const mesh::SurfaceMesh& s, const kelvin::PrepareOptions* o) {
  kelvin::Sha256 h;
  const std::int64_t rows[2] = {s.vertices.rows(), s.faces.rows()};
  h.add(rows, sizeof rows);
  h.add(s.vertices.data(), sizeof(double) * static_cast<std::size_t>(s.vertices.size()));
  h.add(s.faces.data(), sizeof(int) * static_cast<std::size_t>(s.faces.size()));
  if (o != nullptr) {
    const Vec3 c = o->centre.value_or(Vec3::Constant(std::nan("")));
    const double params[7] = {o->lx, o->far_radius, o->feature_angle, c.x(), c.y(), c.z(), o->centre ? 1.0 : 0.0};
    h.add(params, sizeof params);
  }
  return h.hex();
}

}  // namespace

std::string content_key(const mesh::SurfaceMesh& s, const kelvin::PrepareOptions& o) { return surface_hash(s, &o); }

std::string mesh_digest(const mesh::SurfaceMesh& s) { return surface_hash(s, nullptr); }

PreparedRegistry::Entry* PreparedRegistry::find_locked(const std::string& key, const mesh::SurfaceMesh& s,
                                                       const kelvin::PrepareOptions& o) {
  auto [lo, hi] = entries_.equal_range(key);
  for (auto it = lo; it != hi; ++it)
    if (same_options(it->second.options, o) && same_surface(it->second.surface, s)) return &it->second;
  return nullptr;
}

std::shared_ptr<PreparedField> PreparedRegistry::acquire(const mesh::SurfaceMesh& surface,
                                                         const kelvin::PrepareOptions& options,
                                                         const kelvin::Progress& progress, bool* from_memory) {
  const std::string key = content_key(surface, options);
  if (from_memory) *from_memory = false;
  {
    std::unique_lock lock(mutex_);
    for (;;) {
      Entry* e = find_locked(key, surface, options);
      if (e == nullptr) {
        Entry fresh{surface, options, {}, true};
        entries_.emplace(key, std::move(fresh));
        break;
      }
      if (auto f = e->field.lock()) {
        if (from_memory) *from_memory = true;
        return f;
      }
      if (!e->preparing) {
        e->preparing = true;
        break;
      }
      // Another job prepares the same content: wait for it (and stay cancellable).
      cv_.wait_for(lock, std::chrono::milliseconds(100));
      progress.check();
    }
  }
  auto release = [&](const std::shared_ptr<PreparedField>& f) {
    {
      std::lock_guard lock(mutex_);
      Entry* e = find_locked(key, surface, options);
      if (e != nullptr) {
        e->preparing = false;
        if (f) e->field = f;
      }
      if (f) {
        recent_.push_back(f);
        if (recent_.size() > 4) recent_.erase(recent_.begin());
      }
      // Forget entries nobody holds (their disk cache remains).
      for (auto it = entries_.begin(); it != entries_.end();)
        it = (!it->second.preparing && it->second.field.expired()) ? entries_.erase(it) : std::next(it);
    }
    cv_.notify_all();
  };
  try {
    bool hit = false;
    kelvin::Field field = cache_dir_.empty()
                              ? kelvin::Field::prepare(surface, options, progress)
                              : kelvin::Field::prepare_cached(surface, options, cache_dir_, progress, &hit);
    auto prepared = std::make_shared<PreparedField>(key, std::move(field));
    prepared->cache_hit = hit;
    release(prepared);
    return prepared;
  } catch (...) {
    release(nullptr);
    throw;
  }
}

std::size_t PreparedRegistry::size() const {
  std::lock_guard lock(mutex_);
  return entries_.size();
}

json KelvinObject::status_json() {
  std::lock_guard lock(mutex);
  json j = {{"id", id}, {"state", state}, {"job", job}, {"source", source},
            {"n_input_vertices", surface.vertices.rows()}, {"n_input_faces", surface.faces.rows()},
            {"n_welded_vertices", welded.vertices.rows()},
            {"sigma_version", sigma_version}, {"levels", levels}, {"key", key}};
  if (!error.is_null()) j["error"] = error;
  if (prepared) {
    const kelvin::Stats& st = prepared->field.stats();
    j["stats"] = {{"n_verts", st.n_verts}, {"n_tets", st.n_tets}, {"size_mb", st.size_mb},
                  {"t_mesh", st.t_mesh},   {"t_build", st.t_build}, {"t_decomp", st.t_decomp},
                  {"t_solve", st.t_solve}, {"cache_hit", prepared->cache_hit}, {"shared", shared}};
    const Vec3 c = prepared->field.centre();
    j["center"] = {c.x(), c.y(), c.z()};
  }
  return j;
}

std::vector<double> sigma_at_vertices(const kelvin::SigmaSpec& sigma, const mesh::SurfaceMesh& surface) {
  std::vector<double> out(static_cast<std::size_t>(surface.vertices.rows()), sigma.constant);
  for (Eigen::Index v = 0; v < surface.vertices.rows(); ++v) {
    const Vec3 x = surface.vertices.row(v).transpose();
    double& s = out[static_cast<std::size_t>(v)];
    if (sigma.per_vertex && v < sigma.per_vertex->size()) s += (*sigma.per_vertex)[v];
    for (const auto& a : sigma.axis) s += kelvin::evaluate(a, x);
    for (const auto& b : sigma.brushes) s += kelvin::evaluate(b, x);
  }
  return out;
}

kelvin::SigmaSpec field_sigma(const kelvin::SigmaSpec& user, const mesh::SurfaceMesh& surface,
                              const std::vector<int>& to_welded, Eigen::Index n_welded) {
  kelvin::SigmaSpec welded = kelvin::weld_sigma(user, to_welded, n_welded);
  const std::vector<double> total = sigma_at_vertices(user, surface);
  for (std::size_t v = 0; v < total.size(); ++v)
    kelvin::require_sigma_in_range(total[v], surface.vertices.row(static_cast<Eigen::Index>(v)).transpose(),
                                   "vertex " + std::to_string(v));
  return welded;
}

double estimate_vertices(const mesh::SurfaceMesh& surface, double lx, double far_radius) {
  if (surface.vertices.rows() == 0 || !(lx > 0)) return 0;
  const Vec3 lo = surface.vertices.colwise().minCoeff().transpose();
  const Vec3 hi = surface.vertices.colwise().maxCoeff().transpose();
  const double r = 0.5 * (hi - lo).norm();
  const double ratio = std::max(1.0, far_radius) * r / lx;
  return kVertexEstimateConstant * ratio * ratio * ratio + static_cast<double>(surface.vertices.rows());
}

double lx_within(const mesh::SurfaceMesh& surface, double budget, double far_radius) {
  // estimate_vertices solved for lx at the budget (the input's own vertices count too).
  const double room = budget - static_cast<double>(surface.vertices.rows());
  if (surface.vertices.rows() == 0 || !(room > 0)) return std::numeric_limits<double>::infinity();
  const Vec3 lo = surface.vertices.colwise().minCoeff().transpose();
  const Vec3 hi = surface.vertices.colwise().maxCoeff().transpose();
  const double r = 0.5 * (hi - lo).norm();
  return std::max(1.0, far_radius) * r / std::cbrt(room / kVertexEstimateConstant);
}

}  // namespace distlab::server
