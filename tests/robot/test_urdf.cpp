// Robots as data: a second arm, the UR5e (assets/robots/ur5e.urdf, 6 joints, from Universal
// Robots' published DH parameters), through the same code as the Panda: its zero pose against
// the published DH facts, Jacobians against central differences, the self-collision pairs from
// the tree; and URDF input outside the supported subset refused with the field named. (Meshes
// and the other joint types: test_mesh_urdf.cpp.)
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <utility>

#include <gtest/gtest.h>

#include "robot_test_util.hpp"

namespace distlab::robot {
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

TEST(RobotUrdf, InputOutsideTheSubsetIsRefusedNamingIt) {
  using test::field_of;
  const std::string head = R"(<robot name="r" xmlns:distlab="x"><link name="a"/><link name="b">)";
  const std::string joint =
      R"(<joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>)"
      R"(<limit lower="-1" upper="1" velocity="1" effort="1"/></joint>)";
  auto parse = [](const std::string& xml) { return [xml] { Robot::from_urdf(xml, "robot"); }; };
  const std::string ok = head + R"(<collision name="c"><geometry><sphere radius="0.1"/></geometry></collision></link>)" + joint + "</robot>";
  EXPECT_EQ(field_of(parse(ok)), "accepted");
  // A collision element without a name is named after its link and position.
  const auto unnamed = Robot::from_urdf(head + R"(<collision><geometry><sphere radius="0.1"/></geometry></collision></link>)" + joint + "</robot>");
  EXPECT_EQ(unnamed->primitives().at(0).name, "b/collision[0]");
  // A revolute joint without <limit> (urdfdom refuses it), one whose <limit> has no lower and
  // upper (unbounded, with a warning), a prismatic one with lower >= upper.
  EXPECT_NE(field_of(parse(head + "</link>" + R"(<joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/></joint></robot>)")), "accepted");
  const auto unbounded = Robot::from_urdf(head + "</link>" + R"(<joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/><limit effort="1" velocity="2"/></joint></robot>)");
  EXPECT_EQ(unbounded->q_min()[0], -std::numeric_limits<double>::infinity());
  EXPECT_EQ(unbounded->q_max()[0], std::numeric_limits<double>::infinity());
  EXPECT_EQ(unbounded->velocity_max()[0], 2);
  ASSERT_EQ(unbounded->warnings().size(), 1u);
  EXPECT_NE(unbounded->warnings()[0].find("joint \"j\""), std::string::npos) << unbounded->warnings()[0];
  EXPECT_NE(field_of(parse(head + "</link>" + R"(<joint name="j" type="prismatic"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/><limit lower="1" upper="1" velocity="1" effort="1"/></joint></robot>)")).find("joint \"j\" limit lower must be < upper"), std::string::npos);
  EXPECT_NE(field_of(parse(head + R"(<collision name="c"><origin rpy="0 0 1" distlab:quaternion="1 0 0 0"/><geometry><sphere radius="0.1"/></geometry></collision></link>)" + joint + "</robot>")).find("different rotations"), std::string::npos);
  EXPECT_NE(field_of(parse(head + R"(<collision name="c" distlab:capsule="yes"><geometry><cylinder radius="0.1" length="0.2"/></geometry></collision></link>)" + joint + "</robot>")).find("distlab:capsule"), std::string::npos);
  // A geometry urdfdom cannot read (it drops it) is refused naming the attribute at fault.
  for (const auto& [geometry, says] : std::vector<std::pair<std::string, std::string>>{
           {R"(<box size="0.1 nan 0.1"/>)", "<box> size: numbers must be finite"},
           {R"(<box size="0.1 0.1"/>)", "<box> size: expected 3 numbers"},
           {R"(<cylinder radius="0.1"/>)", "<cylinder> has no length"},
           {R"(<sphere radius="inf"/>)", "<sphere> radius: numbers must be finite"},
           {R"(<mesh filename="m.stl" scale="1 1 nan"/>)", "<mesh> scale: numbers must be finite"},
           {R"(<cone radius="0.1"/>)", "<cone> is not a URDF geometry"},
           {"", "no geometry"}}) {
    const std::string refused = field_of(parse(head + R"(<collision name="c"><geometry>)" + geometry + "</geometry></collision></link>" + joint + "</robot>"));
    EXPECT_NE(refused.find("collision[0] \"c\" of link \"b\": " + says), std::string::npos) << geometry << ": " << refused;
  }
  // Two roots: urdfdom itself refuses the tree.
  // The tree is checked before urdfdom (which leaks a ring of links on a cycle): two roots, a
  // cycle, a link defined twice.
  EXPECT_NE(field_of(parse(head + "</link><link name=\"c\"/>" + joint + "</robot>")).find("both have no parent"), std::string::npos);
  const std::string ring = R"(<robot name="r"><link name="a"/><link name="b"/>)"
                           R"(<joint name="j1" type="fixed"><parent link="a"/><child link="b"/></joint>)"
                           R"(<joint name="j2" type="fixed"><parent link="b"/><child link="a"/></joint></robot>)";
  EXPECT_NE(field_of(parse(ring)).find("form a cycle"), std::string::npos) << field_of(parse(ring));
  EXPECT_NE(field_of(parse(R"(<robot name="r"><link name="a"/><link name="a"/></robot>)")).find("defined twice"), std::string::npos);
  // urdfdom's own reason (console_bridge's error log) is in the message, not on stderr.
  const std::string bad_origin = field_of(parse(head + "</link>" + R"(<joint name="j" type="fixed"><origin xyz="1 2"/><parent link="a"/><child link="b"/></joint></robot>)"));
  EXPECT_EQ(bad_origin.rfind("robot: robot URDF: urdfdom cannot parse it: ", 0), 0u) << bad_origin;
  EXPECT_GT(bad_origin.size(), std::string("robot: robot URDF: urdfdom cannot parse it: ").size()) << bad_origin;
  // No moving joint: a rigid body.
  const auto rigid = Robot::from_urdf(R"(<robot name="r"><link name="a"><collision><geometry><sphere radius="0.1"/></geometry></collision></link></robot>)");
  EXPECT_EQ(rigid->dof(), 0);
  EXPECT_EQ(rigid->primitives().size(), 1u);
  EXPECT_TRUE(rigid->self_pairs().empty());
  EXPECT_EQ(rigid->forward(VecQ()).frames.size(), 1u);
  EXPECT_NE(field_of(parse("not xml")).find("robot: "), std::string::npos);
}

// Text an XML parser cannot take is refused before one reads it (TinyXML recurses per level and
// scans an element's attributes per attribute: 100 000 levels overflow its stack), naming the
// caller's field; the built-in robots pass the same scan.
TEST(RobotUrdf, HostileTextIsRefusedBeforeParsing) {
  using test::field_of;
  auto parse = [](const std::string& xml) { return [xml] { Robot::from_urdf(xml, "robot.urdf"); }; };
  std::string deep = R"(<robot name="r">)", wide = R"(<robot name="r"><link name="l" )";
  for (int i = 0; i < 100000; ++i) deep += "<a>";
  for (int i = 0; i < 100000; ++i) deep += "</a>";
  for (int i = 0; i < 70000; ++i) wide += R"(a="" )";
  const std::pair<std::string, std::string> cases[] = {
      {deep + "</robot>", "elements nest deeper than 64 (line 1)"},
      {wide + "/></robot>", "an element has more than 64 attributes (line 1)"},
      {R"(<robot name="r"><![CDATA[<a><a>]]></robot>)", "no DOCTYPE, no CDATA"},
      {"<!DOCTYPE r [<!ENTITY x \"y\">]>\n<robot name=\"r\"/>", "no DOCTYPE, no CDATA"},
      {"<robot\nname=r/>", "attribute values must be quoted (line 2)"},
      {R"(<robot name="r"><!-- <a>)", "a comment is not closed"},
  };
  for (const auto& [xml, what] : cases) {
    const std::string got = field_of(parse(xml));
    EXPECT_EQ(got.rfind("robot.urdf: robot URDF: ", 0), 0u) << got;
    EXPECT_NE(got.find(what), std::string::npos) << got;
  }
  // 64 levels (<robot> and 63 elements urdfdom ignores) are a description; 65 are refused.
  const auto nested = [](int levels) {
    std::string xml = R"(<robot name="r"><link name="a"/>)";
    for (int i = 1; i < levels; ++i) xml += "<x>";
    for (int i = 1; i < levels; ++i) xml += "</x>";
    return xml + "</robot>";
  };
  EXPECT_EQ(field_of(parse(nested(64))), "accepted");
  EXPECT_NE(field_of(parse(nested(65))).find("deeper than 64"), std::string::npos);
  for (const char* name : {"panda", "ur5e"})
    EXPECT_EQ(field_of([name] { Robot::from_file(std::string(DISTLAB_SOURCE_DIR) + "/assets/robots/" + name + ".urdf"); }), "accepted");
}

// The description limits are the caller's (UrdfOptions::limits; the server's come from its limits
// table): a description at a limit is accepted, one past it refused naming the limit, and the
// library's defaults take both.
TEST(RobotUrdf, DescriptionLimitsAreTheCallers) {
  using test::field_of;
  std::string xml = R"(<robot name="r"><link name="l0"><collision><geometry><sphere radius="0.1"/></geometry></collision>)"
                    R"(<collision><geometry><sphere radius="0.2"/></geometry></collision></link>)";
  for (int i = 1; i < 3; ++i)
    xml += "<link name=\"l" + std::to_string(i) + "\"/><joint name=\"j" + std::to_string(i) + "\" type=\"fixed\"><parent link=\"l" +
           std::to_string(i - 1) + "\"/><child link=\"l" + std::to_string(i) + "\"/></joint>";
  xml += "</robot>";  // 3 links, 2 joints, 2 collision elements
  auto parse = [&xml](DescriptionLimits limits) {
    UrdfOptions options;
    options.limits = limits;
    return field_of([&] { Robot::from_urdf(xml, "robot.urdf", options); });
  };
  EXPECT_EQ(parse({}), "accepted");
  EXPECT_EQ(parse({xml.size(), 3, 2, 2, kMaxMeshHullRows, kMaxMeshVertices}), "accepted");
  const std::pair<DescriptionLimits, std::string> cases[] = {
      {{xml.size() - 1, 3, 2, 2, kMaxMeshHullRows, kMaxMeshVertices}, "at most " + std::to_string(xml.size() - 1) + " bytes"},
      {{kMaxUrdfBytes, 2, 2, 2, kMaxMeshHullRows, kMaxMeshVertices}, "at most 2 links"},
      {{kMaxUrdfBytes, 3, 1, 2, kMaxMeshHullRows, kMaxMeshVertices}, "at most 1 joints"},
      {{kMaxUrdfBytes, 3, 2, 1, kMaxMeshHullRows, kMaxMeshVertices}, "at most 1 collision elements"},
  };
  for (const auto& [limits, what] : cases) {
    const std::string got = parse(limits);
    EXPECT_NE(got.find(what), std::string::npos) << got;
  }
}

// A mimic of a mimic: θ3 = m3 (m2 q + o2) + o3, by the joints' own matrices; a cycle of mimics.
TEST(RobotUrdf, MimicChainsAreFollowed) {
  std::string xml = R"(<robot name="chain"><link name="l0"/><link name="l1"/><link name="l2"/><link name="l3"/>)";
  const auto joint = [](const std::string& name, const std::string& parent, const std::string& child, const std::string& mimic) {
    return R"(<joint name=")" + name + R"(" type="revolute"><parent link=")" + parent + R"("/><child link=")" + child +
           R"("/><origin xyz="0.1 0 0.2" rpy="0.3 0 0"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/>)" +
           mimic + "</joint>";
  };
  xml += joint("j1", "l0", "l1", "") + joint("j2", "l1", "l2", R"(<mimic joint="j1" multiplier="2" offset="0.1"/>)") +
         joint("j3", "l2", "l3", R"(<mimic joint="j2" multiplier="-0.5" offset="0.3"/>)") + "</robot>";
  const auto robot = Robot::from_urdf(xml);
  ASSERT_EQ(robot->dof(), 1);
  for (const double q : {-1.0, 0.2, 2.5}) {
    const double theta[3] = {q, 2 * q + 0.1, -0.5 * (2 * q + 0.1) + 0.3};
    test::Mat4 T = test::Mat4::Identity();
    for (const double t : theta) T = T * test::origin(Vec3(0.1, 0, 0.2), Vec3(0.3, 0, 0)) * test::rotation(Vec3::UnitZ(), t);
    const Kinematics k = robot->forward(VecQ::Constant(1, q));
    const int l3 = robot->link_index("l3");
    EXPECT_LT((k.frames[l3].position - T.block<3, 1>(0, 3)).norm(), 1e-12) << q;
    EXPECT_LT((k.R[l3] - T.block<3, 3>(0, 0)).norm(), 1e-12) << q;
    test::expect_jacobian_matches_differences(*robot, VecQ::Constant(1, q), l3, Vec3(0.1, 0.2, 0.3));
  }
  std::string cycle = xml;
  cycle.replace(cycle.find(R"(<mimic joint="j1")"), 18, R"(<mimic joint="j3")");
  const std::string e = test::field_of([&] { Robot::from_urdf(cycle); });
  EXPECT_EQ(e.rfind("robot: ", 0), 0u) << e;
  EXPECT_NE(e.find("cycle"), std::string::npos) << e;
}

}  // namespace
}  // namespace distlab::robot
