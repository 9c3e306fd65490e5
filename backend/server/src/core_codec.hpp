#pragma once
// The core's routes as data (core_routes.cpp): what each handler returns, and the codec that reads
// the requests (decode_*) and writes the answers (encode_*).
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "distlab/server/config.hpp"
#include "distlab/server/http.hpp"
#include "distlab/server/jobs.hpp"
#include "distlab/server/module.hpp"
#include "distlab/server/session.hpp"

namespace distlab::server {

struct VersionInfo {
  std::vector<std::string> modules;  // the features' names, in the order they were added
};

// What GET /api/limits lists: the table, the limits the modules own, and the limits that bound each
// synchronous heavy route ("METHOD PATTERN" -> names).
struct LimitSources {
  const Limits& table;
  std::vector<const Module*> modules;
  std::vector<std::pair<std::string, std::vector<std::string>>> request_bounds;
};
nlohmann::json limits_json(const LimitSources& sources);

struct SessionId {
  std::string id;
};

// GET /api/session: the session, its sockets and jobs, and the modules that add their fields.
struct SessionSummary {
  std::shared_ptr<Session> session;
  std::size_t sockets = 0;
  std::size_t jobs = 0;
  std::vector<Module*> modules;
};

struct JobRef {
  std::string id;  // {id} of the path
};

JobRef decode_job_ref(const Request& request, const Limits& limits);

Response encode_health(const Nothing& nothing);
Response encode_version(const VersionInfo& version);
Response encode_openapi(const LimitSources& sources);
Response encode_limits(const LimitSources& sources);
Response encode_new_session(const SessionId& session);
Response encode_session(const SessionSummary& summary);
Response encode_jobs(const std::vector<JobStatus>& jobs);
Response encode_job(const JobStatus& job);
Response encode_cancelled_job(const JobStatus& job);  // 202: the cancel is asked, the job ends soon

}  // namespace distlab::server
