// Robots as data in the CBF loop: a rollout of assets/scenarios/ur5e_reach.json (the UR5e, 6
// joints) that reaches its target, and scenario input that does not fit its robot refused with
// the field named. (The UR5e's kinematics and the URDF subset: tests/robot/test_urdf.cpp.)
#include <cmath>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "distlab/server/cbf_json.hpp"
#include "panda.hpp"

namespace distlab::cbf {
namespace {

server::CbfRequest reach(const char* metric) {
  setenv("DISTLAB_ASSETS", DISTLAB_SOURCE_DIR "/assets", 1);
  return server::parse_cbf_request({{"scenario", "ur5e_reach"}, {"metric", metric}});
}

TEST(Ur5e, RolloutReachesItsTarget) {
  for (const char* metric : {"gap", "euclidean"}) {
    const server::CbfRequest req = reach(metric);
    ASSERT_EQ(req.scenario.robot->name(), "ur5e");
    const RolloutRecord r = rollout(req.scenario, req.metric, req.options);
    EXPECT_TRUE(r.reached) << metric << " ‖r‖ = " << r.final_task_error;
    EXPECT_LT(r.final_state.position_error, 1e-3) << metric;
    EXPECT_TRUE(r.infeasible_steps.empty()) << metric;
    EXPECT_GT(r.min_clearance, 0) << metric;
    EXPECT_EQ(r.steps.front().q.size(), 6);
    // Velocity limits of the URDF ("velocity_limit": "robot") hold at every step.
    for (const StepRecord& s : r.steps)
      for (int j = 0; j < 6; ++j) ASSERT_LE(std::abs(s.u[j]), M_PI) << metric;
    // Every distance row held: D ≥ δ − 1e-6 for the metric's own D.
    const Margins& m = req.scenario.margins(req.metric);
    for (const StepRecord& s : r.steps)
      for (std::size_t p = 0; p < s.pairs.size(); ++p)
        ASSERT_GE(s.pairs[p].distance, (r.pairs[p].self ? m.self : m.obstacle) - 1e-6)
            << metric << " " << r.pairs[p].name << " t = " << s.t;
  }
}

std::string field_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InvalidInput& e) {
    return e.field() + ": " + e.what();
  }
  return "accepted";
}

TEST(RobotUrdf, ScenarioFieldsFollowTheRobot) {
  setenv("DISTLAB_ASSETS", DISTLAB_SOURCE_DIR "/assets", 1);
  auto scenario = [](nlohmann::json j) { return [j] { server::parse_scenario(j, "scenario"); }; };
  nlohmann::json s = {{"robot", "ur5e"},
                      {"obstacles", nlohmann::json::array()},
                      {"target", {{"position", {0.3, 0, 0.4}}}},
                      {"q0", {0, -1, 1, -1, -1, 0}}};
  EXPECT_EQ(field_of(scenario(s)), "accepted");
  s["q0"] = {0, 0, 0, 0, 0, 0, 0};  // the Panda's 7
  EXPECT_EQ(field_of(scenario(s)).rfind("scenario.q0: ", 0), 0u);
  s["q0"] = {0, -1, 1, -1, -1, 7};  // beyond ±2π
  EXPECT_EQ(field_of(scenario(s)).rfind("scenario.q0[5]: ", 0), 0u);
  s["q0"] = {0, -1, 1, -1, -1, 0};
  s["velocity_limit"] = {1, 1, 1};
  EXPECT_EQ(field_of(scenario(s)).rfind("scenario.velocity_limit: ", 0), 0u);
  s.erase("velocity_limit");
  s["robot"] = "nowhere";
  EXPECT_EQ(field_of(scenario(s)).rfind("scenario.robot: ", 0), 0u);
  s["robot"] = "../robots/ur5e";
  EXPECT_EQ(field_of(scenario(s)).rfind("scenario.robot: ", 0), 0u);
  s["robot"] = 5;
  EXPECT_EQ(field_of(scenario(s)).rfind("scenario.robot: ", 0), 0u);
}

}  // namespace
}  // namespace distlab::cbf
