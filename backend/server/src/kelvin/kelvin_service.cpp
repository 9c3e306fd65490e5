// The Kelvin objects' creation (from an asset, an upload or an inline mesh) and its estimate, and
// the preparation job (repair, prediction, the prepared field).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <optional>
#include <thread>

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

// A preparation not estimated first predicts its field itself (a trial meshing, 0.2-0.3 s) when
// the closed form counts at least this many vertices and the field is not in memory: its stages'
// shares then follow its size (meshing, decomposition, no response that will not be built) rather
// than the typical shares at the size of the preparations measured. The closed form overcounts
// 4-30× (the budget's bound): from here the fields have ~50k vertices or more and take 4 s or
// more (the cube at l_x 0.0385: 228k closed form, 56k made in 4.5 s), so a few percent.
constexpr double kPredictedInTheJob = 2e5;

// Repairs or wraps the object's user mesh and sets everything that depends on the result, under
// the object's lock: the surface to prepare, the σ transfer, the report, the content key.
void run_repair(KelvinObject& o, const kelvin::PrepareOptions& options, const Limits& lim, const VertexPredictor& predict,
                const Progress& progress) {
  Reshaped r = reshape_surface(o.surface, o.welded, o.reshape, lim, progress);
  // What prepare would refuse (a centre outside, a surface over budget), refused now by name.
  const double closed_form = estimate_vertices(r.surface, options.lx, options.far_radius, sizing_for_budget(options));
  try {
    require_within_budget(count_vertices(closed_form, &r.surface, options, lim, predict), r.surface, options, lim, "lx", "far_radius");
  } catch (const ApiError& e) {
    throw InvalidInput(e.field(), std::string("the repaired surface: ") + e.what());
  }
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
  o.stage = PrepareStage::preparing;
}

}  // namespace

KelvinModule::ObjectPlan KelvinModule::plan_object(const CreateObjectRequest& in, Session& session) {
  const Limits& lim = config_.limits;
  ObjectPlan plan;
  plan.options = in.options;
  plan.options.mesh_worker = config_.mesh_worker;
  if (!in.asset.empty()) {
    std::string path;
    for (const char* ext : kMeshExtensions) {
      const fs::path p = fs::path(config_.assets_dir) / (in.asset + ext);
      std::error_code ec;
      if (fs::is_regular_file(p, ec)) {
        path = p.string();
        break;
      }
    }
    if (path.empty()) throw ApiError(404, "unknown_asset", "no asset named \"" + in.asset + "\"", "asset");
    plan.surface = mesh::load_mesh(path, "asset");
  } else if (!in.upload.empty()) {
    std::lock_guard lock(session.mutex);
    auto it = uploads(session).uploads.find(in.upload);
    if (it == uploads(session).uploads.end()) throw ApiError(404, "unknown_upload", "no such upload in this session", "upload");
    plan.surface = it->second->surface;
  } else {
    plan.surface = *in.mesh;
  }
  const auto faces = static_cast<std::size_t>(plan.surface.faces.rows());
  if (faces > lim.max_upload_triangles)
    throw ApiError(413, "too_many_triangles", "at most " + std::to_string(lim.max_upload_triangles) + " triangles", "mesh");
  // A scan is prepared only once simplified or wrapped to what a preparation takes.
  if (faces > lim.max_object_triangles && in.reshape.simplify_faces == 0 && in.reshape.repair.kind != "wrap")
    throw ApiError(422, "too_many_triangles",
                   "the mesh has " + std::to_string(faces) + " triangles and a preparation takes at most " + std::to_string(lim.max_object_triangles) +
                       ": add \"simplify\": {\"faces\": N} with N ≤ " + std::to_string(lim.max_object_triangles) + ", or \"repair\": \"wrap\"",
                   "simplify.faces");
  // A wrap over its budget is refused here, before a job (and its memory) exists.
  try {
    require_repair_within(plan.surface, in.reshape.repair, lim);
  } catch (const InvalidInput& e) {
    throw ApiError(422, "over_budget", e.field() + ": " + e.what(), e.field());
  }
  // The user's mesh keeps its vertex order for the API; the field is prepared on the weld. The
  // budget counts every parameter that grows the mesh (lx and far_radius).
  plan.welded = mesh::weld(plan.surface);
  const mesh::SurfaceMesh& welded = plan.welded.surface;
  plan.diagonal = (welded.vertices.colwise().maxCoeff() - welded.vertices.colwise().minCoeff()).norm();
  if (in.lx_fraction) plan.options.lx = *in.lx_fraction * plan.diagonal;
  if (plan.options.lx < lim.min_lx)
    throw ApiError(422, "over_budget", std::string(in.lx_field()) + " gives lx " + number_text(plan.options.lx) + " m, but lx must be at least " + number_text(lim.min_lx) + " m on this server", in.lx_field());
  // A simplified surface has about faces / 2 vertices instead of the weld's.
  const std::size_t simplify_faces = in.reshape.simplify_faces;
  const double simplified = simplify_faces > 0 ? static_cast<double>(std::min<Eigen::Index>(welded.vertices.rows(), static_cast<Eigen::Index>(simplify_faces / 2 + 2))) - static_cast<double>(welded.vertices.rows()) : 0.0;
  plan.estimate = estimate_vertices(welded, plan.options.lx, plan.options.far_radius, sizing_for_budget(plan.options)) + simplified;
  if (in.reshape.repair.kind != "none")
    plan.unpredicted = "the " + in.reshape.repair.kind + " makes the surface: its field vertices are predicted once it exists (the object's estimate)";
  else if (faces > lim.max_object_triangles)
    plan.unpredicted = "the mesh has more than max_object_triangles triangles: its field vertices are predicted once simplified (the object's estimate)";
  else if (in.reshape.largest_piece)
    plan.piece = mesh::largest_piece(welded);
  return plan;
}

