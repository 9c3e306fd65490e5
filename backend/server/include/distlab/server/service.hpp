#pragma once
// The distlab service, independent of sockets: the router with every endpoint, sessions, jobs,
// Kelvin objects, static files, and the WebSocket protocol. server.hpp puts it on a port.
//
// WebSocket (/ws?session=ID, or the session cookie/header on the upgrade request):
//   client -> server (JSON text): {"type": "ping"} | {"type": "watch", "object", "levels": [...]}
//     | {"type": "sigma", "object", "sigma": {...}} | {"type": "cancel", "job"}
//     | {"type": "state"} (resend the current state) | {"type": "cbf_replay", "rollout", "from"?}
//     Any message may carry "request" (a string of at most 64 characters or an integer): the
//     reply to it (sigma's acknowledgement, or an error) echoes it, to the sending socket only.
//   server -> client: text {"type": "hello"|"pong"|"job"|"object"|"sigma"|"cbf_frames"|"error", ...};
//     binary msgpack frames (see frames.hpp): "surface" (positions, indices, scalars = σ per
//     vertex; once per object and socket), "surface_sigma" (scalars only: every later σ version),
//     "isosurface" (level, index, count, sigma_version, positions, indices).
//   A client joining late (or reconnecting) gets "hello" with the session's jobs and objects,
//   then every ready object's surface with the current σ and the frames of its watched levels.
#include <atomic>
#include <functional>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "distlab/server/config.hpp"
#include "distlab/server/http.hpp"
#include "distlab/server/jobs.hpp"
#include "distlab/server/kelvin_objects.hpp"
#include "distlab/server/router.hpp"
#include "distlab/server/session.hpp"
#include "distlab/server/static_files.hpp"
#include "distlab/server/worker_pool.hpp"

namespace distlab::server {

class CbfRolloutStore;  // cbf_rollouts.hpp

// The OpenAPI document (backend/server/openapi.json, embedded at build time).
const std::string& openapi_text();
// The document with the bounds of its "x-limit" annotations set from `limits` (GET /api/limits).
nlohmann::json openapi_with_limits(const nlohmann::json& limits);
std::string version_string();

class Service {
 public:
  explicit Service(ServiceConfig config);
  ~Service();
  Service(const Service&) = delete;
  Service& operator=(const Service&) = delete;

  const ServiceConfig& config() const { return config_; }
  const Router& router() const { return router_; }
  nlohmann::json limits_json() const;  // GET /api/limits

  // Any HTTP request (API or static file). May block for heavy routes: call it from the
  // compute pool when heavy() says so.
  Response handle(Request& request);
  bool heavy(const Request& request) const;
  std::size_t body_limit(const std::string& path) const;
  // Runs fn on the compute pool; false if too many requests wait (the caller answers 503).
  bool post_compute(std::function<void()> fn);

  // WebSocket: the session of an upgrade request, or nullptr with the refusal to send.
  std::shared_ptr<Session> ws_authorize(const Request& request, Response& refusal);
  void ws_open(const std::shared_ptr<Session>& session, const std::shared_ptr<WsSink>& socket);
  void ws_message(const std::shared_ptr<Session>& session, const std::shared_ptr<WsSink>& socket,
                  const std::string& data, bool binary);
  // A client message's "request" id (a string of at most 64 characters or an integer), echoed in
  // the reply to that message; null when absent or not such an id.
  static nlohmann::json request_id(const nlohmann::json& message);
  static nlohmann::json request_id(const std::string& text);

  void shutdown();  // cancels jobs, stops the pools (idempotent)

 private:
  void register_core_routes();
  void register_gap_routes();
  void register_kelvin_routes();
  void register_cbf_routes();  // routes_cbf.cpp: /api/cbf/...
  void cbf_ws_message(const std::shared_ptr<Session>& session, const std::shared_ptr<WsSink>& socket,
                      const nlohmann::json& msg);  // "cbf_*" WebSocket messages

  void send_state(const std::shared_ptr<Session>& session, const std::shared_ptr<WsSink>& socket);
  std::shared_ptr<Session> require_session(const Request& request);
  std::shared_ptr<KelvinObject> require_object(const Session& session, const Request& request);

  // Kelvin objects (kelvin_service.cpp) and their frames (kelvin_frames.cpp).
  // estimate_only: checks the inputs and answers estimate_json, creating nothing.
  nlohmann::json create_object(const std::shared_ptr<Session>& session, const nlohmann::json& body,
                               bool estimate_only = false);
  nlohmann::json estimate_json(const mesh::SurfaceMesh& welded, kelvin::PrepareOptions options, double estimate) const;
  void record_prepare_time(const nlohmann::json& stats);
  // origin: the socket that sent the edit (gets the acknowledgement with its request id).
  void set_sigma(const std::shared_ptr<Session>& session, const std::shared_ptr<KelvinObject>& object,
                 const nlohmann::json& sigma, WsSink* origin = nullptr, const nlohmann::json& request = nullptr);
  void set_levels(const std::shared_ptr<Session>& session, const std::shared_ptr<KelvinObject>& object,
                  const nlohmann::json& levels);
  void schedule_frames(const std::shared_ptr<Session>& session, const std::shared_ptr<KelvinObject>& object);
  void send_frames(const std::shared_ptr<Session>& session, const std::shared_ptr<KelvinObject>& object,
                   WsSink* only = nullptr);

  ServiceConfig config_;
  std::string temp_cache_;  // removed on shutdown if we made it
  std::string cache_dir_;
  const std::string& registry_cache_dir() const { return cache_dir_; }
  Router router_;
  StaticFiles static_files_;
  SessionStore sessions_;
  PreparedRegistry registry_;
  WorkerPool compute_;
  JobManager jobs_;
  std::shared_ptr<CbfRolloutStore> cbf_rollouts_;
  std::atomic<bool> stopped_{false};
  std::atomic<double> prepare_seconds_per_vertex_{0};  // of the last computed preparation
};

}  // namespace distlab::server
