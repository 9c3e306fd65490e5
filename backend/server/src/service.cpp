// The core service: construction, dispatch, modules, sessions, the WebSocket protocol (its routes:
// core_routes.cpp).
#include "distlab/server/service.hpp"

#include <filesystem>
#include <functional>
#include <thread>

#include "distlab/geometry/error.hpp"
#include "distlab/server/json_fields.hpp"
#include "distlab/server/json_text.hpp"

namespace distlab::server {

using json = nlohmann::json;
namespace fs = std::filesystem;

std::string version_string() {
#ifdef DISTLAB_VERSION
  return DISTLAB_VERSION;
#else
  return "0.0.0";
#endif
}

namespace {

// Heap each compute thread touches at its start (worker_pool.hpp): about what one σ edit's frame
// allocates at 26k vertices (iso-surface tables and mesh, ~3 MB, and its encoding).
constexpr std::size_t kWarmHeapBytes = std::size_t{8} << 20;

std::string make_cache_dir(const std::string& wanted, std::string& temp) {
  if (!wanted.empty()) {
    std::error_code ec;
    fs::create_directories(wanted, ec);
    if (ec) throw std::runtime_error("cannot create the cache directory " + wanted + ": " + ec.message());
    return wanted;
  }
  temp = (fs::temp_directory_path() / ("distlab-cache-" + random_id().substr(0, 12))).string();
  fs::create_directories(temp);
  return temp;
}

JobManager::Options job_options(const ServiceConfig& c) {
  JobManager::Options o;
  o.threads = c.job_threads;
  o.per_session = c.limits.max_jobs_per_session;
  o.total = c.limits.max_jobs_total;
  o.keep_finished = c.limits.max_finished_jobs_kept;
  o.max_seconds = c.limits.max_job_seconds;
  return o;
}

}  // namespace

Service::Service(ServiceConfig config)
    : config_(std::move(config)),
      cache_dir_(make_cache_dir(config_.cache_dir, temp_cache_)),
      static_files_(config_.web_dir),
      sessions_(config_.limits.max_sessions, config_.limits.max_sessions_per_address, config_.limits.session_idle_seconds),
      compute_(config_.compute_threads, [] { warm_thread_heap(kWarmHeapBytes); }),
      jobs_(job_options(config_), [this](const std::string& session_id, const json& event) {
        if (auto s = sessions_.find(session_id)) s->broadcast(event.dump(), false);
      }) {
  register_core_routes();
}

Service::~Service() { shutdown(); }

void Service::add(std::unique_ptr<Module> module) {
  module->register_routes();
  for (const std::string& type : module->ws_types()) {
    if (type == "ping" || type == "state" || type == "cancel" || ws_handlers_.count(type))
      throw std::logic_error("WebSocket message type \"" + type + "\" is registered twice");
    ws_handlers_[type] = module.get();
  }
  modules_.push_back(std::move(module));
}

Module::Module(Service& core)
    : core_(core), config_(core.config_), router_(core.router_), sessions_(core.sessions_), jobs_(core.jobs_), compute_(core.compute_) {}

std::shared_ptr<Session> Module::require_session(const Request& request) { return core_.require_session(request); }
std::shared_ptr<Session> Module::require_session(const Caller& caller) { return core_.require_session(caller.session_id); }
bool Module::post_compute(std::function<void()> fn) { return core_.post_compute(std::move(fn)); }

void Service::shutdown() {
  if (stopped_.exchange(true)) return;
  jobs_.shutdown();
  for (auto& m : modules_) m->shutdown();
  compute_.stop();
  for (const auto& s : sessions_.all()) {
    std::vector<std::shared_ptr<WsSink>> live;
    {
      std::lock_guard lock(s->mutex);
      for (auto& w : s->sockets)
        if (auto p = w.lock()) live.push_back(p);
    }
    for (auto& p : live) p->close();
  }
  if (!temp_cache_.empty()) {
    std::error_code ec;
    fs::remove_all(temp_cache_, ec);
  }
}

Response Service::handle(Request& request) {
  if (request.path == "/api" || request.path.rfind("/api/", 0) == 0) {
    Response r = router_.dispatch(request);
    r.headers.emplace_back("Cache-Control", "no-store");
    return r;
  }
  return static_files_.serve(request);
}

bool Service::heavy(const Request& request) const {
  const Route* r = router_.match(request.method, request.path);
  return r != nullptr && r->heavy;
}

std::size_t Service::body_limit(const std::string& path) const {
  for (const Route& r : router_.routes())
    if (r.body_limit != 0 && router_.match(r.method, path) == &r) return r.body_limit;
  return config_.limits.max_body_bytes;
}

bool Service::post_compute(std::function<void()> fn) {
  return compute_.post(std::move(fn), config_.limits.max_pending_requests);
}

std::shared_ptr<Session> Service::require_session(const Request& request) { return require_session(request.session_id()); }

std::shared_ptr<Session> Service::require_session(const std::string& id) {
  if (id.empty())
    throw ApiError(401, "session_required",
                   "this endpoint needs a session: POST /api/session, then send its id in the "
                   "X-Distlab-Session header (or the distlab_session cookie)");
  auto s = sessions_.find(id);
  if (!s) throw ApiError(404, "unknown_session", "no such session (it may have expired)");
  return s;
}

// The OpenAPI document with this server's limits: a schema node {"x-limit": {"maxItems":
// "max_gap_pairs"}} gets maxItems = limits.max_gap_pairs (the checked-in values are the defaults).
json openapi_with_limits(const json& limits) {
  json doc = json::parse(openapi_text());
  std::function<void(json&)> walk = [&](json& node) {
    if (node.is_object()) {
      if (const auto it = node.find("x-limit"); it != node.end() && it->is_object()) {
        const json bounds = *it;
        for (const auto& [keyword, name] : bounds.items()) node[keyword] = limits.at(name.get<std::string>());
      }
      for (auto& [key, child] : node.items()) walk(child);
    } else if (node.is_array()) {
      for (auto& child : node) walk(child);
    }
  };
  walk(doc);
  return doc;
}

// --------------------------------------------------------------------------------------------
// WebSocket protocol.

std::shared_ptr<Session> Service::ws_authorize(const Request& request, Response& refusal) {
  if (request.path != "/ws") {
    refusal = error_response(404, "unknown_route", "the WebSocket endpoint is /ws");
    return nullptr;
  }
  refusal = guarded([&]() -> Response {
    require_session(request);
    return Response{};
  });
  if (refusal.status != 200) return nullptr;
  return sessions_.find(request.session_id());
}

void Service::ws_open(const std::shared_ptr<Session>& session, const std::shared_ptr<WsSink>& socket) {
  send_state(session, socket);
}

void Service::send_state(const std::shared_ptr<Session>& session, const std::shared_ptr<WsSink>& socket) {
  session->start_join(socket);  // listed before the state is read: nothing between is lost
  std::string hello;
  try {
    json jobs = json::array();
    for (const auto& j : jobs_.list(session->id)) jobs.push_back(j->to_json());
    json h{{"type", "hello"}, {"session", session->id}, {"jobs", jobs}};
    for (const auto& m : modules_) m->add_state(*session, h);
    hello = h.dump();
  } catch (...) {
    session->finish_join(*socket, {});
    throw;
  }
  session->finish_join(*socket, hello);
  // Late joiners (and a reconnected client) get the modules' current state after the hello.
  for (const auto& m : modules_) m->joined(session, socket);
}

json Service::request_id(const json& message) {
  if (!message.is_object()) return nullptr;
  const auto it = message.find("request");
  if (it == message.end()) return nullptr;
  if ((it->is_string() && it->get_ref<const std::string&>().size() <= 64) || it->is_number_integer()) return *it;
  return nullptr;
}

json Service::request_id(const std::string& text) {
  return request_id(json::parse(text, nullptr, false));
}

void Service::ws_message(const std::shared_ptr<Session>& session, const std::shared_ptr<WsSink>& socket,
                         const std::string& data, bool binary) {
  session->touch();
  json request;  // the message's request id, echoed in its reply (null: none)
  auto reply_error = [&](int status, const std::string& code, const std::string& message, const std::string& field) {
    json e{{"type", "error"}, {"status", status}, {"error", {{"code", code}, {"message", message}, {"field", field}}}};
    if (!request.is_null()) e["request"] = request;
    socket->send(e.dump(), false);
  };
  if (binary) return reply_error(400, "unsupported", "binary messages from clients are not part of the protocol", "");
  json msg;
  try {
    msg = parse_json_text(data, data.size());  // held to max_ws_message_bytes by the socket
  } catch (const std::exception&) {
    const ErrorAnswer a = error_answer(std::current_exception());
    return reply_error(a.status, a.code, a.message, a.field);
  }
  const Response r = guarded([&]() -> Response {
    if (!msg.is_object() || !msg.contains("type") || !msg["type"].is_string())
      throw InvalidInput("type", "a message is an object with a string \"type\"");
    request = request_id(msg);
    if (msg.contains("request") && request.is_null())
      throw InvalidInput("request", "request must be a string of at most 64 characters or an integer");
    const std::string type = msg["type"];
    if (type == "ping") {
      json_check_keys(msg, "", {"type", "request"});
      socket->send(json{{"type", "pong"}}.dump(), false);
    } else if (type == "state") {
      json_check_keys(msg, "", {"type", "request"});
      send_state(session, socket);
    } else if (type == "cancel") {
      json_check_keys(msg, "", {"type", "request", "job"});
      if (!msg.contains("job") || !msg["job"].is_string()) throw InvalidInput("job", "job must be a job id");
      auto j = jobs_.find(session->id, msg["job"]);
      if (!j) throw ApiError(404, "unknown_job", "no such job in this session", "job");
      j->cancel = true;
    } else if (const auto it = ws_handlers_.find(type); it != ws_handlers_.end()) {
      it->second->ws_message(session, socket, msg, request);
    } else {
      throw InvalidInput("type", "unknown message type \"" + type.substr(0, 32) + "\"");
    }
    return Response{};
  });
  if (r.status != 200) {
    const json body = json::parse(r.body, nullptr, false);
    if (body.is_object() && body.contains("error")) {
      json e{{"type", "error"}, {"status", r.status}, {"error", body["error"]}};
      if (!request.is_null()) e["request"] = request;
      socket->send(e.dump(), false);
    }
  }
}

}  // namespace distlab::server
