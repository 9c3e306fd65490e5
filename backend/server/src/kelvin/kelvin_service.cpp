// The Service's Kelvin objects: creation (from an asset, an upload or an inline mesh; prepared
// as a job), lookup, and edits of σ and of the watched iso-levels (which reschedule the frames).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <optional>

#include "distlab/geometry/error.hpp"
#include "distlab/kelvin/progress.hpp"
#include "distlab/kelvin/sigma.hpp"
#include "distlab/mesh/checks.hpp"
#include "distlab/mesh/repair.hpp"
#include "distlab/mesh/weld.hpp"
#include "distlab/server/deadline.hpp"
#include "distlab/server/gap_json.hpp"
#include "distlab/server/json_fields.hpp"
#include "distlab/server/kelvin_json.hpp"
#include "distlab/server/request_params.hpp"
#include "kelvin_inputs.hpp"
#include "kelvin_module.hpp"

namespace distlab::server {

using json = nlohmann::json;
namespace fs = std::filesystem;

namespace {

// Repairs or wraps the object's user mesh and sets everything that depends on the result, under
// the object's lock: the surface to prepare, the σ transfer, the report, the content key.
void run_repair(KelvinObject& o, const kelvin::PrepareOptions& options, const Limits& lim, const Progress& progress) {
  Reshaped r = reshape_surface(o.surface, o.welded, o.reshape, lim, progress);
  // What prepare would refuse (a centre outside, a surface over budget), refused now by name.
  const double estimate = estimate_vertices(r.surface, options.lx, options.far_radius, sizing_for_budget(options));
  if (estimate > static_cast<double>(lim.max_vertex_estimate))
    throw InvalidInput("lx", "the repaired surface at lx " + json(options.lx).dump() + " would make about " +
                                 json(std::round(estimate)).dump() + " vertices, over this server's budget of " +
                                 std::to_string(lim.max_vertex_estimate) + "; use a larger lx");
  kelvin::check_prepare_inputs(r.surface, options);
  mesh::Transfer transfer = mesh::nearest_face_transfer(o.surface, r.surface.vertices, progress);
  std::lock_guard lock(o.mutex);
  o.repaired = std::move(r.surface);
  o.to_repaired = std::move(transfer);
  o.repair_report = std::move(r.repair_report);
  o.simplify_report = std::move(r.simplify_report);
  o.components_report = std::move(r.components_report);
  o.key = kelvin::prepare_key(o.repaired, options);
  o.field_sigma = field_sigma(o.sigma, o);
  o.state = "preparing";
}

}  // namespace

std::shared_ptr<KelvinObject> KelvinModule::require_object(const Session& session, const Request& request) {
  auto& s = const_cast<Session&>(session);
  std::lock_guard lock(s.mutex);
  auto it = kelvin_state(s).objects.find(request.params.at("id"));
  if (it == kelvin_state(s).objects.end()) throw ApiError(404, "unknown_object", "no such object in this session");
  return it->second;
}

json KelvinModule::create_object(const std::shared_ptr<Session>& session, const json& body, bool estimate_only) {
  const Limits& lim = config_.limits;
  if (!body.is_object()) throw InvalidInput("", "the request must be an object");
  for (const auto& [k, v] : body.items())
    if (k != "asset" && k != "upload" && k != "mesh" && k != "lx" && k != "lx_fraction" && k != "center" && k != "far_radius" &&
        k != "grading" && k != "sigma" && k != "levels" && k != "repair" && k != "repair_options" && k != "simplify" && k != "components" && k != "comment")
      throw InvalidInput(k, "unknown key \"" + k.substr(0, 64) + "\"");
  const int sources = static_cast<int>(body.contains("asset")) + static_cast<int>(body.contains("upload")) +
                      static_cast<int>(body.contains("mesh"));
  if (sources != 1) throw InvalidInput("", "give exactly one of asset, upload and mesh");
  if (body.contains("lx") == body.contains("lx_fraction"))
    throw InvalidInput("lx", "give lx (metres) or lx_fraction (of the bounding box's diagonal), exactly one");
  kelvin::PrepareOptions options;
  double lx_fraction = 0;
  if (body.contains("lx")) {
    options.lx = json_number(body["lx"], "lx");
    if (!(options.lx > 0)) throw InvalidInput("lx", "lx must be positive");
  } else {
    lx_fraction = json_number(body["lx_fraction"], "lx_fraction");
    if (!(lx_fraction > 0) || lx_fraction > 1) throw InvalidInput("lx_fraction", "lx_fraction must be in (0, 1]");
  }
  if (body.contains("center")) options.centre = json_vec3(body["center"], "center", kMaxCoordinate);
  if (body.contains("far_radius")) {
    options.far_radius = json_number(body["far_radius"], "far_radius", kelvin::kMaxFarRadius);
    if (!(options.far_radius >= 0.5)) throw InvalidInput("far_radius", "far_radius must be in [0.5, " + json(kelvin::kMaxFarRadius).dump() + "]");
  }
  if (body.contains("grading")) {  // absent: prepare chooses
    options.grading = json_number(body["grading"], "grading", kelvin::kMaxGrading);
    if (!(*options.grading >= 0)) throw InvalidInput("grading", "grading must be in [0, " + json(kelvin::kMaxGrading).dump() + "]");
  }
  const ReshapeRequest reshape = parse_reshape(body, lim);
  const RepairRequest& repair = reshape.repair;
  const std::size_t simplify_faces = reshape.simplify_faces;
  json source = json::object();
  if (options.centre) source["center"] = {options.centre->x(), options.centre->y(), options.centre->z()};
  if (body.contains("far_radius")) source["far_radius"] = options.far_radius;
  if (options.grading) source["grading"] = *options.grading;

  mesh::SurfaceMesh surface;
  if (body.contains("asset")) {
    if (!body["asset"].is_string() || !valid_name(body["asset"])) throw InvalidInput("asset", "asset must be an asset name");
    const std::string name = body["asset"];
    std::string path;
    for (const char* ext : kMeshExtensions) {
      const fs::path p = fs::path(config_.assets_dir) / (name + ext);
      std::error_code ec;
      if (fs::is_regular_file(p, ec)) {
        path = p.string();
        break;
      }
    }
    if (path.empty()) throw ApiError(404, "unknown_asset", "no asset named \"" + name + "\"", "asset");
    surface = mesh::load_mesh(path, "asset");
    source["asset"] = name;
  } else if (body.contains("upload")) {
    if (!body["upload"].is_string()) throw InvalidInput("upload", "upload must be an upload id");
    std::lock_guard lock(session->mutex);
    auto it = uploads(*session).uploads.find(body["upload"].get<std::string>());
    if (it == uploads(*session).uploads.end()) throw ApiError(404, "unknown_upload", "no such upload in this session", "upload");
    surface = it->second->surface;
    source["upload"] = it->first;
  } else {
    surface = inline_mesh(body["mesh"], lim.max_upload_triangles);
    source["mesh"] = "inline";
  }
  if (static_cast<std::size_t>(surface.faces.rows()) > lim.max_upload_triangles)
    throw ApiError(413, "too_many_triangles", "at most " + std::to_string(lim.max_upload_triangles) + " triangles", "mesh");
  // A scan is prepared only once simplified or wrapped to what a preparation takes.
  const auto faces = static_cast<std::size_t>(surface.faces.rows());
  if (faces > lim.max_object_triangles && simplify_faces == 0 && repair.kind != "wrap")
    throw ApiError(422, "too_many_triangles",
                   "the mesh has " + std::to_string(faces) + " triangles and a preparation takes at most " + std::to_string(lim.max_object_triangles) +
                       ": add \"simplify\": {\"faces\": N} with N ≤ " + std::to_string(lim.max_object_triangles) + ", or \"repair\": \"wrap\"",
                   "simplify.faces");
  // A wrap over its budget is refused here, before a job (and its memory) exists.
  try {
    require_repair_within(surface, repair, lim);
  } catch (const InvalidInput& e) {
    throw ApiError(422, "over_budget", e.field() + ": " + e.what(), e.field());
  }
  // The user's mesh keeps its vertex order for the API; the field is prepared on the weld. The
  // budget counts every parameter that grows the mesh (lx and far_radius); the field named is
  // far_radius when the request would fit with the default far radius.
  mesh::Welded welded = mesh::weld(surface);
  const std::string lx_field = body.contains("lx") ? "lx" : "lx_fraction";
  const double diagonal = (welded.surface.vertices.colwise().maxCoeff() - welded.surface.vertices.colwise().minCoeff()).norm();
  if (body.contains("lx_fraction")) {
    options.lx = lx_fraction * diagonal;
    source["lx_fraction"] = lx_fraction;
  }
  source["lx"] = options.lx;
  if (options.lx < lim.min_lx)
    throw ApiError(422, "over_budget", lx_field + " gives lx " + json(options.lx).dump() + " m, but lx must be at least " + json(lim.min_lx).dump() + " m on this server", lx_field);
  const auto budget = static_cast<double>(lim.max_vertex_estimate);
  // A simplified surface has about faces / 2 vertices instead of the weld's.
  const double simplified = simplify_faces > 0 ? static_cast<double>(std::min<Eigen::Index>(welded.surface.vertices.rows(), static_cast<Eigen::Index>(simplify_faces / 2 + 2))) - static_cast<double>(welded.surface.vertices.rows()) : 0.0;
  const double estimate = estimate_vertices(welded.surface, options.lx, options.far_radius, sizing_for_budget(options)) + simplified;
  if (estimate_only) {
    // The vertices are predicted on the surface the preparation will prepare: the weld, its
    // largest piece, or for a simplification the weld it simplifies (the same shape; a mesh
    // over max_object_triangles is not predicted: that costs seconds). A fix or wrap makes the
    // surface in the job, which predicts then (the object's "estimate").
    std::optional<mesh::SurfaceMesh> piece;
    const mesh::SurfaceMesh* predicted = nullptr;
    std::string note;
    if (repair.kind != "none") {
      note = "the " + repair.kind + " makes the surface: its field vertices are predicted once it exists (the object's estimate)";
    } else if (faces > lim.max_object_triangles) {
      note = "the mesh has more than max_object_triangles triangles: its field vertices are predicted once simplified (the object's estimate)";
    } else {
      if (reshape.largest_piece) piece = mesh::largest_piece(welded.surface);
      predicted = piece ? &*piece : &welded.surface;
      if (simplify_faces > 0) note = "predicted on the mesh before simplify (the same shape)";
    }
    json out = estimate_json(welded.surface, options, estimate, predicted, reshape.any());
    if (!note.empty() && out["prediction_note"].is_null()) out["prediction_note"] = note;
    if (json wrap = repair_estimate_json(surface, repair); !wrap.is_null()) out["repair_estimate"] = std::move(wrap);
    return out;
  }
  if (estimate > budget) {
    const bool far = estimate_vertices(welded.surface, options.lx, 1.0, sizing_for_budget(options)) <= budget;
    const double fits = std::max(lim.min_lx, smallest_lx_within(welded.surface, budget, options.far_radius));
    const std::string advice =
        far                ? "; use a smaller far_radius"
        : fits <= diagonal ? "; lx " + json(fits).dump() + " m or larger fits (lx_fraction " + json(fits / diagonal).dump() + ")"
                           : "; no lx up to the bounding box's diagonal (" + json(diagonal).dump() + " m) fits: the surface has too many vertices";
    throw ApiError(422, "over_budget",
                   std::string(far ? "far_radius " + json(options.far_radius).dump() : "lx " + json(options.lx).dump()) +
                       " would make about " + json(std::round(estimate)).dump() + " vertices, over this server's budget of " +
                       std::to_string(lim.max_vertex_estimate) + advice,
                   far ? "far_radius" : lx_field);
  }
  source["vertex_estimate"] = std::llround(estimate);
  // The job's meshing cap is the same budget, and whatever prepare would refuse (a surface that
  // is not closed, a centre outside or too near the surface) is refused now, before a job starts.
  options.max_vertices = std::max<std::size_t>(100, lim.max_vertex_estimate);
  if (repair.kind == "none" && reshape.largest_piece) {
    // The piece prepared is checked, in its own numbering (the others are dropped).
    const mesh::SurfaceMesh piece = mesh::largest_piece(welded.surface);
    if (const std::string defect = mesh::topology_defect(piece); !defect.empty())
      throw InvalidInput("components", "the largest piece is not a closed manifold surface: " + defect +
                                           " (numbers of the piece's own vertices and faces); \"repair\": \"fix\" or \"wrap\" can make it one");
    kelvin::check_prepare_inputs(piece, options);
  } else if (repair.kind == "none") {
    // Topology first, named in the file's numbering: a welded vertex is its first file vertex.
    std::vector<int> names(static_cast<std::size_t>(welded.surface.vertices.rows()), -1);
    for (std::size_t i = 0; i < welded.to_welded.size(); ++i)
      if (const int w = welded.to_welded[i]; w >= 0 && names[static_cast<std::size_t>(w)] < 0) names[static_cast<std::size_t>(w)] = static_cast<int>(i);
    if (const std::string defect = mesh::topology_defect(welded.surface, names); !defect.empty())
      throw InvalidInput(body.contains("upload") ? "upload" : body.contains("asset") ? "asset"
                                                                                     : "mesh",
                         "the mesh is not a closed manifold surface: " + defect +
                             " (vertex and face numbers are the file's); \"repair\": \"fix\" or \"wrap\" can make it one");
    // A simplified surface is checked in the job (run_repair), as a repaired one: on a 2M-face
    // scan this check takes 3.6 s, too long for the request.
    if (simplify_faces == 0) kelvin::check_prepare_inputs(welded.surface, options);
  }
  source["repair"] = repair.kind;

  auto object = std::make_shared<KelvinObject>();
  object->held = held_triangles_.reserve(session->address, faces, body.contains("upload") ? "upload" : body.contains("asset") ? "asset"
                                                                                                                              : "mesh");
  object->id = random_id();
  object->key = kelvin::prepare_key(welded.surface, options);
  object->source = source;
  object->surface = std::move(surface);
  object->welded = std::move(welded.surface);
  object->to_welded = std::move(welded.to_welded);
  object->reshape = reshape;
  if (object->reshaped()) object->state = "repairing";
  object->surface_digest = kelvin::surface_digest(object->surface);
  object->sigma_key = sigma_key(*object, json::object());
  if (body.contains("sigma")) {
    object->sigma = parse_sigma(body["sigma"]);
    object->field_sigma = kelvin::field_sigma(object->sigma, object->surface.vertices, object->to_welded, object->welded.vertices.rows());
    object->sigma_json = body["sigma"];
    object->sigma_key = sigma_key(*object, body["sigma"]);
  }
  if (body.contains("levels")) object->levels = parse_levels(body["levels"], "levels", lim.max_levels);
  {
    std::lock_guard lock(session->mutex);
    if (kelvin_state(*session).objects.size() >= lim.max_objects_per_session)
      throw ApiError(429, "too_many_objects",
                     "this session already has " + std::to_string(lim.max_objects_per_session) + " objects; delete one first");
    kelvin_state(*session).objects.emplace(object->id, object);
  }
  std::weak_ptr<Session> weak_session = session;
  std::shared_ptr<Job> job;
  try {
    job = jobs_.submit(session->id, "kelvin_prepare", {{"object", object->id}}, [this, object, options, weak_session](Job& j) {
      auto announce = [&] {
        if (auto s = weak_session.lock()) s->broadcast(json{{"type", "object"}, {"object", object->status_json()}}.dump(), false);
      };
      try {
        // The job's fraction: a repair's own while it repairs, then the preparation's overall
        // fraction, its stages weighed by their predicted seconds (set below, once predicted).
        std::optional<kelvin::StageProgress> stages;
        kelvin::Progress progress;
        progress.report = [&j, &stages](const std::string& stage, double fraction) {
          j.report(stage, stages ? stages->report(stage, fraction) : fraction);
        };
        progress.cancel = &j.cancel;
        if (object->reshaped()) {
          // The long part of a repair request (the user's mesh is already imported and checked):
          // fix and wrap poll the job's token and report stage "repair".
          run_repair(*object, options, config_.limits, progress);
        }
        // What this preparation will make, predicted on the surface it prepares: the estimate's
        // when this request was estimated (POST /api/kelvin/estimate), else predicted now where
        // the estimate could not (a repaired or simplified surface); a refusal is left to the
        // preparation to give.
        const mesh::SurfaceMesh& to_prepare = object->reshaped() ? object->repaired : object->welded;
        json predicted = nullptr;
        std::optional<kelvin::PreparePrediction> p;
        try {
          p = cached_prediction(to_prepare, options);
          if (!p && object->reshaped()) p = predict(to_prepare, options, &j.cancel);
          if (p) predicted = prediction_json(p, prepare_rate_);
        } catch (const kelvin::Cancelled&) {
          throw;
        } catch (const std::exception&) {
          // No prediction (the preparation gives any refusal itself).
        }
        {
          std::lock_guard lock(object->mutex);
          object->estimate = std::move(predicted);
        }
        // Unpredicted (a request not estimated first), the shares are the rates of the sizing
        // asked for (or of both sizings) at the size of the preparations measured.
        stages.emplace(stage_shares(p, prepare_rate_, options.grading));
        if (object->reshaped()) announce();  // the repair's report and the prediction on its surface
        j.report("load", 0.0);
        bool from_memory = false;
        auto prepared = registry_.acquire(to_prepare, options, progress, &from_memory);
        stages->finish();
        const bool computed = !from_memory && !prepared->cache_hit;
        {
          std::lock_guard lock(object->mutex);
          object->prepared = prepared;
          object->shared = from_memory;
          if (computed) object->stage_seconds = stages->seconds();
          object->state = "ready";
        }
        j.report("ready", 1.0);
        announce();
        if (auto s = weak_session.lock()) schedule_frames(s, object);
        // This server's seconds per vertex learn from what it computed (not from a cache or
        // another object's preparation).
        if (computed) prepare_rate_.record(prepared->field.stats().grading, stages->seconds(), static_cast<double>(prepared->field.stats().n_verts));
        const json status = object->status_json();
        return json{{"object", object->id}, {"stats", status.value("stats", json::object())}};
      } catch (const kelvin::Cancelled&) {
        {
          std::lock_guard lock(object->mutex);
          object->state = "cancelled";
        }
        announce();
        throw;
      } catch (const std::exception&) {
        {  // the job's own mapping logs an internal error
          std::lock_guard lock(object->mutex);
          object->state = j.cancelled() ? "cancelled" : "failed";
          object->error = error_answer(std::current_exception(), "job_failed", "internal error (logged on the server)", nullptr).body();
        }
        announce();
        throw;
      }
    });
  } catch (...) {
    std::lock_guard lock(session->mutex);
    kelvin_state(*session).objects.erase(object->id);
    throw;
  }
  {
    std::lock_guard lock(object->mutex);
    object->job = job->id;
  }
  return {{"object", object->status_json()}, {"job", job->to_json()}};
}

// What POST /api/kelvin/objects would do with these inputs, without doing it: the server's vertex
// count against its budget, the smallest l_x within the budget, the refusal if any, and the
// prediction: the field vertices the mesher's sizing prediction gives for the sizing the
// preparation will choose, and the seconds they take at this server's measured rate.
json KelvinModule::estimate_json(const mesh::SurfaceMesh& welded, kelvin::PrepareOptions options, double estimate,
                                 const mesh::SurfaceMesh* predicted, bool reshaped) {
  const Limits& lim = config_.limits;
  const auto budget = static_cast<double>(lim.max_vertex_estimate);
  const Vec3 lo = welded.vertices.colwise().minCoeff().transpose(), hi = welded.vertices.colwise().maxCoeff().transpose();
  json out = {{"vertex_estimate", std::llround(estimate)},
              {"max_vertex_estimate", lim.max_vertex_estimate},
              {"min_lx", lim.min_lx},
              {"diagonal", (hi - lo).norm()},
              {"lx_for_budget", std::max(lim.min_lx, smallest_lx_within(welded, budget, options.far_radius))},
              {"problem", nullptr},
              {"prediction_note", nullptr}};
  try {
    if (estimate > budget)
      throw InvalidInput("lx", "about " + std::to_string(std::llround(estimate)) + " vertices, over this server's budget of " +
                                   std::to_string(lim.max_vertex_estimate) + "; use a larger lx");
    options.max_vertices = std::max<std::size_t>(100, lim.max_vertex_estimate);
    kelvin::check_prepare_inputs(welded, options);
  } catch (const InvalidInput& e) {
    // A reshaping request's surface checks are of the surface it makes, in the job: the user's
    // open mesh is no problem here, only the budget (and l_x) can be judged before.
    if (!reshaped || e.field() == "lx") out["problem"] = {{"field", e.field()}, {"message", e.what()}};
  }
  std::optional<kelvin::PreparePrediction> prediction;
  if (predicted != nullptr && out["problem"].is_null()) {
    const CancelAfter deadline(lim.max_request_seconds);  // the trial meshing stops there
    try {
      prediction = predict(*predicted, options, deadline.flag());
    } catch (const kelvin::Cancelled&) {
      out["prediction_note"] = "not predicted within this server's max_request_seconds (" + json(lim.max_request_seconds).dump() +
                               " s): the preparation's meshing will take at least as long";
    } catch (const InvalidInput& e) {
      // What the preparation would refuse (a thin sheet, l_x beyond the object's radius about
      // its centre) is known now.
      if (!reshaped) out["problem"] = {{"field", e.field()}, {"message", e.what()}};
      out["prediction_note"] = std::string("not predicted: ") + e.what();
    } catch (const std::exception&) {
      // Whatever else the mesher refuses is the preparation's to report, as it was.
      out["prediction_note"] = "not predicted: the mesher failed on this surface (the preparation will say how)";
    }
  }
  out.update(prediction_json(prediction, prepare_rate_, options.grading));
  return out;
}

kelvin::PreparePrediction KelvinModule::predict(const mesh::SurfaceMesh& surface, kelvin::PrepareOptions options,
                                                const std::atomic<bool>* cancel) {
  if (auto hit = cached_prediction(surface, options)) return *hit;
  options.max_vertices = std::max<std::size_t>(100, config_.limits.max_vertex_estimate);
  kelvin::Progress progress;
  progress.cancel = cancel;
  kelvin::PreparePrediction p = kelvin::predict_preparation(surface, options, progress);
  predictions_.put(kelvin::prepare_key(surface, options), p);
  return p;
}

std::optional<kelvin::PreparePrediction> KelvinModule::cached_prediction(const mesh::SurfaceMesh& surface, const kelvin::PrepareOptions& options) {
  return predictions_.find(kelvin::prepare_key(surface, options));
}

void KelvinModule::set_sigma(const std::shared_ptr<Session>& session, const std::shared_ptr<KelvinObject>& object,
                             const json& sigma_json, WsSink* origin, const json& request) {
  kelvin::SigmaSpec spec = parse_sigma(sigma_json);
  // surface, welded and to_welded are set at creation and never change: no lock needed.
  kelvin::SigmaSpec solved = kelvin::field_sigma(spec, object->surface.vertices, object->to_welded, object->welded.vertices.rows());
  std::uint64_t version;
  {
    std::lock_guard lock(object->mutex);
    // A repaired object carries σ to its repaired surface once that exists (the job does it then).
    if (object->reshaped() && object->repaired.faces.rows() > 0) solved = field_sigma(spec, *object);
    object->sigma = std::move(spec);
    object->field_sigma = std::move(solved);
    object->sigma_json = sigma_json;
    object->sigma_key = sigma_key(*object, sigma_json);
    version = ++object->sigma_version;
    object->sigma_at = std::chrono::steady_clock::now();
    ++object->frames_version;
  }
  json ack{{"type", "sigma"}, {"object", object->id}, {"sigma_version", version}};
  // The other sockets of the session learn of the new version; the sender's acknowledgement
  // echoes its request id (ids are the sender's own: another tab may use the same ones).
  session->broadcast(ack.dump(), false, origin);
  if (origin != nullptr) {
    if (!request.is_null()) ack["request"] = request;
    origin->send(ack.dump(), false);
  }
  schedule_frames(session, object);
}

void KelvinModule::set_levels(const std::shared_ptr<Session>& session, const std::shared_ptr<KelvinObject>& object,
                              const json& levels) {
  std::vector<double> parsed = parse_levels(levels, "levels", config_.limits.max_levels);
  {
    std::lock_guard lock(object->mutex);
    object->levels = std::move(parsed);
    ++object->frames_version;
  }
  schedule_frames(session, object);
}

}  // namespace distlab::server
