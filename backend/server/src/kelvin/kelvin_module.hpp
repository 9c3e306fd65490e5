#pragma once
// The Kelvin feature as a module of the service: assets, uploads and objects (routes_kelvin.cpp),
// their creation (kelvin_service.cpp), reads and edits (kelvin_object_handlers.cpp), their frames
// (kelvin_frames.cpp), and the WebSocket messages "watch" and "sigma" (kelvin_module.cpp).
#include <atomic>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "distlab/mesh/weld.hpp"
#include "distlab/server/kelvin_objects.hpp"
#include "distlab/server/module.hpp"
#include "distlab/server/service.hpp"
#include "distlab/server/uploads.hpp"
#include "kelvin_codec.hpp"
#include "kelvin_upload_codec.hpp"
#include "prepare_estimate.hpp"

namespace distlab::server {

// The Kelvin part of a session (Session::state, guarded by the session's mutex); its uploads are
// the session's (uploads.hpp), which other modules read too.
struct KelvinSessionState : ModuleState {
  std::map<std::string, std::shared_ptr<KelvinObject>> objects;
};

class KelvinModule final : public Module {
 public:
  explicit KelvinModule(Service& core)
      : Module(core),
        registry_(field_store(core.cache_dir(), config_.limits), config_.limits.max_response_bytes, config_.limits.max_response_bytes_total) {}

  std::string name() const override { return "kelvin"; }
  void register_routes() override;  // objects (routes_kelvin.cpp)
  std::vector<std::string> ws_types() const override { return {"watch", "sigma"}; }
  void ws_message(const std::shared_ptr<Session>& session, const std::shared_ptr<WsSink>& socket,
                  const nlohmann::json& msg, const nlohmann::json& request) override;
  void add_limits(nlohmann::json& limits) const override;
  void add_state(Session& session, nlohmann::json& hello) override;
  void joined(const std::shared_ptr<Session>& session, const std::shared_ptr<WsSink>& socket) override;
  void describe_session(Session& session, nlohmann::json& out) override;

 private:
  void register_upload_routes();  // assets and uploads (routes_kelvin_uploads.cpp)
  // The upload routes' handlers (routes_kelvin_uploads.cpp; their codec kelvin_upload_codec.hpp).
  AssetNames list_assets(const Nothing& none, const Caller& caller);
  UploadDescription create_upload(const UploadFile& file, const Caller& caller);
  UploadDescription reuse_upload(const UploadDigest& in, const Caller& caller);
  Nothing delete_upload(const UploadId& in, const Caller& caller);
  UploadSurface upload_surface(const UploadId& in, const Caller& caller);
  UploadDefects upload_defects(const UploadId& in, const Caller& caller);
  const std::string& registry_cache_dir() const { return core_.cache_dir(); }
  // This session's objects and uploads; call with session.mutex held.
  static KelvinSessionState& kelvin_state(Session& session) { return session.state<KelvinSessionState>(); }
  static SessionUploads& uploads(Session& session) { return session.state<SessionUploads>(); }
  std::shared_ptr<KelvinObject> require_object(Session& session, const std::string& id);
  std::shared_ptr<const Upload> require_upload(Session& session, const std::string& id);
  // Adds an upload to the session and to held_; the upload's description (POST .../uploads).
  UploadDescription add_upload(Session& session, const std::shared_ptr<const Upload>& upload);
  // 429 too_many_uploads when the session holds max_uploads_per_session (call under its mutex).
  void require_upload_room(Session& session) const;
  // The mesh with this digest if some session still holds it.
  std::shared_ptr<const Upload> held(const std::string& digest);

  // The object routes' handlers (routes_kelvin.cpp; their codec kelvin_codec.hpp): creation
  // (kelvin_service.cpp), the rest in kelvin_object_handlers.cpp.
  CreatedObject create_object(const CreateObjectRequest& in, const Caller& caller);
  ObjectEstimate estimate(const CreateObjectRequest& in, const Caller& caller);
  ObjectList list_objects(const Nothing& none, const Caller& caller);
  std::shared_ptr<KelvinObject> get_object(const ObjectRef& in, const Caller& caller);
  Nothing delete_object(const ObjectRef& in, const Caller& caller);
  SigmaState get_sigma(const ObjectRef& in, const Caller& caller);
  SigmaState put_sigma(const SigmaRequest& in, const Caller& caller);
  std::vector<double> put_levels(const LevelsRequest& in, const Caller& caller);
  QueryResult query(const QueryRequest& in, const Caller& caller);
  Isosurface isosurface(const LevelRequest& in, const Caller& caller);
  SurfaceView surface(const SurfaceRequest& in, const Caller& caller);
  ExportFile export_isosurface(const LevelRequest& in, const Caller& caller);

