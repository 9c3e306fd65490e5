#include "distlab/server/kelvin_objects.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>

#include "distlab/geometry/error.hpp"
#include "distlab/kelvin/progress.hpp"
#include "distlab/kelvin/sigma.hpp"
#include "distlab/kelvin/surface_tools.hpp"
#include "distlab/mesh/checks.hpp"
#include "distlab/mesh/simplify.hpp"
#include "distlab/server/json_fields.hpp"

namespace distlab::server {

using json = nlohmann::json;

namespace {

bool same_options(const kelvin::PrepareOptions& a, const kelvin::PrepareOptions& b) {
  return a.lx == b.lx && a.far_radius == b.far_radius && a.grading == b.grading && a.feature_angle == b.feature_angle &&
         a.centre.has_value() == b.centre.has_value() && (!a.centre || *a.centre == *b.centre);
}

bool same_surface(const mesh::SurfaceMesh& a, const mesh::SurfaceMesh& b) {
  return a.vertices.rows() == b.vertices.rows() && a.faces.rows() == b.faces.rows() &&
         a.vertices == b.vertices && a.faces == b.faces;
}

}  // namespace

PreparedRegistry::Entry* PreparedRegistry::find_locked(const std::string& key, const mesh::SurfaceMesh& s,
                                                       const kelvin::PrepareOptions& o) {
  auto [lo, hi] = entries_.equal_range(key);
  for (auto it = lo; it != hi; ++it)
    if (same_options(it->second.options, o) && same_surface(it->second.surface, s)) return &it->second;
  return nullptr;
}

ResponseBudget::Share::~Share() {
  const std::lock_guard lock(budget_->mutex_);
  budget_->used_ -= bytes_;
}

std::unique_ptr<ResponseBudget::Share> ResponseBudget::take(std::size_t bytes) {
  const std::lock_guard lock(mutex_);
  if (bytes > total_ - used_) return nullptr;
  used_ += bytes;
  return std::make_unique<Share>(shared_from_this(), bytes);
}

std::size_t ResponseBudget::used() const {
  const std::lock_guard lock(mutex_);
  return used_;
}

std::shared_ptr<PreparedField> PreparedRegistry::acquire(const std::string& key, const mesh::SurfaceMesh& surface,
                                                         const kelvin::PrepareOptions& options,
                                                         const kelvin::Progress& progress, bool* from_memory) {
  if (from_memory) *from_memory = false;
  if (auto f = find_or_claim(key, surface, options, progress)) {
    if (from_memory) *from_memory = true;
    return f;
  }
  try {
    auto prepared = prepare(key, surface, options, progress);
    release(key, surface, options, prepared);
    return prepared;
  } catch (...) {
    release(key, surface, options, nullptr);
    throw;
  }
}

std::shared_ptr<PreparedField> PreparedRegistry::find_or_claim(const std::string& key, const mesh::SurfaceMesh& surface,
                                                               const kelvin::PrepareOptions& options, const kelvin::Progress& progress) {
  std::unique_lock lock(mutex_);
  for (;;) {
    Entry* e = find_locked(key, surface, options);
    if (e == nullptr) {
      Entry fresh{surface, options, {}, true};
      entries_.emplace(key, std::move(fresh));
      return nullptr;
    }
    if (auto f = e->field.lock()) return f;
    if (!e->preparing) {
      e->preparing = true;
      return nullptr;
    }
    // Another job prepares the same content: wait for it (and stay cancellable).
    cv_.wait_for(lock, std::chrono::milliseconds(100));
    progress.check();
  }
}

void PreparedRegistry::release(const std::string& key, const mesh::SurfaceMesh& surface, const kelvin::PrepareOptions& options,
                               const std::shared_ptr<PreparedField>& f) {
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
}

std::shared_ptr<PreparedField> PreparedRegistry::prepare(const std::string& key, const mesh::SurfaceMesh& surface,
                                                         const kelvin::PrepareOptions& options, const kelvin::Progress& progress) {
  const auto t0 = std::chrono::steady_clock::now();
  bool hit = false;
  kelvin::Field field = store_.dir.empty() ? kelvin::Field::prepare(surface, options, progress)
                                           : kelvin::Field::prepare_cached(surface, options, store_, progress, &hit);
  const double response_mb = field.boundary_response_megabytes();
  const auto response_bytes = static_cast<std::size_t>(std::llround(response_mb * 1e6));
  std::unique_ptr<ResponseBudget::Share> share;
  if (response_bytes <= response_bytes_) share = take_response(response_bytes);
  if (share && !field.build_boundary_response(response_mb, progress)) share.reset();
  auto prepared = std::make_shared<PreparedField>(key, std::move(field));
  prepared->cache_hit = hit;
  prepared->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  prepared->response_share = std::move(share);
  return prepared;
}

std::unique_ptr<ResponseBudget::Share> PreparedRegistry::take_response(std::size_t bytes) {
  if (auto share = responses_->take(bytes)) return share;
  {  // Kept only by recent_ (the registry's lock stops anyone from taking them meanwhile).
    std::lock_guard lock(mutex_);
    for (const auto& f : recent_)
      if (f.use_count() == 1 && f->response_share) f->release_response();
  }
  return responses_->take(bytes);
}

bool PreparedRegistry::in_memory(const std::string& key, const mesh::SurfaceMesh& surface, const kelvin::PrepareOptions& options) {
  std::lock_guard lock(mutex_);
  const Entry* e = find_locked(key, surface, options);
  return e != nullptr && (e->preparing || !e->field.expired());
}

std::size_t PreparedRegistry::size() const {
  std::lock_guard lock(mutex_);
  return entries_.size();
}

const char* object_state_name(Lifecycle state, PrepareStage stage) {
  switch (state) {
    case Lifecycle::queued:
    case Lifecycle::running:
      return stage == PrepareStage::repairing ? "repairing" : "preparing";
    case Lifecycle::succeeded:
      return "ready";
    case Lifecycle::failed:
      return "failed";
    case Lifecycle::cancelled:
      return "cancelled";
  }
  return "unknown";
}

namespace {
json source_json(const ObjectSource& s) {
  json j = {{"lx", s.lx}, {"vertex_estimate", s.vertex_estimate}, {"repair", s.repair}};
  if (!s.asset.empty()) j["asset"] = s.asset;
  else if (!s.upload.empty()) j["upload"] = s.upload;
  else j["mesh"] = "inline";
  if (s.center) j["center"] = {s.center->x(), s.center->y(), s.center->z()};
  if (s.far_radius) j["far_radius"] = *s.far_radius;
  if (s.grading) j["grading"] = *s.grading;
  if (s.lx_fraction) j["lx_fraction"] = *s.lx_fraction;
  return j;
}
}  // namespace

json KelvinObject::status_json() {
  std::lock_guard lock(mutex);
  json j = {{"id", id}, {"state", object_state_name(state, stage)}, {"job", job}, {"source", source_json(source)}, {"n_input_vertices", surface.vertices.rows()}, {"n_input_faces", surface.faces.rows()}, {"n_welded_vertices", welded.vertices.rows()}, {"surface_digest", surface_digest}, {"repair", reshape.repair.kind}, {"sigma_version", sigma_version}, {"levels", levels}, {"key", key}};
  if (!error.is_null()) j["error"] = error;
  if (!repair_report.is_null()) j["repair_report"] = repair_report;
  if (reshape.simplify_faces > 0) j["simplify"] = {{"faces", reshape.simplify_faces}};
  if (reshape.largest_piece) j["components"] = "largest";
  if (!components_report.is_null()) j["components_report"] = components_report;
  if (!simplify_report.is_null()) j["simplify_report"] = simplify_report;
  if (!estimate.is_null()) j["estimate"] = estimate;
  if (prepared) {
    const kelvin::Stats& st = prepared->field.stats();
    j["stats"] = {{"n_verts", st.n_verts}, {"n_tets", st.n_tets}, {"size_mb", st.size_mb}, {"t_mesh", st.t_mesh}, {"t_build", st.t_build}, {"t_decomp", st.t_decomp}, {"t_solve", st.t_solve}, {"grading", st.grading}, {"mesh_threads", st.mesh_threads}, {"response_mb", st.response_mb}, {"cache_hit", prepared->cache_hit}, {"shared", shared}, {"t_prepare", prepared->seconds}};
    if (stage_seconds) {
      json t = json::object();
      for (std::size_t i = 0; i < kelvin::kPrepareStageCount; ++i) t[kelvin::kPrepareStages[i]] = (*stage_seconds)[i];
      j["stats"]["t_stages"] = std::move(t);
    }
    const Vec3 c = prepared->field.centre();
    j["center"] = {c.x(), c.y(), c.z()};
  }
  return j;
}

kelvin::SigmaSpec carry_sigma(kelvin::SigmaSpec solved, const kelvin::SigmaSpec& user, const mesh::Transfer& to_repaired) {
  if (!user.per_vertex) return solved;
  const std::vector<double> values(user.per_vertex->data(), user.per_vertex->data() + user.per_vertex->size());
  const std::vector<double> carried = to_repaired.apply(values);
  solved.per_vertex = VecX(Eigen::Map<const VecX>(carried.data(), static_cast<Eigen::Index>(carried.size())));
  return solved;
}

kelvin::SigmaSpec field_sigma(const kelvin::SigmaSpec& user, const KelvinObject& o) {
  kelvin::SigmaSpec out = kelvin::field_sigma(user, o.surface.vertices, o.to_welded, o.welded.vertices.rows());
  return o.reshaped() ? carry_sigma(std::move(out), user, o.to_repaired) : out;
}

std::size_t parse_simplify(const json& body, const Limits& lim) {
  if (!body.contains("simplify")) return 0;
  const json& s = body["simplify"];
  json_require_object(s, "simplify");
  json_check_keys(s, "simplify", {"faces"});
  if (!s.contains("faces")) throw InvalidInput("simplify.faces", "simplify needs faces (the face count to simplify to)");
  const json& n = s["faces"];
  if (!n.is_number_integer() || n.get<std::int64_t>() < 4 || n.get<std::int64_t>() > static_cast<std::int64_t>(lim.max_object_triangles))
    throw InvalidInput("simplify.faces", "faces must be a whole number in [4, " + std::to_string(lim.max_object_triangles) + "]");
  return n.get<std::size_t>();
}

// "repair": "none" | "fix" | "wrap" and its "repair_options" (fix: max_hole_edges; wrap: alpha and
// offset in metres), each bounded by the limits table.
RepairRequest parse_repair(const json& body, const Limits& lim) {
  RepairRequest r;
  if (body.contains("repair")) {
    if (!body["repair"].is_string() || (body["repair"] != "none" && body["repair"] != "fix" && body["repair"] != "wrap"))
      throw InvalidInput("repair", "repair must be \"none\", \"fix\" or \"wrap\"");
    r.kind = body["repair"];
  }
  if (!body.contains("repair_options")) return r;
  const json& o = body["repair_options"];
  json_require_object(o, "repair_options");
  if (r.kind == "none") throw InvalidInput("repair_options", "repair_options needs repair \"fix\" or \"wrap\"");
  if (r.kind == "fix") {
    json_check_keys(o, "repair_options", {"max_hole_edges"});
    if (o.contains("max_hole_edges")) {
      const json& m = o["max_hole_edges"];
      if (!m.is_number_integer() || m.get<std::int64_t>() < 0 || m.get<std::int64_t>() > static_cast<std::int64_t>(lim.max_hole_edges))
        throw InvalidInput("repair_options.max_hole_edges", "max_hole_edges must be a whole number in [0, " + std::to_string(lim.max_hole_edges) + "]");
      r.options["max_hole_edges"] = m;
    }
  } else {
    json_check_keys(o, "repair_options", {"alpha", "offset"});
    for (const char* k : {"alpha", "offset"})
      if (o.contains(k)) {
        const double v = json_number(o[k], std::string("repair_options.") + k, kMaxCoordinate);
        if (!(v > 0)) throw InvalidInput(std::string("repair_options.") + k, std::string(k) + " must be positive (metres)");
        r.options[k] = v;
      }
  }
  return r;
}

namespace {
mesh::WrapOptions wrap_options(const RepairRequest& request) {
  mesh::WrapOptions w;
  w.alpha = request.options.value("alpha", 0.0);
  w.offset = request.options.value("offset", 0.0);
  return w;
}
}  // namespace

std::optional<mesh::WrapEstimate> repair_estimate(const mesh::SurfaceMesh& user, const RepairRequest& request) {
  if (request.kind != "wrap") return std::nullopt;
  return mesh::estimate_wrap(user, wrap_options(request));
}

void require_repair_within(const mesh::SurfaceMesh& user, const RepairRequest& request, const Limits& limits) {
  if (request.kind == "wrap") mesh::require_wrap_within(user, wrap_options(request), wrap_budget(limits), "repair_options");
}

std::pair<mesh::RepairResult, json> run_repair_request(const mesh::SurfaceMesh& user, const RepairRequest& request,
                                                       const mesh::WrapBudget& budget, const Progress& progress) {
  mesh::RepairResult r;
  json report;
  if (request.kind == "fix") {
    mesh::FixOptions f;
    f.max_hole_edges = request.options.value("max_hole_edges", 0);
    r = mesh::fix(user, f, "repair", progress);
    json steps = json::object();
    for (const auto& [name, n] : r.steps) steps[name] = n;
    report = {{"kind", "fix"}, {"steps", steps}, {"hausdorff", {{"input_to_fixed", r.input_to_result}, {"fixed_to_input", r.result_to_input}}}};
  } else {
    r = mesh::wrap(user, wrap_options(request), budget, "repair_options", progress);
    report = {{"kind", "wrap"}, {"alpha", r.alpha}, {"offset", r.offset}, {"hausdorff", {{"input_to_wrap", r.input_to_result}, {"wrap_to_input", r.result_to_input}}}};
  }
  report["n_vertices"] = r.surface.vertices.rows();
  report["n_faces"] = r.surface.faces.rows();
  return {std::move(r), std::move(report)};
}

double unit_scale(const std::string& unit, const std::string& field) {
  static const std::map<std::string, double> units = {{"m", 1.0}, {"cm", 0.01}, {"mm", 0.001}, {"in", 0.0254}};
  const auto it = units.find(unit);
  if (it == units.end()) throw InvalidInput(field, field + " must be m, cm, mm or in");
  return it->second;
}

ReshapeRequest parse_reshape(const json& body, const Limits& limits) {
  ReshapeRequest r;
  if (body.contains("components")) {
    const json& c = body["components"];
    if (c != "all" && c != "largest") throw InvalidInput("components", "components must be \"all\" or \"largest\"");
    r.largest_piece = c == "largest";
  }
  r.simplify_faces = parse_simplify(body, limits);
  r.repair = parse_repair(body, limits);
  return r;
}

Reshaped reshape_surface(const mesh::SurfaceMesh& user, const mesh::SurfaceMesh& welded, const ReshapeRequest& request,
                         const Limits& limits, const Progress& progress) {
  Reshaped out;
  // The repair of an untouched surface sees the user's own (fix merges what it must).
  out.surface = request.largest_piece || request.simplify_faces > 0 ? welded : user;
  if (request.largest_piece) {
    long pieces = 0;
    out.surface = mesh::largest_piece(welded, &pieces);
    out.components_report = {{"pieces", pieces}, {"n_vertices", out.surface.vertices.rows()}, {"n_faces", out.surface.faces.rows()}};
  }
  // Simplify before the repair: the point is to make big scans small before anything else.
  if (request.simplify_faces > 0) {
    const std::size_t input_faces = static_cast<std::size_t>(out.surface.faces.rows());
    mesh::SimplifyResult s = mesh::simplify(out.surface, request.simplify_faces, "simplify", progress);
    out.simplify_report = {{"faces", request.simplify_faces}, {"n_input_faces", input_faces}, {"n_faces", s.surface.faces.rows()}, {"n_vertices", s.surface.vertices.rows()}, {"hausdorff", {{"input_to_simplified", s.input_to_result}}}};
    out.surface = std::move(s.surface);
  }
  if (request.repair.kind != "none") {
    require_repair_within(out.surface, request.repair, limits);
    auto [r, report] = run_repair_request(out.surface, request.repair, wrap_budget(limits), progress);
    out.surface = std::move(r.surface);
    out.repair_report = std::move(report);
  }
  return out;
}

double estimate_vertices(const mesh::SurfaceMesh& surface, double lx, double far_radius, double grading) {
  if (surface.vertices.rows() == 0 || !(lx > 0)) return 0;
  const Vec3 lo = surface.vertices.colwise().minCoeff().transpose();
  const Vec3 hi = surface.vertices.colwise().maxCoeff().transpose();
  const double r = 0.5 * (hi - lo).norm();
  const double ratio = std::max(1.0, far_radius) * r / lx;
  double edges = 0;
  if (grading > 0)
    for (const auto& [a, b] : kelvin::sharp_edges(surface, kelvin::PrepareOptions{}.feature_angle))
      edges += (surface.vertices.row(a) - surface.vertices.row(b)).norm();
  return kVertexEstimateConstant * ratio * ratio * ratio + static_cast<double>(surface.vertices.rows()) +
         kelvin::kGradedEdgeVerticesPerLength * edges / lx;
}

double smallest_lx_within(const mesh::SurfaceMesh& surface, double budget, double far_radius) {
  const double room = budget - static_cast<double>(surface.vertices.rows());
  if (surface.vertices.rows() == 0 || !(room > 0)) return std::numeric_limits<double>::infinity();
  const Vec3 lo = surface.vertices.colwise().minCoeff().transpose();
  const Vec3 hi = surface.vertices.colwise().maxCoeff().transpose();
  const double r = 0.5 * (hi - lo).norm();
  // C (f r / l_x)^3 + n <= budget  <=>  l_x >= f r (C / (budget - n))^(1/3); rounded up a little
  // so that the estimate at the answer is within the budget despite rounding.
  return std::max(1.0, far_radius) * r * std::cbrt(kVertexEstimateConstant / room) * (1 + 1e-9);
}

}  // namespace distlab::server
