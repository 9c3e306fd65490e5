#pragma once
// The CBF feature as a module of the service: scenarios, robots and rollouts (routes_cbf.cpp), the
// rollouts kept per session (cbf_rollouts.hpp), and the WebSocket message "cbf_replay".
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

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
  }

 private:
  void cbf_ws_message(const std::shared_ptr<Session>& session, const std::shared_ptr<WsSink>& socket,
                      const nlohmann::json& msg);

  std::shared_ptr<CbfRolloutStore> cbf_rollouts_;
};

}  // namespace distlab::server
