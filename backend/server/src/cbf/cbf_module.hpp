#pragma once
// The CBF feature as a module of the service: scenarios, robots and rollouts (routes_cbf.cpp), the
// rollouts kept per session (cbf_rollouts.hpp), their Kelvin fields (cbf_field_service.hpp), and
// the WebSocket message "cbf_replay".
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cbf_codec.hpp"
#include "cbf_field_service.hpp"
#include "distlab/server/cbf_json.hpp"
#include "distlab/server/cbf_rollouts.hpp"
#include "distlab/server/module.hpp"

namespace distlab::server {

// The sweeps of every session, the oldest forgotten past cbf_rollouts_kept_total.
class CbfSweepStore {
 public:
  explicit CbfSweepStore(std::size_t kept) : kept_(kept) {}
  void add(std::shared_ptr<CbfSweepRun> s);
  std::shared_ptr<CbfSweepRun> find(const std::string& session, const std::string& id) const;  // owner only

 private:
  std::size_t kept_;
  mutable std::mutex mutex_;
  std::vector<std::shared_ptr<CbfSweepRun>> sweeps_;
};

class CbfModule final : public Module {
 public:
  using Module::Module;
  std::string name() const override { return "cbf"; }
  void register_routes() override;
  std::vector<std::string> ws_types() const override { return {"cbf_replay"}; }
  void ws_message(const std::shared_ptr<Session>& session, const std::shared_ptr<WsSink>& socket,
                  const nlohmann::json& msg, const nlohmann::json& /*request*/) override {
    cbf_ws_message(session, socket, msg);
  }

 private:
  // The routes' handlers (routes_cbf.cpp; the jobs' in cbf_jobs.cpp).
  CbfScenarioList scenarios(const Nothing& in, const Caller& caller);
  CbfScenarioFile scenario(const CbfScenarioName& in, const Caller& caller);
  CbfRobotDescription robot(const CbfRobotName& in, const Caller& caller);
  CbfFeasibilityAnswer feasibility(const CbfPlannedRequest& in, const Caller& caller);
  CbfRolloutStatus start_rollout(const CbfRolloutRequest& in, const Caller& caller);
  CbfRolloutList rollouts(const Nothing& in, const Caller& caller);
  CbfRolloutStatus rollout(const CbfRolloutId& in, const Caller& caller);
  CbfFrames frames(const CbfFramesRequest& in, const Caller& caller);
  CbfRecord record(const CbfRolloutId& in, const Caller& caller);
  CbfFieldSurfaces fields(const CbfFieldsRequest& in, const Caller& caller);
  CbfSweepStatus start_sweep(const CbfSweepRequest& in, const Caller& caller);
  CbfSweepStatus sweep(const CbfRolloutId& in, const Caller& caller);

  // The caller's rollout `id` (404 unknown_rollout).
  std::shared_ptr<CbfRollout> require_rollout(const std::string& id, const Caller& caller);

  void cbf_ws_message(const std::shared_ptr<Session>& session, const std::shared_ptr<WsSink>& socket,
                      const nlohmann::json& msg);

  // A scenario's Kelvin fields (cbf_field_service.hpp) for a planned request: held ones shared,
  // the others prepared in the service's cache directory; progress reports their stages.
  void prepare_fields(cbf::Scenario& scenario, const FieldPlan& plan, const Progress& progress,
                      std::map<std::string, cbf::SceneField>& prepared);

  std::shared_ptr<CbfRolloutStore> cbf_rollouts_;
  std::shared_ptr<CbfSweepStore> sweeps_;
  SharedFields shared_fields_;
};

}  // namespace distlab::server
