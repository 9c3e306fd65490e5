#pragma once
// The distlab service, independent of sockets: the core that knows no feature (the router,
// sessions, jobs, the compute pool, limits, static files, the OpenAPI document, the WebSocket
// protocol's dispatch) and the feature modules added to it (module.hpp; modules.hpp adds gap,
// kelvin and cbf). server.hpp puts it on a port.
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
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "distlab/server/config.hpp"
#include "distlab/server/http.hpp"
#include "distlab/server/jobs.hpp"
#include "distlab/server/module.hpp"
#include "distlab/server/router.hpp"
#include "distlab/server/session.hpp"
#include "distlab/server/static_files.hpp"
#include "distlab/server/worker_pool.hpp"

namespace distlab::server {

// The OpenAPI document (assembled by openapi_assemble.py, embedded at build time).
const std::string& openapi_text();
// The document with the bounds of its "x-limit" annotations set from `limits` (GET /api/limits).
nlohmann::json openapi_with_limits(const nlohmann::json& limits);
std::string version_string();

struct VersionInfo;
struct LimitSources;
struct SessionId;
struct SessionSummary;
struct JobRef;

class Service {
 public:
  explicit Service(ServiceConfig config);  // no feature yet: add them with add()
  ~Service();
  Service(const Service&) = delete;
  Service& operator=(const Service&) = delete;

  // Adds a feature: registers its routes and WebSocket message types (before serving).
  void add(std::unique_ptr<Module> module);
  template <class M>
  M& add() {
    auto m = std::make_unique<M>(*this);
    M& ref = *m;
    add(std::move(m));
    return ref;
  }

  const ServiceConfig& config() const { return config_; }
  const Router& router() const { return router_; }
  const std::string& cache_dir() const { return cache_dir_; }
  nlohmann::json limits_json() const;  // GET /api/limits

  // Any HTTP request (API or static file). May block for heavy routes: call it from the
  // compute pool when heavy() says so.
  Response handle(Request& request);
  bool heavy(const Request& request) const;
  std::size_t body_limit(const std::string& path) const;
  // Runs fn on the compute pool; false if too many requests wait (the caller answers 503).
  bool post_compute(std::function<void()> fn);
  // The request's session; ApiError 401 without an id, 404 for an unknown one.
  std::shared_ptr<Session> require_session(const Request& request);
  // The caller's session (route_table.hpp's Caller): 401 session_required without one, 404 unknown_session.
  std::shared_ptr<Session> require_session(const std::string& session_id);

  // WebSocket: the session of an upgrade request, or nullptr with the refusal to send.
  std::shared_ptr<Session> ws_authorize(const Request& request, Response& refusal);
  void ws_open(const std::shared_ptr<Session>& session, const std::shared_ptr<WsSink>& socket);
  void ws_message(const std::shared_ptr<Session>& session, const std::shared_ptr<WsSink>& socket,
                  const std::string& data, bool binary);
  // A client message's "request" id (a string of at most 64 characters or an integer), echoed in
  // the reply to that message; null when absent or not such an id.
  static nlohmann::json request_id(const nlohmann::json& message);
  static nlohmann::json request_id(const std::string& text);

  void shutdown();  // cancels jobs, stops the modules and the pools (idempotent)

 private:
  friend class Module;
  void register_core_routes();  // core_routes.cpp: its table and handlers
  Nothing health(const Nothing& in, const Caller& caller);
  VersionInfo version(const Nothing& in, const Caller& caller);
  LimitSources published_limits(const Nothing& in, const Caller& caller);
  LimitSources limit_sources() const;
  SessionId create_session(const Nothing& in, const Caller& caller);
  SessionSummary session_summary(const Nothing& in, const Caller& caller);
  Nothing end_session(const Nothing& in, const Caller& caller);
  std::vector<JobStatus> session_jobs(const Nothing& in, const Caller& caller);
  std::shared_ptr<Job> find_job(const JobRef& ref, const Caller& caller);  // 404 unknown_job
  JobStatus job(const JobRef& ref, const Caller& caller);
  JobStatus cancel_job(const JobRef& ref, const Caller& caller);
  void send_state(const std::shared_ptr<Session>& session, const std::shared_ptr<WsSink>& socket);

  ServiceConfig config_;
  std::string temp_cache_;  // removed on shutdown if we made it
  std::string cache_dir_;
  Router router_;
  StaticFiles static_files_;
  SessionStore sessions_;
  WorkerPool compute_;
  JobManager jobs_;
  // Declared last: destroyed first, while the core parts they refer to still exist.
  std::vector<std::unique_ptr<Module>> modules_;
  std::map<std::string, Module*> ws_handlers_;  // message type -> module
  std::atomic<bool> stopped_{false};
};

}  // namespace distlab::server
