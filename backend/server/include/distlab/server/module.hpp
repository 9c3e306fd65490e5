#pragma once
// A feature of the service (gap, kelvin, cbf, ...) as the core sees it: it registers its routes,
// handles its WebSocket message types, adds its limits to GET /api/limits and its part of the
// state a joining socket receives. What it keeps per session is its own type derived from
// ModuleState (session.hpp), reached with session.state<T>(). The core (service.hpp) knows this
// interface and no feature; a feature knows the core. modules.cpp wires the features in, one line
// each.
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "distlab/server/config.hpp"
#include "distlab/server/http.hpp"
#include "distlab/server/jobs.hpp"
#include "distlab/server/route_table.hpp"
#include "distlab/server/router.hpp"
#include "distlab/server/session.hpp"
#include "distlab/server/worker_pool.hpp"

namespace distlab::server {

class Service;

class Module {
 public:
  explicit Module(Service& core);
  virtual ~Module() = default;
  Module(const Module&) = delete;
  Module& operator=(const Module&) = delete;

  virtual std::string name() const = 0;  // listed by GET /api/version
  virtual void register_routes() = 0;    // called once, by Service::add

  // WebSocket message types ({"type": ...}) this module answers; ws_message gets only those.
  // `request` is the message's request id (null when absent), echoed in a reply.
  virtual std::vector<std::string> ws_types() const { return {}; }
  virtual void ws_message(const std::shared_ptr<Session>& /*session*/, const std::shared_ptr<WsSink>& /*socket*/,
                          const nlohmann::json& /*msg*/, const nlohmann::json& /*request*/) {}
  // Entries of GET /api/limits beyond the Limits table (limits the module owns).
  virtual void add_limits(nlohmann::json& /*limits*/) const {}
  // Fields of the "hello" a joining socket gets, and what it is sent after it (late joiners).
  virtual void add_state(Session& /*session*/, nlohmann::json& /*hello*/) {}
  virtual void joined(const std::shared_ptr<Session>& /*session*/, const std::shared_ptr<WsSink>& /*socket*/) {}
  // Fields of GET /api/session.
  virtual void describe_session(Session& /*session*/, nlohmann::json& /*out*/) {}
  virtual void shutdown() {}  // after the jobs stopped, before the pools are gone

  // The built-in assets (meshes, scenarios, robots), for a table's decoders (route_table.hpp).
  const std::string& assets_dir() const { return config_.assets_dir; }

 protected:
  // The core's parts a module uses (the same names the Service itself uses).
  std::shared_ptr<Session> require_session(const Request& request);
  std::shared_ptr<Session> require_session(const Caller& caller);  // a table's handler (route_table.hpp)
  bool post_compute(std::function<void()> fn);

  Service& core_;
  const ServiceConfig& config_;
  Router& router_;
  SessionStore& sessions_;
  JobManager& jobs_;
  WorkerPool& compute_;
};

}  // namespace distlab::server
