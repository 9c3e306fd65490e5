// Every Jacobian distances() returns, dD/dq, against central differences of the distance it
// returns (issue 32: 1e-6 relative): the Panda and the mesh robot of mesh_robot.hpp (prismatic,
// continuous and mimic joints), both metrics, obstacle and self pairs, at random configurations
// and at pairs placed 1e-4 m from contact.
//
// Differences: each D solved cold (tracking off), central differences at steps h and h/2,
// Richardson-extrapolated (truncation O(h⁴)). GAP's D falls like a high power of the Euclidean
// distance d near contact, so its scale of variation is d: h = 1e-3 d (joint units; the Panda's
// points move at most ~1.2 m per radian), rounded down to a power of ten so that pairs share
// their differences. The Euclidean distance of shapes with unique nearest features varies on
// the shapes' own scale (curvature radii, edge lengths), not d: h = 1e-5.
//
// "Relative" is to |∂D/∂x| · |∂w/∂q_j|, the gradient of D in the shapes' positions times the
// speed of the nearest points w per unit joint velocity, summed over the pair's moving shapes
// and maximised over the joints (and at least ‖dD/dq‖∞): dD/dq_j = n · ∂w/∂q_j for the Euclidean
// distance, so this bounds it. Not |dD/dq_j| alone: where a pair's distance is stationary in the
// joints (a cylinder turning about its own axis, two links moved rigidly together, w moving
// across n) dD/dq cancels to ~1e-18 or to a small fraction of |∂w/∂q|, and the pose gradient's
// own accuracy is relative to |∂D/∂x| (FCL's nearest points are certified to a duality gap of
// 1e-14, their direction to ~1e-7: collision/euclidean_distance.cpp; on a cylinder–capsule pair
// dD/dq_1 = 4.2743130e-3 against the differences' converged 4.2743190e-3, a 1.4e-6 part of it,
// where |∂w/∂q_1| = 0.16).
#include <algorithm>
#include <cmath>
#include <map>
#include <random>

#include <gtest/gtest.h>

#include "mesh_robot.hpp"
#include "robot_test_util.hpp"

#include "distlab/gap/distance.hpp"
#include "distlab/gap/validator.hpp"
#include "distlab/robot/distances.hpp"