VertexCount KelvinModule::count_vertices(const ObjectPlan& plan) {
  const double seconds = config_.limits.max_request_seconds;
  return server::count_vertices(plan.estimate, plan.to_predict(), plan.options, config_.limits,
                                [this, seconds](const mesh::SurfaceMesh& surface, const kelvin::PrepareOptions& options) {
                                  const CancelAfter deadline(seconds);  // the trial meshing stops there
                                  try {
                                    return predict(surface, options, deadline.flag()).vertices;
                                  } catch (const kelvin::Cancelled&) {
                                    throw std::runtime_error("not predicted within this server's max_request_seconds (" + number_text(seconds) + " s)");
                                  }
                                });
}

ObjectEstimate KelvinModule::estimate(const CreateObjectRequest& in, const Caller& caller) {
  auto session = require_session(caller);
  const ObjectPlan plan = plan_object(in, *session);
  ObjectEstimate out = estimate_of(in, plan);
  if (in.reshape.simplify_faces > 0 && !out.prediction_note && out.prediction) out.prediction_note = "predicted on the mesh before simplify (the same shape)";
  out.repair = repair_estimate(plan.surface, in.reshape.repair);
  return out;
}

void KelvinModule::check_preparable(const CreateObjectRequest& in, ObjectPlan& plan) {
  const Limits& lim = config_.limits;
  kelvin::PrepareOptions& options = plan.options;
  const mesh::SurfaceMesh& welded = plan.welded.surface;
  require_within_budget(count_vertices(plan), welded, options, lim, in.lx_field(), "far_radius");
  // The job's meshing cap is the same budget, and whatever prepare would refuse (a surface that
  // is not closed, a centre outside or too near the surface) is refused now, before a job starts.
  options.max_vertices = std::max<std::size_t>(100, lim.max_vertex_estimate);
  // Several meshing threads only in a child process (kelvin/isolated_mesher.hpp): CGAL 5.5's
  // parallel refinement can crash its process, and this one holds every client's state.
  const int cores = static_cast<int>(std::max(1U, std::thread::hardware_concurrency()));
  if (config_.mesh_worker.empty() && options.mesh_threads > 1)
    throw InvalidInput("mesh_threads", "mesh_threads must be 0 or 1 here: this server meshes in its own process, on one thread");
  if (options.mesh_threads > cores)
    throw InvalidInput("mesh_threads", "mesh_threads must be in [0, " + std::to_string(cores) + "] here (this machine's cores)");
  if (in.reshape.repair.kind != "none") return;
  if (plan.piece) {
    // The piece prepared is checked, in its own numbering (the others are dropped).
    const mesh::SurfaceMesh& piece = *plan.piece;
    if (const std::string defect = mesh::topology_defect(piece); !defect.empty())
      throw InvalidInput("components", "the largest piece is not a closed manifold surface: " + defect +
                                           " (numbers of the piece's own vertices and faces); " + mesh::repair_advice(piece));
    kelvin::check_prepare_inputs(piece, options);
    return;
  }
  // Topology first, named in the file's numbering: a welded vertex is its first file vertex.
  std::vector<int> names(static_cast<std::size_t>(welded.vertices.rows()), -1);
  for (std::size_t i = 0; i < plan.welded.to_welded.size(); ++i)
    if (const int w = plan.welded.to_welded[i]; w >= 0 && names[static_cast<std::size_t>(w)] < 0) names[static_cast<std::size_t>(w)] = static_cast<int>(i);
  if (const std::string defect = mesh::topology_defect(welded, names); !defect.empty())
    throw InvalidInput(in.source_field(), "the mesh is not a closed manifold surface: " + defect +
                                              " (vertex and face numbers are the file's); " + mesh::repair_advice(welded));
  // A simplified surface is checked in the job (run_repair), as a repaired one: on a 2M-face
  // scan this check takes 3.6 s, too long for the request.
  if (in.reshape.simplify_faces == 0) kelvin::check_prepare_inputs(welded, options);
}

