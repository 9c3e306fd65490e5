#pragma once
// The codec of the CBF routes (routes_cbf.cpp): decode reads a request into a typed input and is
// the one place that checks it (the scenario and request through cbf_json.hpp, which the CLI and
// Python share); encode writes a handler's typed result as the answer (route_table.hpp). A decode
// that reads scenarios or robots by name also gets the server's assets directory.
#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cbf_field_service.hpp"
#include "distlab/server/cbf_json.hpp"
#include "distlab/server/cbf_rollouts.hpp"
#include "distlab/server/config.hpp"
#include "distlab/server/http.hpp"
#include "distlab/server/jobs.hpp"

namespace distlab::server {

// GET /api/cbf/scenarios: the scenario files' names, sorted, and the rollout limits.
struct CbfScenarioList {
  std::vector<std::string> names;
  Limits limits;
};
Response encode_scenarios(const CbfScenarioList& list);

// GET /api/cbf/scenarios/{name}: a valid name; the handler finds its file.
struct CbfScenarioName {
  std::string name;
};
CbfScenarioName decode_scenario_name(const Request& req, const Limits& limits);
struct CbfScenarioFile {
  std::string path;
};
Response encode_scenario_file(const CbfScenarioFile& file);  // a broken file is the server's fault (500)

// GET /api/cbf/robot?name= (default panda).
struct CbfRobotName {
  std::string name;
};
CbfRobotName decode_robot_name(const Request& req, const Limits& limits);
struct CbfRobotDescription {
  std::shared_ptr<const cbf::Robot> robot;
};
Response encode_robot(const CbfRobotDescription& robot);

// POST /api/cbf/feasibility: the request planned (its fields within the budget) and its pairs
// within the scan's pair-steps.
struct CbfPlannedRequest {
  CbfRequest request;
  FieldPlan plan;
};
CbfPlannedRequest decode_feasibility(const Request& req, const Limits& limits, const std::string& assets_dir);
struct CbfFeasibilityAnswer {
  cbf::Feasibility feasibility;
  cbf::Scenario scenario;
};
Response encode_feasibility_answer(const CbfFeasibilityAnswer& answer);

// POST /api/cbf/rollouts: the rollout as the request describes it (no id, session or job yet),
// its planned fields and the controller's options.
struct CbfRolloutRequest {
  std::shared_ptr<CbfRollout> rollout;
  std::shared_ptr<const FieldPlan> plan;
  cbf::RolloutOptions options;
};
CbfRolloutRequest decode_rollout(const Request& req, const Limits& limits, const std::string& assets_dir);
// A rollout and its job (POST: 202; GET .../{id}: 200 with the job when the session still has it).
struct CbfRolloutStatus {
  std::shared_ptr<const CbfRollout> rollout;
  std::shared_ptr<Job> job;
};
Response encode_rollout_started(const CbfRolloutStatus& started);
Response encode_rollout_status(const CbfRolloutStatus& status);
struct CbfRolloutList {
  std::vector<std::shared_ptr<const CbfRollout>> rollouts;
};
Response encode_rollouts(const CbfRolloutList& list);
// The job's parameters and result (GET /api/jobs/{id}).
nlohmann::json rollout_job_params(const CbfRollout& rollout);
nlohmann::json rollout_job_result(const CbfRollout& rollout, const cbf::RolloutRecord& record);

// {id} of /api/cbf/rollouts/{id}/... and /api/cbf/sweeps/{id}.
struct CbfRolloutId {
  std::string id;
};
CbfRolloutId decode_rollout_id(const Request& req, const Limits& limits);

// GET .../frames?from=&count= (at most max_cbf_frames_per_request: 413 too_many_frames).
struct CbfFramesRequest {
  std::string id;
  std::size_t from = 0, count = 0;
};
CbfFramesRequest decode_frames(const Request& req, const Limits& limits);
struct CbfFrames {
  std::shared_ptr<const CbfRollout> rollout;
  std::size_t from = 0, count = 0;
};
Response encode_frames(const CbfFrames& frames);

// GET .../record: the record of an ended rollout.
struct CbfRecord {
  std::shared_ptr<const cbf::RolloutRecord> record;
  std::string scenario_name;
  bool with_pairs = true;
  bool cancelled = false;  // the steps of a cancelled rollout
};
Response encode_rollout_record(const CbfRecord& record);

// GET .../fields?levels=A,B (at most max_levels: 413 too_many_levels).
struct CbfFieldsRequest {
  std::string id;
  std::optional<std::vector<double>> levels;
};
CbfFieldsRequest decode_fields(const Request& req, const Limits& limits);
Response encode_fields_frame(const CbfFieldSurfaces& fields);  // msgpack

// POST /api/cbf/sweeps: every run planned and within the steps and pair-steps of a rollout.
struct CbfSweepRequest {
  std::shared_ptr<CbfSweep> sweep;  // its runs' fields are prepared in the job
  std::shared_ptr<const std::vector<FieldPlan>> plans;
};
CbfSweepRequest decode_sweep(const Request& req, const Limits& limits, const std::string& assets_dir);

// A sweep (one job): the runs' entries as they finish, so a cancelled sweep still shows the runs
// it completed. Owner only, like rollouts.
struct CbfSweepRun {
  std::string id, session;
  std::shared_ptr<const CbfSweep> sweep;
  mutable std::mutex mutex;
  std::vector<nlohmann::json> entries;  // in the sweep's order
};
struct CbfSweepStatus {
  std::shared_ptr<const CbfSweepRun> sweep;
  std::shared_ptr<Job> job;
};
Response encode_sweep_started(const CbfSweepStatus& started);  // 202
Response encode_sweep_status(const CbfSweepStatus& status);    // the job without its result
// The job's parameters {"parameter"}, and its result: the sweep's head {"scenario", "metric",
// "parameter", "values"} and its "entries" so far.
nlohmann::json sweep_job_params(const CbfSweep& sweep);
nlohmann::json sweep_head(const CbfSweep& sweep);
nlohmann::json sweep_job_result(const CbfSweepRun& run);

}  // namespace distlab::server
