#pragma once
// The CBF feature as a module of the service: scenarios, robots and rollouts (routes_cbf.cpp), the
// rollouts kept per session (cbf_rollouts.hpp), their Kelvin fields (cbf_field_service.hpp), and
// the WebSocket message "cbf_replay".
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cbf_field_service.hpp"
#include "distlab/server/cbf_json.hpp"
#include "distlab/server/cbf_rollouts.hpp"
#include "distlab/server/module.hpp"

namespace distlab::server {

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
  // The rollout limits (also in GET /api/cbf/scenarios).
  void add_limits(nlohmann::json& limits) const override {
    const CbfLimits& cbf = cbf_rollouts_->limits();
    limits["max_cbf_steps"] = cbf.max_steps;
    limits["max_cbf_duration"] = kMaxScenarioDuration;
    limits["max_cbf_pair_steps"] = cbf.max_pair_steps;
    limits["max_cbf_batch_steps"] = cbf.max_batch_steps;
    limits["max_cbf_frames_per_request"] = cbf.max_frames_per_request;
    limits["cbf_rollouts_kept_per_session"] = cbf.kept_per_session;
    limits["cbf_rollouts_kept_total"] = cbf.kept_total;
    limits["max_cbf_sweep_values"] = cbf.max_sweep_values;
    limits["cbf_fields_kept_total"] = cbf.fields_kept_total;
    limits["max_cbf_fields"] = cbf::kMaxSceneFields;
    limits["max_cbf_control_points"] = cbf::kMaxControlPoints;
  }

 private:
  void cbf_ws_message(const std::shared_ptr<Session>& session, const std::shared_ptr<WsSink>& socket,
                      const nlohmann::json& msg);

  // A scenario's Kelvin fields (cbf_field_service.hpp) for a planned request: held ones shared,
  // the others prepared in the service's cache directory; progress reports their stages.
  void prepare_fields(cbf::Scenario& scenario, const FieldPlan& plan, const Progress& progress,
                      std::map<std::string, cbf::SceneField>& prepared);

  std::shared_ptr<CbfRolloutStore> cbf_rollouts_;
  SharedFields shared_fields_;
};

}  // namespace distlab::server