std::shared_ptr<KelvinObject> KelvinModule::make_object(const CreateObjectRequest& in, ObjectPlan& plan, const Session& session) {
  auto object = std::make_shared<KelvinObject>();
  object->held = held_triangles_.reserve(session.address, static_cast<std::size_t>(plan.surface.faces.rows()), in.source_field());
  object->id = random_id();
  object->key = kelvin::prepare_key(plan.welded.surface, plan.options);
  object->source = {in.asset, in.upload, plan.options.centre, in.far_radius, plan.options.grading, in.lx_fraction, plan.options.lx,
                    std::llround(plan.estimate), in.reshape.repair.kind};
  object->surface = std::move(plan.surface);
  object->welded = std::move(plan.welded.surface);
  object->to_welded = std::move(plan.welded.to_welded);
  object->reshape = in.reshape;
  if (object->reshaped()) object->stage = PrepareStage::repairing;
  object->surface_digest = kelvin::surface_digest(object->surface);
  object->sigma_key = sigma_key(*object, object->sigma_given);
  if (in.sigma) {
    object->sigma = in.sigma->spec;
    object->field_sigma = kelvin::field_sigma(object->sigma, object->surface.vertices, object->to_welded, object->welded.vertices.rows());
    object->sigma_given = in.sigma->given;
    object->sigma_key = sigma_key(*object, in.sigma->given);
  }
  if (in.levels) object->levels = *in.levels;
  return object;
}

CreatedObject KelvinModule::create_object(const CreateObjectRequest& in, const Caller& caller) {
  auto session = require_session(caller);
  ObjectPlan plan = plan_object(in, *session);
  check_preparable(in, plan);
  const kelvin::PrepareOptions options = plan.options;
  auto object = make_object(in, plan, *session);
  {
    std::lock_guard lock(session->mutex);
    const std::size_t most = config_.limits.max_objects_per_session;
    if (kelvin_state(*session).objects.size() >= most)
      throw ApiError(429, "too_many_objects", "this session already has " + std::to_string(most) + " objects; delete one first");
    kelvin_state(*session).objects.emplace(object->id, object);
  }
  std::shared_ptr<Job> job;
  try {
    job = start_preparation(session, object, options);
  } catch (...) {
    std::lock_guard lock(session->mutex);
    kelvin_state(*session).objects.erase(object->id);
    throw;
  }
  {
    std::lock_guard lock(object->mutex);
    object->job = job->id;
  }
  return {object, job};
}

namespace {
// The object's status to its session's sockets.
void announce_object(const std::weak_ptr<Session>& weak_session, KelvinObject& object) {
  if (auto s = weak_session.lock()) s->broadcast(json{{"type", "object"}, {"object", object.status_json()}}.dump(), false);
}
}  // namespace

std::shared_ptr<Job> KelvinModule::start_preparation(const std::shared_ptr<Session>& session, const std::shared_ptr<KelvinObject>& object,
                                                     const kelvin::PrepareOptions& options) {
  std::weak_ptr<Session> weak_session = session;
  // Cancelled while queued: the preparation never starts, and the object ends cancelled with it.
  auto skipped = [object, weak_session] {
    {
      std::lock_guard lock(object->mutex);
      object->state = Lifecycle::cancelled;
    }
    announce_object(weak_session, *object);
  };
  return jobs_.submit(
      session->id, "kelvin_prepare", {{"object", object->id}},
      [this, object, options, weak_session](Job& j) { return prepare_object(j, object, options, weak_session); }, skipped);
}