  // What creating and estimating share: the user's mesh (loaded, within the triangle bounds), its
  // weld, the options with l_x resolved (at least min_lx), and the vertex estimate.
  // The surface the preparation will prepare where it exists before the job: the weld, its largest
  // piece, or for a simplification the weld it simplifies (the same shape); none where a fix or
  // wrap makes it, or over max_object_triangles (predicting that costs seconds): `unpredicted` says.
  struct ObjectPlan {
    mesh::SurfaceMesh surface;
    mesh::Welded welded;
    std::optional<mesh::SurfaceMesh> piece;
    kelvin::PrepareOptions options;
    double diagonal = 0, estimate = 0;  // estimate: the closed form (estimate_vertices)
    std::string unpredicted;
    const mesh::SurfaceMesh* to_predict() const { return !unpredicted.empty() ? nullptr : piece ? &*piece
                                                                                                : &welded.surface; }
  };
  ObjectPlan plan_object(const CreateObjectRequest& in, Session& session);
  // The plan's count for the vertex budget (kelvin_json.hpp, count_vertices), predicting within max_request_seconds.
  VertexCount count_vertices(const ObjectPlan& plan);
  // Refuses what the preparation would (over the vertex budget, not closed, a bad centre) before
  // a job exists; sets the job's meshing cap.
  void check_preparable(const CreateObjectRequest& in, ObjectPlan& plan);
  std::shared_ptr<KelvinObject> make_object(const CreateObjectRequest& in, ObjectPlan& plan, const Session& session);
  // Submits the object's preparation job (repair, predict, prepare) and returns it.
  std::shared_ptr<Job> start_preparation(const std::shared_ptr<Session>& session, const std::shared_ptr<KelvinObject>& object,
                                         const kelvin::PrepareOptions& options);
  // The job's work; its result {"object", "stats"}.
  nlohmann::json prepare_object(Job& job, const std::shared_ptr<KelvinObject>& object, const kelvin::PrepareOptions& options,
                                const std::weak_ptr<Session>& session);
  // Repairs (if asked), predicts and prepares the object's field, which it sets on the object.
  void prepare_field(Job& job, KelvinObject& object, const kelvin::PrepareOptions& options, const std::function<void()>& announce);
  ObjectEstimate estimate_of(const CreateObjectRequest& in, const ObjectPlan& plan);
  // The largest boundary response a preparation builds (PreparedRegistry::prepare), in MB.
  double response_megabytes_limit() const { return static_cast<double>(config_.limits.max_response_bytes) / 1e6; }
  // The object's prepared field with its σ, or 409 not_ready.
  struct ReadyField {
    std::shared_ptr<PreparedField> prepared;
    kelvin::SigmaSpec sigma;
    std::string key;
    std::uint64_t version = 0;
  };
  static ReadyField ready_field(KelvinObject& object);
  // kelvin::predict_preparation through predictions_ (options.max_vertices as the job's).
  // Throws what it throws (InvalidInput: the refusal the preparation would give; kelvin::Cancelled
  // once *cancel is set).
  kelvin::PreparePrediction predict(const mesh::SurfaceMesh& surface, kelvin::PrepareOptions options,
                                    const std::atomic<bool>* cancel = nullptr);
  std::optional<kelvin::PreparePrediction> cached_prediction(const mesh::SurfaceMesh& surface, const kelvin::PrepareOptions& options);
  // origin: the socket that sent the edit (gets the acknowledgement with its request id).
  void set_sigma(const std::shared_ptr<Session>& session, const std::shared_ptr<KelvinObject>& object, const SigmaEdit& sigma,
                 WsSink* origin = nullptr, const nlohmann::json& request = nullptr);
  void set_levels(const std::shared_ptr<Session>& session, const std::shared_ptr<KelvinObject>& object,
                  std::vector<double> levels);
  void schedule_frames(const std::shared_ptr<Session>& session, const std::shared_ptr<KelvinObject>& object);
  void send_frames(const std::shared_ptr<Session>& session, const std::shared_ptr<KelvinObject>& object,
                   WsSink* only = nullptr);

  PreparedRegistry registry_;
  // Every session's uploads by digest (weak: a mesh is held while a session holds it). A link
  // names an upload by its digest; POST .../uploads/reuse gives the asking session the same mesh.
  // That is all the digest proves (the mesh's identity): nothing else of the uploading session
  // (its file name, objects, σ) is reachable this way.
  std::mutex held_mutex_;
  std::map<std::string, std::weak_ptr<const Upload>> held_;
  // Uploads' and objects' triangles, per client address and in all.
  ClientShare held_triangles_{"triangles", "max_held_triangles_per_address", config_.limits.max_held_triangles_per_address, "max_held_triangles",
                              config_.limits.max_held_triangles, "uploads or objects (DELETE /api/kelvin/uploads/{id}, /api/kelvin/objects/{id})"};
  PrepareRate prepare_rate_;     // seconds per field vertex of the preparations computed here
  PredictionCache predictions_;  // predict()'s last answers
};

}  // namespace distlab::server
