// Robots as data: a second arm, the UR5e (assets/robots/ur5e.urdf, 6 joints, from Universal
// Robots' published DH parameters), through the same code as the Panda: its zero pose against
// the published DH facts, Jacobians against central differences, the self-collision pairs from
// the tree, a rollout of assets/scenarios/ur5e_reach.json that reaches its target; and URDF or
// scenario input outside the supported subset refused with the field named.
#include <cmath>
#include <fstream>
#include <random>
#include <sstream>

#include <gtest/gtest.h>

#include "distlab/server/cbf_json.hpp"
#include "panda.hpp"

namespace distlab::cbf {
namespace {

std::shared_ptr<const Robot> ur5e() {
  return Robot::load(std::string(DISTLAB_SOURCE_DIR) + "/assets/robots/ur5e.urdf");
}

TEST(Ur5e, ZeroPoseMatchesThePublishedDh) {
  const Robot& robot = *ur5e();
  ASSERT_EQ(robot.dof(), 6);
  EXPECT_EQ(robot.joint_names().front(), "shoulder_pan");
  const Kinematics k = robot.forward(VecQ::Zero(6));
  // Standard DH at q = 0: flange at (a2 + a3, −(d4 + d6), d1 − d5), its z axis along −y.
  EXPECT_LT((k.ee.position - Vec3(-0.425 - 0.3922, -(0.1333 + 0.0996), 0.1625 - 0.0997)).norm(), 1e-12);
  EXPECT_LT((k.ee_R.col(2) - Vec3(0, -1, 0)).norm(), 1e-12);
  // Elbow and wrist 1 by hand: the arm lies along −x at the shoulder's height d1.
  EXPECT_LT((k.frames[robot.link_index("ur5e_link2")].position - Vec3(-0.425, 0, 0.1625)).norm(), 1e-12);
  EXPECT_LT((k.frames[robot.link_index("ur5e_link4")].position - Vec3(-0.8172, -0.1333, 0.1625)).norm(), 1e-12);
  // A rotation of the base joint turns the flange about z.
  VecQ q = VecQ::Zero(6);
  q[0] = 0.5 * M_PI;
  EXPECT_LT((robot.forward(q).ee.position - Vec3(0.2329, -0.8172, 0.0628)).norm(), 1e-12);
  for (int i = 0; i < 6; ++i) {
    EXPECT_DOUBLE_EQ(robot.q_max()[i], 2 * M_PI);
    EXPECT_DOUBLE_EQ(robot.velocity_max()[i], M_PI);
  }
}

TEST(Ur5e, JacobiansMatchCentralDifferences) {
  const Robot& robot = *ur5e();
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> U(-M_PI, M_PI);
  for (int trial = 0; trial < 20; ++trial) {
    VecQ q(6);
    for (int i = 0; i < 6; ++i) q[i] = U(rng);
    // Every link, the flange (the end effector, ur5e_link6) included.
    for (int link = 0; link < static_cast<int>(robot.links().size()); ++link)
      test::expect_jacobian_matches_differences(robot, q, link, Vec3(0.05, -0.1, 0.07));
  }
}

TEST(Ur5e, ModelFromTheTree) {
  const Robot& robot = *ur5e();
  ASSERT_EQ(robot.primitives().size(), 6u);  // one per moving link
  // Links two or more revolute joints apart: 4 + 3 + 2 + 1 = 10 pairs out of 15.
  EXPECT_EQ(robot.self_pairs().size(), 10u);
  EXPECT_TRUE(std::holds_alternative<Capsule>(robot.primitives().back().shape));  // distlab:capsule
  EXPECT_EQ(std::get<Capsule>(robot.primitives().back().shape).height, 0.05);
}

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

TEST(RobotUrdf, InputOutsideTheSubsetIsRefusedNamingIt) {
  const std::string head = R"(<robot name="r" xmlns:distlab="x"><link name="a"/><link name="b">)";
  const std::string joint =
      R"(<joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>)"
      R"(<limit lower="-1" upper="1" velocity="1" effort="1"/></joint>)";
  auto parse = [](const std::string& xml) { return [xml] { Robot::from_urdf(xml, "robot"); }; };
  const std::string ok = head + R"(<collision name="c"><geometry><sphere radius="0.1"/></geometry></collision></link>)" + joint + "</robot>";
  EXPECT_EQ(field_of(parse(ok)), "accepted");
  EXPECT_NE(field_of(parse(head + "</link>" + R"(<joint name="j" type="prismatic"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" velocity="1" effort="1"/></joint></robot>)")).find("only revolute and fixed"), std::string::npos);
  EXPECT_NE(field_of(parse(head + R"(<collision><geometry><sphere radius="0.1"/></geometry></collision></link>)" + joint + "</robot>")).find("needs a name"), std::string::npos);
  EXPECT_NE(field_of(parse(head + R"(<collision name="c"><geometry><mesh filename="x.stl"/></geometry></collision></link>)" + joint + "</robot>")).find("only box, cylinder"), std::string::npos);
  EXPECT_NE(field_of(parse(head + R"(<collision name="c"><origin rpy="0 0 1" distlab:quaternion="1 0 0 0"/><geometry><sphere radius="0.1"/></geometry></collision></link>)" + joint + "</robot>")).find("different rotations"), std::string::npos);
  EXPECT_NE(field_of(parse(head + R"(<collision name="c" distlab:capsule="yes"><geometry><cylinder radius="0.1" length="0.2"/></geometry></collision></link>)" + joint + "</robot>")).find("distlab:capsule"), std::string::npos);
  // Two roots: urdfdom itself refuses the tree.
  EXPECT_EQ(field_of(parse(head + "</link><link name=\"c\"/>" + joint + "</robot>")), "robot: robot URDF: urdfdom cannot parse it");
  EXPECT_NE(field_of(parse("<robot name=\"r\"><link name=\"a\"/></robot>")).find("at least one revolute joint"), std::string::npos);
  EXPECT_NE(field_of(parse("not xml")).find("robot: "), std::string::npos);
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