json KelvinModule::prepare_object(Job& j, const std::shared_ptr<KelvinObject>& object, const kelvin::PrepareOptions& options,
                                  const std::weak_ptr<Session>& weak_session) {
  auto announce = [&] { announce_object(weak_session, *object); };
  auto end = [&](Lifecycle state, bool with_error) {
    {
      std::lock_guard lock(object->mutex);
      object->state = state;
      if (with_error)  // the job's own mapping logs an internal error
        object->error = error_answer(std::current_exception(), "job_failed", "internal error (logged on the server)", nullptr).body();
    }
    announce();
  };
  {
    std::lock_guard lock(object->mutex);
    object->state = Lifecycle::running;
  }
  try {
    prepare_field(j, *object, options, announce);
    {
      std::lock_guard lock(object->mutex);
      object->state = Lifecycle::succeeded;
    }
    j.report("ready", 1.0);
    announce();
    if (auto s = weak_session.lock()) schedule_frames(s, object);
    const json status = object->status_json();
    return json{{"object", object->id}, {"stats", status.value("stats", json::object())}};
  } catch (const kelvin::Cancelled&) {
    end(Lifecycle::cancelled, false);
    throw;
  } catch (const std::exception&) {
    end(j.cancelled() ? Lifecycle::cancelled : Lifecycle::failed, true);
    throw;
  }
}

void KelvinModule::prepare_field(Job& j, KelvinObject& object, const kelvin::PrepareOptions& options,
                                 const std::function<void()>& announce) {
  // The job's fraction: a repair's own while it repairs, then the preparation's overall fraction,
  // its stages weighed by their predicted seconds (set below, once predicted).
  std::optional<kelvin::StageProgress> stages;
  kelvin::Progress progress;
  progress.report = [&j, &stages](const std::string& stage, double fraction) {
    j.report(stage, stages ? stages->report(stage, fraction) : fraction);
  };
  progress.cancel = &j.cancel;
  // The long part of a repair request (the user's mesh is already imported and checked): fix
  // and wrap poll the job's token and report stage "repair".
  if (object.reshaped())
    run_repair(
        object, options, config_.limits, [this, &j](const mesh::SurfaceMesh& s, const kelvin::PrepareOptions& o) { return predict(s, o, &j.cancel).vertices; },
        progress);
  // What this preparation will make, predicted on the surface it prepares: the estimate's when
  // this request was estimated (POST /api/kelvin/estimate), else predicted now where the estimate
  // could not (a repaired or simplified surface) or where the stages' shares need it (a large
  // field not in memory, kPredictedInTheJob); a refusal is left to the preparation to give.
  const mesh::SurfaceMesh& to_prepare = object.reshaped() ? object.repaired : object.welded;
  json predicted = nullptr;
  std::optional<kelvin::PreparePrediction> p;
  try {
    p = cached_prediction(to_prepare, options);
    // object.key: the content's key, set before this job or by its repair above (not hashed again,
    // here or in acquire).
    const auto large = [&] { return static_cast<double>(object.source.vertex_estimate) >= kPredictedInTheJob && !registry_.in_memory(object.key, to_prepare, options); };
    if (!p && (object.reshaped() || large())) p = predict(to_prepare, options, &j.cancel);
    if (p) predicted = prediction_json(p, prepare_rate_, std::nullopt, response_megabytes_limit());
  } catch (const kelvin::Cancelled&) {
    throw;
  } catch (const std::exception&) {
    // No prediction (the preparation gives any refusal itself).
  }
  {
    std::lock_guard lock(object.mutex);
    object.estimate = std::move(predicted);
  }
  // Unpredicted (a small request not estimated first), the shares are the rates of the sizing
  // asked for (or of both sizings) at the size of the preparations measured.
  stages.emplace(stage_shares(p, prepare_rate_, options.grading, response_megabytes_limit()));
  if (object.reshaped()) announce();  // the repair's report and the prediction on its surface
  j.report("load", 0.0);
  bool from_memory = false;
  auto prepared = registry_.acquire(object.key, to_prepare, options, progress, &from_memory);
  stages->finish();
  const bool computed = !from_memory && !prepared->cache_hit;
  {
    std::lock_guard lock(object.mutex);
    object.prepared = prepared;
    object.shared = from_memory;
    if (computed) object.stage_seconds = stages->seconds();
  }
  // This server's seconds per vertex learn from what it computed (not from a cache or another
  // object's preparation).
  if (computed) prepare_rate_.record(prepared->field.stats().grading, prepared->field.stats().mesh_threads, stages->seconds(), static_cast<double>(prepared->field.stats().n_verts));
}

