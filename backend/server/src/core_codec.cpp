// The core routes' codec (core_codec.hpp): their only input is a path parameter; their answers.
#include "core_codec.hpp"

#include <mutex>

#include "distlab/server/service.hpp"

namespace distlab::server {

using json = nlohmann::json;

// Every limit of the table (config.hpp for_each_limit), those the modules own (Module::add_limits)
// and request_bounds: for each synchronous heavy route, the limits bounding it.
json limits_json(const LimitSources& sources) {
  json limits = json::object();
  for_each_limit(sources.table, [&](const char* name, auto value) { limits[name] = value; });
  for (const Module* m : sources.modules) m->add_limits(limits);
  json bounds = json::object();
  for (const auto& [route, names] : sources.request_bounds) bounds[route] = names;
  limits["request_bounds"] = bounds;
  return limits;
}

JobRef decode_job_ref(const Request& request, const Limits& /*limits*/) { return {request.params.at("id")}; }

Response encode_health(const Nothing& /*nothing*/) { return json_response(200, {{"status", "ok"}}); }

Response encode_version(const VersionInfo& version) {
  return json_response(200, {{"name", "distlab"}, {"version", version_string()}, {"api", "1"}, {"modules", version.modules}});
}

Response encode_openapi(const LimitSources& sources) {
  Response r;
  r.body = openapi_with_limits(limits_json(sources)).dump(1);
  return r;
}

Response encode_limits(const LimitSources& sources) { return json_response(200, limits_json(sources)); }

Response encode_new_session(const SessionId& session) {
  Response r = json_response(201, {{"session", session.id}});
  r.headers.emplace_back("Set-Cookie", "distlab_session=" + session.id + "; Path=/; HttpOnly; SameSite=Strict");
  return r;
}

Response encode_session(const SessionSummary& summary) {
  json out = {{"session", summary.session->id}, {"sockets", summary.sockets}, {"jobs", summary.jobs}};
  for (Module* m : summary.modules) m->describe_session(*summary.session, out);
  return json_response(200, out);
}

Response encode_jobs(const std::vector<JobStatus>& jobs) {
  json list = json::array();
  for (const JobStatus& j : jobs) list.push_back(job_json(j));
  return json_response(200, {{"jobs", list}});
}

Response encode_job(const JobStatus& job) { return json_response(200, job_json(job)); }

Response encode_cancelled_job(const JobStatus& job) { return json_response(202, job_json(job)); }

}  // namespace distlab::server