namespace distlab::robot {
namespace {

constexpr double kBound = 1e-6;  // relative, issue 32
constexpr double kNear = 1e-4;   // Euclidean distance of the near-contact pairs

DistanceBatch at(const DistanceModel& model, const VecQ& q) {
  BatchOptions cold;
  cold.threads = 1;
  cold.tracking = false;
  return distances(model, std::span<const double>(q.data(), static_cast<std::size_t>(q.size())), 1, cold);
}

// The Euclidean distance of every pair at q (the GAP steps' scale).
std::vector<double> clearances(const DistanceModel& model, const VecQ& q) {
  const Robot& robot = model.robot();
  const Kinematics k = robot.forward(q);
  std::vector<double> out;
  for (const RobotPair& p : model.pairs()) {
    const Pose pa = robot.primitive_pose(k, p.a);
    const Pose pb = p.self ? robot.primitive_pose(k, p.b) : model.obstacles()[p.b].pose;
    const EuclideanShape& b = p.self ? model.robot_shape(p.b) : model.obstacle_shape(p.b);
    out.push_back(euclidean_distance(model.robot_shape(p.a), pa, b, pb).distance);
  }
  return out;
}

// Per pair, |∂D/∂x| · |∂w/∂q| (above): the pose gradient of D from gap_distance of bodies built
// as DistanceModel documents or from FCL, the nearest points from FCL.
std::vector<double> term_scales(const DistanceModel& model, const VecQ& q) {
  const Robot& robot = model.robot();
  const Kinematics k = robot.forward(q);
  const GapParams& params = model.params();
  const auto& prims = robot.primitives();
  const DistanceModel::Workspace bodies = model.workspace();  // an element's own h included
  std::vector<double> out;
  for (const RobotPair& p : model.pairs()) {
    const Pose pa = robot.primitive_pose(k, p.a);
    const Pose pb = p.self ? robot.primitive_pose(k, p.b) : model.obstacles()[p.b].pose;
    const EuclideanShape& eb = p.self ? model.robot_shape(p.b) : model.obstacle_shape(p.b);
    const EuclideanResult e = euclidean_distance(model.robot_shape(p.a), pa, eb, pb);
    Vec6 ga = e.gradient_a, gb = e.gradient_b;
    if (model.metric() == Metric::gap) {
      GapBody A = bodies.robot_gap[p.a], B = p.self ? bodies.robot_gap[p.b] : model.obstacle_body(p.b);
      A.set_pose(pa);
      B.set_pose(pb);
      const GapResult r = gap_distance(A, B, params);
      ga = r.gradient_a, gb = r.gradient_b;
    }
    const Jac Ja = robot.point_jacobian(k, prims[p.a].link, e.witness_a);
    const Jac Jb = p.self ? robot.point_jacobian(k, prims[p.b].link, e.witness_b) : Jac::Zero(6, robot.dof());
    double scale = 0;
    for (int j = 0; j < robot.dof(); ++j)
      scale = std::max(scale, ga.head<3>().norm() * Ja.col(j).head<3>().norm() + gb.head<3>().norm() * Jb.col(j).head<3>().norm());
    out.push_back(scale);
  }
  return out;
}

struct Checked {
  int pairs = 0, near = 0;
  double worst = 0;        // of error / (kBound · scale)
  double worst_plain = 0;  // of error / ‖dD/dq‖∞ (reported, not asserted)
  double widest = 0;       // of scale / ‖dD/dq‖∞
};

// ‖FD − ∇D‖∞ ≤ kBound · |∂D/∂x| · |∂w/∂q| (above) for every pair at q; overlapping pairs (D = 0, ∇D = 0) are refused
// by the callers' choice of q.
void expect_gradients_match_differences(const DistanceModel& model, const VecQ& q, const std::string& tag,
                                        Checked& checked) {
  const int dof = model.dof(), np = static_cast<int>(model.pairs().size());
  const DistanceBatch b = at(model, q);
  const std::vector<double> d = clearances(model, q), terms = term_scales(model, q);
  // Pairs grouped by step.
  std::map<double, std::vector<int>> by_step;
  for (int p = 0; p < np; ++p) {
    ASSERT_FALSE(b.overlap[p]) << tag << " " << model.pairs()[p].name;
    ASSERT_GT(d[p], 0.5 * kNear) << tag << " " << model.pairs()[p].name;
    const double h = model.metric() == Metric::gap ? std::pow(10.0, std::floor(std::log10(1e-3 * d[p]))) : 1e-5;
    by_step[h].push_back(p);
  }
  for (const auto& [h, pairs] : by_step) {
    Eigen::MatrixXd fd(np, dof);
    for (int j = 0; j < dof; ++j) {
      const auto central = [&](double s) {
        VecQ qp = q, qm = q;
        qp[j] += s;
        qm[j] -= s;
        const DistanceBatch bp = at(model, qp), bm = at(model, qm);
        Eigen::VectorXd c(np);
        for (int p = 0; p < np; ++p) c[p] = (bp.distance[p] - bm.distance[p]) / (2 * s);
        return c;
      };
      fd.col(j) = (4 * central(h / 2) - central(h)) / 3;
    }
    for (int p : pairs) {
      const Eigen::Map<const Eigen::RowVectorXd> g(&b.jacobian[static_cast<std::size_t>(p) * dof], dof);
      const double scale = std::max(terms[p], g.cwiseAbs().maxCoeff()), error = (fd.row(p) - g).cwiseAbs().maxCoeff();
      EXPECT_LE(error, kBound * scale) << tag << " " << to_string(model.metric()) << " " << model.pairs()[p].name
                                       << ": D " << b.distance[p] << ", d " << d[p] << ", step " << h << ", scale " << scale
                                       << "\n  gradient " << g << "\n  differences " << fd.row(p);
      EXPECT_GT(scale, 0) << tag << " " << model.pairs()[p].name;
      ++checked.pairs;
      checked.worst = std::max(checked.worst, error / (kBound * scale));
      if (g.cwiseAbs().maxCoeff() > 0) {
        checked.worst_plain = std::max(checked.worst_plain, error / g.cwiseAbs().maxCoeff());
        checked.widest = std::max(checked.widest, scale / g.cwiseAbs().maxCoeff());
      }
      checked.near += d[p] < 2 * kNear;
    }
  }
}

// A configuration where every pair of the model is at least `gap` apart (Euclidean).
VecQ clear_configuration(const DistanceModel& model, std::mt19937_64& rng, double gap) {
  for (int draw = 0; draw < 10000; ++draw) {
    const VecQ q = test::random_q(rng, model.robot());
    const std::vector<double> d = clearances(model, q);
    if (*std::min_element(d.begin(), d.end()) >= gap) return q;
  }
  ADD_FAILURE() << "no configuration with every pair " << gap << " apart";
  return VecQ::Zero(model.dof());
}

// The corridor's boxes (franka-corridor.md, corridor_narrow), a sphere and a capsule.
void record(const std::string& name, const Checked& c) {
  char text[160];
  std::snprintf(text, sizeof text, "%d pairs (%d near contact); worst error %.3g of the bound, %.3g of |dD/dq|; scale up to %.3g |dD/dq|",
                c.pairs, c.near, c.worst, c.worst_plain, c.widest);
  ::testing::Test::RecordProperty(name, text);
}

std::vector<Obstacle> panda_obstacles() {
  return {{"wall1", Box{Vec3(0.35, 0.05, 0.90)}, {Vec3(0.53, 0.16, 0.45), Quat::Identity()}},
          {"wall2", Box{Vec3(0.35, 0.05, 0.90)}, {Vec3(0.53, -0.16, 0.45), Quat::Identity()}},
          {"roof", Box{Vec3(0.35, 0.35, 0.05)}, {Vec3(0.53, 0, 0.925), Quat::Identity()}},
          {"ball", Sphere{0.06}, {Vec3(-0.3, 0.35, 0.6), Quat::Identity()}},
          {"rod", Capsule{0.04, 0.3}, {Vec3(-0.2, -0.4, 0.3), Quat(0.8, 0.3, -0.4, 0.2).normalized()}}};
}

PairSelection both() {
  PairSelection s;
  s.self = true;
  return s;
}

TEST(DistanceJacobians, PandaRandomConfigurations) {
  for (const Metric metric : {Metric::gap, Metric::euclidean}) {
    const DistanceModel model(test::panda(), panda_obstacles(), metric, GapParams{}, both());
    ASSERT_EQ(model.pairs().size(), 9u * 5u + 25u);
    std::mt19937_64 rng(metric == Metric::gap ? 1 : 2);
    Checked checked;
    for (int trial = 0; trial < 6; ++trial)
      expect_gradients_match_differences(model, clear_configuration(model, rng, 1e-3),
                                         "trial " + std::to_string(trial), checked);
    EXPECT_EQ(checked.pairs, 6 * 70);
    record(to_string(metric), checked);
  }
}

TEST(DistanceJacobians, MeshRobotRandomConfigurations) {
  test::TempDir dir;
  const test::MeshRobot spec = test::write_mesh_robot(dir);
  const auto robot = Robot::from_file(spec.urdf_path, "robot", spec.options);
  const std::vector<Obstacle> obstacles = {
      {"ball", Sphere{0.05}, {Vec3(0.45, -0.1, 0.55), Quat::Identity()}},
      {"slab", Box{Vec3(0.3, 0.2, 0.04)}, {Vec3(0.1, 0.1, -0.25), Quat(0.9, 0.1, -0.3, 0.2).normalized()}}};
  for (const Metric metric : {Metric::gap, Metric::euclidean}) {
    const DistanceModel model(robot, obstacles, metric, GapParams{}, both());
    ASSERT_EQ(model.pairs().size(), 7u * 2u + 11u);
    std::mt19937_64 rng(metric == Metric::gap ? 3 : 4);
    Checked checked;
    for (int trial = 0; trial < 6; ++trial)
      expect_gradients_match_differences(model, clear_configuration(model, rng, 1e-3),
                                         "trial " + std::to_string(trial), checked);
    EXPECT_EQ(checked.pairs, 6 * 25);
    record(to_string(metric), checked);
  }
}

// At `trials` random configurations clear of contact: every pair's distance finite, positive and
// converged, its Jacobian that of central differences.
void expect_clear_distances_and_gradients(const DistanceModel& model, std::uint64_t seed, int trials) {
  std::mt19937_64 rng(seed);
  Checked checked;
  for (int trial = 0; trial < trials; ++trial) {
    const VecQ q = clear_configuration(model, rng, 1e-3);
    const DistanceBatch b = at(model, q);
    for (int p = 0; p < b.pairs; ++p) {
      EXPECT_TRUE(std::isfinite(b.distance[p]) && b.distance[p] > 0) << model.pairs()[p].name;
      EXPECT_TRUE(b.converged[p]) << model.pairs()[p].name;
    }
    expect_gradients_match_differences(model, q, "trial " + std::to_string(trial), checked);
  }
  EXPECT_EQ(checked.pairs, trials * static_cast<int>(model.pairs().size()));
}

// A URDF arm with collision elements small against h = 0.1 (element_params): an IMU's 2 mm box
// (as in quadrupeds' descriptions), a 1 mm placeholder sphere (a gripper's thumb) and a 9 mm
// sphere, besides a link-sized cylinder. The base has none (its distances do not move with q).
std::shared_ptr<const Robot> arm_with_small_elements() {
  return Robot::from_urdf(R"(<robot name="small">
  <link name="base"/>
  <link name="arm">
    <collision><origin xyz="0.15 0 0"/><geometry><cylinder radius="0.04" length="0.3"/></geometry></collision>
    <collision><origin xyz="0.05 0 0.045"/><geometry><box size="0.002 0.002 0.002"/></geometry></collision>
  </link>
  <link name="hand">
    <collision><geometry><sphere radius="0.009"/></geometry></collision>
    <collision><origin xyz="0.02 0 0"/><geometry><sphere radius="0.001"/></geometry></collision>
  </link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="arm"/><origin xyz="0 0 0.1"/>
    <axis xyz="0 1 0"/><limit lower="-1.5" upper="1.5" effort="1" velocity="1"/></joint>
  <joint name="wrist" type="revolute"><parent link="arm"/><child link="hand"/><origin xyz="0.33 0 0"/>
    <axis xyz="0 0 1"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
</robot>)");
}

TEST(DistanceJacobians, ElementsSmallAgainstHTakeTheirOwnH) {
  const auto robot = arm_with_small_elements();
  const std::vector<Obstacle> obstacles = {{"ball", Sphere{0.05}, {Vec3(0.3, 0.2, 0.3), Quat::Identity()}},
                                           {"slab", Box{Vec3(0.6, 0.6, 0.02)}, {Vec3(0.2, 0, 0.5), Quat::Identity()}}};
  const GapParams params;
  const DistanceModel model(robot, obstacles, Metric::gap, params, PairSelection{});
  const auto& prims = robot->primitives();
  ASSERT_EQ(prims.size(), 4u);
  const DistanceModel::Workspace w = model.workspace();
  int own = 0;
  for (std::size_t i = 0; i < prims.size(); ++i) {
    SCOPED_TRACE(prims[i].name);
    const GapBody at_h(prims[i].shape, Pose{}, params, gap_body_options(prims[i].shape, {}, params));
    const bool passes_at_h = validate_p2s(at_h.p2s()).ok;
    const double h = w.robot_gap[i].p2s().phi().h();
    EXPECT_TRUE(validate_p2s(w.robot_gap[i].p2s()).ok);  // every body the model holds keeps Property 2
    if (passes_at_h) {
      EXPECT_EQ(h, params.h);  // the 9 mm sphere too: small, but it passes at h
    } else {
      ++own;  // the 2 mm box and the 1 mm sphere fail at h, and take a smaller one
      EXPECT_LT(bounding_ball(prims[i].shape).radius, kSmallElementShare * params.h);
      EXPECT_LT(h, params.h);
    }
  }
  EXPECT_EQ(own, 2);
  ASSERT_EQ(model.warnings().size(), 2u);
  for (const std::string& warning : model.warnings())
    EXPECT_NE(warning.find("small against h = 0.1: its GAP function takes h = "), std::string::npos) << warning;
  EXPECT_NE(model.warnings()[0].find(prims[1].name), std::string::npos) << model.warnings()[0];
  EXPECT_NE(model.warnings()[1].find(prims[3].name), std::string::npos) << model.warnings()[1];
  // The h a warning gives reads back as the element's h, to the bit.
  for (const auto& [k, i] : {std::pair{0, 1}, std::pair{1, 3}}) {
    const std::string& text = model.warnings()[static_cast<std::size_t>(k)];
    const std::string takes = "takes h = ";
    ASSERT_NE(text.find(takes), std::string::npos) << text;
    EXPECT_EQ(std::stod(text.substr(text.find(takes) + takes.size())), w.robot_gap[static_cast<std::size_t>(i)].p2s().phi().h()) << text;
  }
  expect_clear_distances_and_gradients(model, 11, 4);
  // The Euclidean metric has no h: no warning.
  EXPECT_TRUE(DistanceModel(robot, obstacles, Metric::euclidean, params, PairSelection{}).warnings().empty());
}

// A URDF with collision elements large against h = 0.1 (element_params): a 1 m cylinder and a
// 1 m cube mesh (simple_humanoid's body and box.stl in Gepetto/example-robot-data), a 1 m
// capsule, and a 0.3 m sphere, which holds at the given parameters.
TEST(DistanceJacobians, ElementsLargeAgainstHTakeTheirOwnEps) {
  test::TempDir dir;
  std::string cube = "o cube\n";
  for (int i = 0; i < 8; ++i)
    cube += "v " + std::to_string(i & 1 ? 0.5 : -0.5) + " " + std::to_string(i & 2 ? 0.5 : -0.5) + " " +
            std::to_string(i & 4 ? 0.5 : -0.5) + "\n";
  // Two triangles a face, outward.
  cube += "f 1 3 4\nf 1 4 2\nf 5 6 8\nf 5 8 7\nf 1 2 6\nf 1 6 5\nf 3 7 8\nf 3 8 4\nf 1 5 7\nf 1 7 3\nf 2 4 8\nf 2 8 6\n";
  dir.write("meshes/cube.obj", cube);
  const std::string urdf = dir.write("large.urdf", R"(<robot name="large">
  <link name="base"/>
  <link name="body">
    <collision><origin xyz="0 0 1"/><geometry><cylinder radius="1" length="1"/></geometry></collision>
    <collision><origin xyz="0 0 2"/><geometry><mesh filename="meshes/cube.obj"/></geometry></collision>
    <collision><origin xyz="0 0 2.9"/><geometry><sphere radius="0.3"/></geometry></collision>
  </link>
  <link name="arm">
    <collision distlab:capsule="true"><origin xyz="1.5 0 0" rpy="0 1.5708 0"/><geometry><cylinder radius="1" length="1"/></geometry></collision>
  </link>
  <joint name="turn" type="revolute"><parent link="base"/><child link="body"/><axis xyz="0 0 1"/>
    <limit lower="-1.5" upper="1.5" effort="1" velocity="1"/></joint>
  <joint name="lift" type="revolute"><parent link="body"/><child link="arm"/><origin xyz="1.2 0 1.5"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>)");
  const auto robot = Robot::from_file(urdf, "robot");
  const std::vector<Obstacle> obstacles = {{"post", Cylinder{0.1, 2}, {Vec3(0, 3.5, 1), Quat::Identity()}},
                                           {"crate", Box{Vec3(0.4, 0.4, 0.4)}, {Vec3(-3, 0, 0.3), Quat::Identity()}}};
  const GapParams params;
  const DistanceModel model(robot, obstacles, Metric::gap, params, PairSelection{});
  const auto& prims = robot->primitives();
  ASSERT_EQ(prims.size(), 4u);
  const DistanceModel::Workspace w = model.workspace();
  std::vector<std::string> own;
  for (std::size_t i = 0; i < prims.size(); ++i) {
    SCOPED_TRACE(prims[i].name);
    const GapBody at_eps(prims[i].shape, Pose{}, params, gap_body_options(prims[i].shape, {}, params));
    const ValidationReport given = validate_p2s(at_eps.p2s());
    const double eps = w.robot_gap[i].p2s().strict_params().eps;
    EXPECT_TRUE(validate_p2s(w.robot_gap[i].p2s()).ok);  // every body the model holds keeps Property 2
    EXPECT_EQ(w.robot_gap[i].p2s().strict_params().sigma, params.sigma);
    EXPECT_EQ(w.robot_gap[i].p2s().phi().h(), params.h);
    if (given.ok) {
      EXPECT_EQ(eps, params.eps);  // the 0.3 m sphere
    } else {
      own.push_back(prims[i].name);  // the cylinder (1.21 at ε), the cube (1.14) and the capsule (1.29)
      EXPECT_GE(bounding_ball(prims[i].shape).radius, kLargeElementShare * params.h);
      EXPECT_LT(eps, params.eps);
      // The largest ε of the halvings that holds: twice it fails.
      GapParams twice = params;
      twice.eps = 2 * eps;
      const GapBody at_twice(prims[i].shape, Pose{}, twice, gap_body_options(prims[i].shape, {}, twice));
      EXPECT_FALSE(validate_p2s(at_twice.p2s()).ok);
    }
  }
  ASSERT_EQ(own.size(), 3u);
  ASSERT_EQ(model.warnings().size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) {
    const std::string& text = model.warnings()[k];
    EXPECT_NE(text.find(own[k]), std::string::npos) << text;
    EXPECT_NE(text.find("large against h = 0.1: its GAP function takes eps = "), std::string::npos) << text;
  }
  expect_clear_distances_and_gradients(model, 12, 4);
}

// Building a model calls its checkpoint before each GAP body and each Property 2 check of a small
// element, so a time limit stops it at any of them: a checkpoint that throws at its k-th call
// stops construction with that exception, for every k up to the calls a full build makes.
TEST(DistanceJacobians, ModelConstructionStopsAtItsCheckpoint) {
  const auto robot = arm_with_small_elements();
  const std::vector<Obstacle> obstacles = {{"ball", Sphere{0.05}, {Vec3(0.3, 0.2, 0.3), Quat::Identity()}},
                                           {"slab", Box{Vec3(0.6, 0.6, 0.02)}, {Vec3(0.2, 0, 0.5), Quat::Identity()}}};
  const auto calls_of = [&](Metric metric) {
    int calls = 0;
    const DistanceModel model(robot, obstacles, metric, GapParams{}, PairSelection{}, nullptr, [&] { ++calls; });
    return calls;
  };
  EXPECT_EQ(calls_of(Metric::euclidean), 2);  // the obstacles' shapes; the robot's are built at load
  // GAP: 4 bodies and 2 obstacles, and at least one check of each of the 3 small elements (the
  // 2 mm box and the 1 mm sphere fail at h and are checked again).
  const int calls = calls_of(Metric::gap);
  EXPECT_GE(calls, 4 + 2 + 3 + 2);
  struct Stop {};
  for (int k = 1; k <= calls; ++k) {
    int seen = 0;
    EXPECT_THROW(DistanceModel(robot, obstacles, Metric::gap, GapParams{}, PairSelection{}, nullptr,
                               [&] {
                                 if (++seen == k) throw Stop{};
                               }),
                 Stop)
        << "call " << k;
    EXPECT_EQ(seen, k);
  }
}

// Moves `o` along the line of the nearest points of element `i` at q to kNear from it (the slab
// between the nearest points' planes keeps separating them: the distance falls by the move).
void place_near(const DistanceModel& model, const VecQ& q, int i, Obstacle& o) {
  const Robot& robot = model.robot();
  const Pose pose = robot.primitive_pose(robot.forward(q), i);
  const EuclideanShape& a = model.robot_shape(i);
  const EuclideanShape b(o.shape);
  const EuclideanResult e = euclidean_distance(a, pose, b, o.pose);
  ASSERT_GT(e.distance, kNear);
  o.pose.position -= (e.distance - kNear) * (e.witness_b - e.witness_a) / e.distance;
  EXPECT_NEAR(euclidean_distance(a, pose, b, o.pose).distance, kNear, 1e-12);
}

// A sphere and a capsule 1e-4 m from two elements of the Panda (the rest ≥ 5 mm away), obstacle
// and self pairs.
TEST(DistanceJacobians, PandaObstaclesNearContact) {
  std::mt19937_64 rng(5);
  const auto panda = test::panda();
  for (const Metric metric : {Metric::gap, Metric::euclidean}) {
    Checked checked;
    for (int trial = 0; trial < 4; ++trial) {
      // Elements: the link-7 gripper box and the link-5 cylinder, then the link-6 cylinder and the link-5 box.
      const int first = trial % 2 ? 6 : 8, second = trial % 2 ? 4 : 5;
      const DistanceModel self(panda, {}, metric, GapParams{}, both());
      for (int attempt = 0;; ++attempt) {
        ASSERT_LT(attempt, 1000) << "no placement";
        const VecQ q = clear_configuration(self, rng, 5e-3);
        const Kinematics k = panda->forward(q);
        std::vector<Obstacle> obstacles = {
            {"ball", Sphere{0.04}, {panda->primitive_pose(k, first).position + 0.3 * test::random_unit(rng), Quat::Identity()}},
            {"rod", Capsule{0.03, 0.12}, {panda->primitive_pose(k, second).position + 0.3 * test::random_unit(rng), test::random_rotation(rng)}}};
        place_near(self, q, first, obstacles[0]);
        place_near(self, q, second, obstacles[1]);
        const DistanceModel model(panda, obstacles, metric, GapParams{}, both());
        std::vector<double> d = clearances(model, q);
        int near = 0;
        for (double x : d) near += x < 2 * kNear;
        std::sort(d.begin(), d.end());
        if (near != 2 || d[2] < 5e-3) continue;  // another element is close too: draw again
        expect_gradients_match_differences(model, q, "trial " + std::to_string(trial), checked);
        break;
      }
    }
    EXPECT_EQ(checked.near, 8) << to_string(metric);
    record(to_string(metric), checked);
  }
}

// Self pairs 1e-4 m from contact: a configuration on the segment from one where the pair is
// apart to one where it overlaps, found by bisection on its Euclidean distance.
TEST(DistanceJacobians, PandaSelfPairsNearContact) {
  std::mt19937_64 rng(6);
  const auto panda = test::panda();
  PairSelection self_only;
  self_only.obstacles = false;
  self_only.self = true;
  for (const Metric metric : {Metric::gap, Metric::euclidean}) {
    const DistanceModel model(panda, {}, metric, GapParams{}, self_only);
    Checked checked;
    int found = 0;
    for (int draw = 0; draw < 20000 && found < 4; ++draw) {
      const VecQ q1 = test::random_q(rng, *panda);
      const std::vector<double> d1 = clearances(model, q1);
      int overlapping = -1, count = 0;
      for (int p = 0; p < static_cast<int>(d1.size()); ++p)
        if (d1[p] <= 0) overlapping = p, ++count;
      if (count != 1) continue;  // exactly one pair overlaps at q1
      const VecQ q0 = clear_configuration(model, rng, 0.02);
      double lo = 0, hi = 1;  // distance at lo > kNear, at hi 0
      VecQ q;
      double dp = 0;
      for (int it = 0; it < 100; ++it) {
        const double t = 0.5 * (lo + hi);
        q = (1 - t) * q0 + t * q1;
        dp = clearances(model, q)[overlapping];
        if (std::abs(dp - kNear) < 1e-7) break;
        (dp > kNear ? lo : hi) = t;
      }
      std::vector<double> d = clearances(model, q);
      std::sort(d.begin(), d.end());
      if (std::abs(dp - kNear) >= 1e-7 || d[0] < 0.5 * kNear || d[1] < 5e-3) continue;
      expect_gradients_match_differences(model, q, model.pairs()[overlapping].name, checked);
      ++found;
    }
    EXPECT_EQ(found, 4) << to_string(metric);
    EXPECT_EQ(checked.near, 4) << to_string(metric);
    record(to_string(metric), checked);
  }
}

}  // namespace
}  // namespace distlab::robot
