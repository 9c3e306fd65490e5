// The core's routes, one row each: health, version, the OpenAPI document, limits, the session and
// its jobs. The handlers below the table know the caller and never the request (core_codec.hpp).
#include <mutex>

#include "core_codec.hpp"
#include "distlab/server/service.hpp"

namespace distlab::server {

void Service::register_core_routes() {
  add_routes<Service>(router_, *this, config_.limits,
                      {
                          {"GET", "/api/health", Work::light, {}, codec(decode_nothing, &Service::health, encode_health)},
                          {"GET", "/api/version", Work::light, {}, codec(decode_nothing, &Service::version, encode_version)},
                          {"GET", "/api/openapi.json", Work::light, {}, codec(decode_nothing, &Service::published_limits, encode_openapi)},
                          {"GET", "/api/limits", Work::light, {}, codec(decode_nothing, &Service::published_limits, encode_limits)},
                          {"POST", "/api/session", Work::light, {}, codec(decode_nothing, &Service::create_session, encode_new_session)},
                          {"GET", "/api/session", Work::light, {}, codec(decode_nothing, &Service::session_summary, encode_session)},
                          {"DELETE", "/api/session", Work::light, {}, codec(decode_nothing, &Service::end_session, encode_no_content)},
                          {"GET", "/api/jobs", Work::light, {}, codec(decode_nothing, &Service::session_jobs, encode_jobs)},
                          {"GET", "/api/jobs/{id}", Work::light, {}, codec(decode_job_ref, &Service::job, encode_job)},
                          {"POST", "/api/jobs/{id}/cancel", Work::light, {}, codec(decode_job_ref, &Service::cancel_job, encode_cancelled_job)},
                      });
}

Nothing Service::health(const Nothing& /*in*/, const Caller& /*caller*/) { return {}; }

VersionInfo Service::version(const Nothing& /*in*/, const Caller& /*caller*/) {
  VersionInfo v;
  for (const auto& m : modules_) v.modules.push_back(m->name());
  return v;
}

LimitSources Service::published_limits(const Nothing& /*in*/, const Caller& /*caller*/) { return limit_sources(); }

LimitSources Service::limit_sources() const {
  LimitSources sources{config_.limits, {}, {}};
  for (const auto& m : modules_) sources.modules.push_back(m.get());
  for (const Route& r : router_.routes())
    if (r.heavy) sources.request_bounds.emplace_back(r.method + " " + r.pattern, r.bounds);
  return sources;
}

nlohmann::json Service::limits_json() const { return server::limits_json(limit_sources()); }

SessionId Service::create_session(const Nothing& /*in*/, const Caller& caller) { return {sessions_.create(caller.address)->id}; }

SessionSummary Service::session_summary(const Nothing& /*in*/, const Caller& caller) {
  SessionSummary summary;
  summary.session = require_session(caller.session_id);
  {
    std::lock_guard lock(summary.session->mutex);
    summary.sockets = summary.session->sockets.size();
  }
  summary.jobs = jobs_.list(summary.session->id).size();
  for (const auto& m : modules_) summary.modules.push_back(m.get());
  return summary;
}

Nothing Service::end_session(const Nothing& /*in*/, const Caller& caller) {
  auto s = require_session(caller.session_id);
  jobs_.cancel_session(s->id);
  sessions_.erase(s->id);
  return {};
}

std::vector<JobStatus> Service::session_jobs(const Nothing& /*in*/, const Caller& caller) {
  auto s = require_session(caller.session_id);
  std::vector<JobStatus> list;
  for (const auto& j : jobs_.list(s->id)) list.push_back(j->status());
  return list;
}

std::shared_ptr<Job> Service::find_job(const JobRef& ref, const Caller& caller) {
  auto s = require_session(caller.session_id);
  auto j = jobs_.find(s->id, ref.id);
  if (!j) throw ApiError(404, "unknown_job", "no such job in this session");
  return j;
}

JobStatus Service::job(const JobRef& ref, const Caller& caller) { return find_job(ref, caller)->status(); }

JobStatus Service::cancel_job(const JobRef& ref, const Caller& caller) {
  auto j = find_job(ref, caller);
  j->cancel = true;
  return j->status();
}

}  // namespace distlab::server
