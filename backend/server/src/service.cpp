// The service: construction, dispatch, sessions, jobs routes, the WebSocket protocol.
#include "distlab/server/service.hpp"

#include <filesystem>
#include <functional>
#include <thread>

#include "distlab/geometry/error.hpp"
#include "distlab/server/cbf_json.hpp"
#include "distlab/server/cbf_rollouts.hpp"
#include "distlab/server/frames.hpp"
#include "distlab/server/gap_json.hpp"
#include "distlab/server/json_fields.hpp"

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
      registry_(cache_dir_),
      compute_(config_.compute_threads),
      jobs_(job_options(config_), [this](const std::string& session_id, const json& event) {
        if (auto s = sessions_.find(session_id)) s->broadcast(event.dump(), false);
      }) {
  register_core_routes();
  register_gap_routes();
  register_kelvin_routes();
  register_cbf_routes();
}

Service::~Service() { shutdown(); }

void Service::shutdown() {
  if (stopped_.exchange(true)) return;
  jobs_.shutdown();
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

std::shared_ptr<Session> Service::require_session(const Request& request) {
  const std::string id = request.session_id();
  if (id.empty())
    throw ApiError(401, "session_required",
                   "this endpoint needs a session: POST /api/session, then send its id in the "
                   "X-Distlab-Session header (or the distlab_session cookie)");
  auto s = sessions_.find(id);
  if (!s) throw ApiError(404, "unknown_session", "no such session (it may have expired)");
  return s;
}

// Every limit of the table (config.hpp for_each_limit), the CBF rollout limits (also in GET
// /api/cbf/scenarios) and request_bounds: for each synchronous heavy route, the limits bounding it.
json Service::limits_json() const {
  json limits = json::object();
  for_each_limit(config_.limits, [&](const char* name, auto value) { limits[name] = value; });
  limits["isosurface_levels_per_request"] = kIsosurfaceLevelsPerRequest;
  limits["max_abs_sigma"] = kelvin::kMaxAbsSigma;  // a property of the method (sigma.hpp)
  const CbfLimits& cbf = cbf_rollouts_->limits();
  limits["max_cbf_steps"] = cbf.max_steps;
  limits["max_cbf_duration"] = kMaxScenarioDuration;
  limits["max_cbf_pair_steps"] = cbf.max_pair_steps;
  limits["max_cbf_batch_steps"] = cbf.max_batch_steps;
  limits["max_cbf_frames_per_request"] = cbf.max_frames_per_request;
  limits["cbf_rollouts_kept_per_session"] = cbf.kept_per_session;
  limits["cbf_rollouts_kept_total"] = cbf.kept_total;
  json bounds = json::object();
  for (const Route& r : router_.routes())
    if (r.heavy) bounds[r.method + " " + r.pattern] = r.bounds;
  limits["request_bounds"] = bounds;
  return limits;
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
// Core routes: health, version, OpenAPI, sessions, jobs.

void Service::register_core_routes() {
  router_.add({"GET", "/api/health", [](Request&) { return json_response(200, {{"status", "ok"}}); }});
  router_.add({"GET", "/api/version", [](Request&) {
                 json modules = {"gap", "levelset"};
#ifdef DISTLAB_HAVE_KELVIN
                 modules.push_back("kelvin");
#endif
                 return json_response(200, {{"name", "distlab"}, {"version", version_string()},
                                            {"api", "1"}, {"modules", modules}});
               }});
  router_.add({"GET", "/api/openapi.json", [this](Request&) {
                 Response r;
                 r.body = openapi_with_limits(limits_json()).dump(1);
                 return r;
               }});
  router_.add({"GET", "/api/limits", [this](Request&) { return json_response(200, limits_json()); }});

  router_.add({"POST", "/api/session", [this](Request& req) {
                 auto s = sessions_.create(req.remote_address);
                 Response r = json_response(201, {{"session", s->id}});
                 r.headers.emplace_back("Set-Cookie", "distlab_session=" + s->id + "; Path=/; HttpOnly; SameSite=Strict");
                 return r;
               }});
  router_.add({"GET", "/api/session", [this](Request& req) {
                 auto s = require_session(req);
                 std::size_t objects, uploads, sockets;
                 {
                   std::lock_guard lock(s->mutex);
                   objects = s->objects.size();
                   uploads = s->uploads.size();
                   sockets = s->sockets.size();
                 }
                 return json_response(200, {{"session", s->id}, {"objects", objects}, {"uploads", uploads},
                                            {"sockets", sockets}, {"jobs", jobs_.list(s->id).size()}});
               }});
  router_.add({"DELETE", "/api/session", [this](Request& req) {
                 auto s = require_session(req);
                 jobs_.cancel_session(s->id);
                 sessions_.erase(s->id);
                 return no_content_response();
               }});

  router_.add({"GET", "/api/jobs", [this](Request& req) {
                 auto s = require_session(req);
                 json list = json::array();
                 for (const auto& j : jobs_.list(s->id)) list.push_back(j->to_json());
                 return json_response(200, {{"jobs", list}});
               }});
  router_.add({"GET", "/api/jobs/{id}", [this](Request& req) {
                 auto s = require_session(req);
                 auto j = jobs_.find(s->id, req.params["id"]);
                 if (!j) throw ApiError(404, "unknown_job", "no such job in this session");
                 return json_response(200, j->to_json());
               }});
  router_.add({"POST", "/api/jobs/{id}/cancel", [this](Request& req) {
                 auto s = require_session(req);
                 auto j = jobs_.find(s->id, req.params["id"]);
                 if (!j) throw ApiError(404, "unknown_job", "no such job in this session");
                 j->cancel = true;
                 return json_response(202, j->to_json());
               }});
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
  {
    std::lock_guard lock(session->mutex);
    session->sockets.push_back(socket);
  }
  send_state(session, socket);
}

void Service::send_state(const std::shared_ptr<Session>& session, const std::shared_ptr<WsSink>& socket) {
  std::vector<std::shared_ptr<KelvinObject>> objects;
  {
    std::lock_guard lock(session->mutex);
    for (const auto& [id, o] : session->objects) objects.push_back(o);
  }
  json jobs = json::array(), objs = json::array();
  for (const auto& j : jobs_.list(session->id)) jobs.push_back(j->to_json());
  for (const auto& o : objects) objs.push_back(o->status_json());
  socket->send(json{{"type", "hello"}, {"session", session->id}, {"jobs", jobs}, {"objects", objs}}.dump(), false);
  // Late joiners (and a reconnected client) get the current state of every ready object: its
  // surface with the current σ, and the frames of its watched levels.
  for (const auto& o : objects) {
    bool ready;
    {
      std::lock_guard lock(o->mutex);
      ready = o->state == "ready";
    }
    if (ready) {
      auto weak = std::weak_ptr<WsSink>(socket);
      post_compute([this, session, o, weak] {
        if (auto s = weak.lock()) send_frames(session, o, s.get());
      });
    }
  }
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
  } catch (const JsonSyntaxError& e) {
    return reply_error(400, "malformed_json", "malformed JSON at byte " + std::to_string(e.byte()), "");
  } catch (const InvalidInput& e) {
    return reply_error(400, "invalid_input", e.what(), e.field());
  }
  const Response r = guarded([&]() -> Response {
    if (!msg.is_object() || !msg.contains("type") || !msg["type"].is_string())
      throw InvalidInput("type", "a message is an object with a string \"type\"");
    request = request_id(msg);
    if (msg.contains("request") && request.is_null())
      throw InvalidInput("request", "request must be a string of at most 64 characters or an integer");
    const std::string type = msg["type"];
    auto object = [&]() {
      if (!msg.contains("object") || !msg["object"].is_string()) throw InvalidInput("object", "object must be an object id");
      std::lock_guard lock(session->mutex);
      auto it = session->objects.find(msg["object"].get<std::string>());
      if (it == session->objects.end()) throw ApiError(404, "unknown_object", "no such object in this session", "object");
      return it->second;
    };
    if (type == "ping") {
      json_check_keys(msg, "", {"type", "request"});
      socket->send(json{{"type", "pong"}}.dump(), false);
    } else if (type == "state") {
      json_check_keys(msg, "", {"type", "request"});
      send_state(session, socket);
    } else if (type == "watch") {
      json_check_keys(msg, "", {"type", "request", "object", "levels"});
      if (!msg.contains("levels")) throw InvalidInput("levels", "levels is required");
      set_levels(session, object(), msg["levels"]);
    } else if (type == "sigma") {
      json_check_keys(msg, "", {"type", "request", "object", "sigma"});
      if (!msg.contains("sigma")) throw InvalidInput("sigma", "sigma is required");
      set_sigma(session, object(), msg["sigma"], socket.get(), request);
    } else if (type == "cancel") {
      json_check_keys(msg, "", {"type", "request", "job"});
      if (!msg.contains("job") || !msg["job"].is_string()) throw InvalidInput("job", "job must be a job id");
      auto j = jobs_.find(session->id, msg["job"]);
      if (!j) throw ApiError(404, "unknown_job", "no such job in this session", "job");
      j->cancel = true;
    } else if (type.rfind("cbf_", 0) == 0) {
      cbf_ws_message(session, socket, msg);
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