// What POST /api/kelvin/objects would do with these inputs, without doing it: the closed form and
// the count the vertex budget holds (kelvin_json.hpp, count_vertices), the smallest l_x the closed form fits, the
// refusal if any, and the prediction: the field vertices the mesher's sizing prediction gives for
// the sizing the preparation will choose, and the seconds they take at this server's measured rate.
ObjectEstimate KelvinModule::estimate_of(const CreateObjectRequest& in, const ObjectPlan& plan) {
  const Limits& lim = config_.limits;
  const mesh::SurfaceMesh& welded = plan.welded.surface;
  kelvin::PrepareOptions options = plan.options;
  const bool reshaped = in.reshape.any();
  ObjectEstimate out;
  out.vertex_estimate = std::llround(plan.estimate);
  out.budget_vertices = out.vertex_estimate;
  out.max_vertex_estimate = lim.max_vertex_estimate;
  out.min_lx = lim.min_lx;
  out.diagonal = plan.diagonal;
  out.lx_for_budget = std::max(lim.min_lx, smallest_lx_within(welded, static_cast<double>(lim.max_vertex_estimate), options.far_radius));
  if (!plan.unpredicted.empty()) out.prediction_note = plan.unpredicted;
  try {
    const VertexCount count = count_vertices(plan);
    out.budget_vertices = std::llround(count.count());
    require_within_budget(count, welded, options, lim, in.lx_field(), "far_radius");
    options.max_vertices = std::max<std::size_t>(100, lim.max_vertex_estimate);
    kelvin::check_prepare_inputs(welded, options);
  } catch (const ApiError& e) {
    out.problem = {e.field(), e.what()};
  } catch (const InvalidInput& e) {
    // A reshaping request's surface checks are of the surface it makes, in the job: the user's
    // open mesh is no problem here, only the budget (and l_x) can be judged before.
    if (!reshaped || e.field() == "lx") out.problem = {e.field(), e.what()};
  }
  if (const mesh::SurfaceMesh* predicted = plan.to_predict(); predicted != nullptr && !out.problem) {
    const CancelAfter deadline(lim.max_request_seconds);  // the trial meshing stops there
    try {
      out.prediction = predict(*predicted, options, deadline.flag());
    } catch (const kelvin::Cancelled&) {
      out.prediction_note = "not predicted within this server's max_request_seconds (" + number_text(lim.max_request_seconds) +
                            " s): the preparation's meshing will take at least as long";
    } catch (const InvalidInput& e) {
      // What the preparation would refuse (a thin sheet, l_x beyond the object's radius about
      // its centre) is known now.
      if (!reshaped) out.problem = {e.field(), e.what()};
      out.prediction_note = std::string("not predicted: ") + e.what();
    } catch (const std::exception&) {
      // Whatever else the mesher refuses is the preparation's to report, as it was.
      out.prediction_note = "not predicted: the mesher failed on this surface (the preparation will say how)";
    }
  }
  out.rate = prediction_rate(out.prediction, prepare_rate_, options.grading, response_megabytes_limit());
  return out;
}

// The field's key and the threads asked for: a prediction says the threads it will mesh on, and
// mesh_threads is not part of the field's key.
static std::string prediction_key(const mesh::SurfaceMesh& surface, const kelvin::PrepareOptions& options) {
  return kelvin::prepare_key(surface, options) + "/" + std::to_string(options.mesh_threads);
}

kelvin::PreparePrediction KelvinModule::predict(const mesh::SurfaceMesh& surface, kelvin::PrepareOptions options,
                                                const std::atomic<bool>* cancel) {
  if (auto hit = cached_prediction(surface, options)) return *hit;
  options.max_vertices = std::max<std::size_t>(100, config_.limits.max_vertex_estimate);
  kelvin::Progress progress;
  progress.cancel = cancel;
  kelvin::PreparePrediction p = kelvin::predict_preparation(surface, options, progress);
  predictions_.put(prediction_key(surface, options), p);
  return p;
}

std::optional<kelvin::PreparePrediction> KelvinModule::cached_prediction(const mesh::SurfaceMesh& surface, const kelvin::PrepareOptions& options) {
  return predictions_.find(prediction_key(surface, options));
}

}  // namespace distlab::server
