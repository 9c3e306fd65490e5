// Is the corridor's target pose inside the CBF safe set at all? (Issue 6: both controllers stall.)
//
// At the target T(0.64, 0, 0.75)·Ry(π/2)·Rz(π/2) the pose of frame 7 is fixed (EE = frame 7 ·
// Rz(−π/4)), hence frame 6 up to q7 (α7 = 0: frame 6 = frame 7 · Tz(−0.177) · Rz(−q7)). The
// link-5 cylinder (r 0.06, h 0.22, Tz(−0.03) in frame 5) is symmetric about z5 = y6, and frame 5's
// origin is o6 − 0.088·x6, so its world placement depends on q7 alone — q1..q6 cannot help.
// Scanning q7 over its whole range bounds the cylinder's clearance to the corridor walls from above
// for EVERY configuration that reaches the target: at most 1.152 cm (at q7 ≈ −0.457), below the
// Euclidean margin δ_obs = 0.03 and, with GAP, D ≈ 2e-5 there, below δ_obs = 0.002. Independently,
// with GAP, link 7's boxes (whose pose the target fixes completely) have D < 0.002 to the roof.
// So the target lies outside the safe set {D ≥ δ} of eq. (7) with the facts of franka-corridor.md:
// a CBF-QP rollout cannot converge to it (test_corridor_outcomes.cpp asserts arrival within 2 cm instead).
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "panda.hpp"

#include "distlab/cbf/controller.hpp"
#include "distlab/cbf/feasibility.hpp"
#include "distlab/collision/euclidean.hpp"

namespace distlab::cbf {
namespace {

constexpr double kPi = std::numbers::pi;

Pose rz(double a) {
  Pose p;
  p.rotation = Quat(Eigen::AngleAxisd(a, Vec3::UnitZ()));
  return p;
}
Pose tz(double d) {
  Pose p;
  p.position = Vec3(0, 0, d);
  return p;
}
int index_of(const Robot& robot, const std::string& name) {
  for (std::size_t i = 0; i < robot.primitives().size(); ++i)
    if (robot.primitives()[i].name == name) return static_cast<int>(i);
  return -1;
}

// Frame 7 at the target: target · Rz(+π/4).
Pose frame7_at_target(const Scenario& sc) { return compose(sc.target, rz(kPi / 4)); }

TEST(TargetFeasibility, FrameSixAtTheTargetMatchesForwardKinematics) {
  // The construction below (frame 6 = frame 7 · Rz(−q7) · Tz(−0.177), frame 5 origin = o6 − 0.088 x6,
  // z5 = y6) checked against FK at an IK-free configuration: any q, "target" = its own EE pose.
  const Robot& robot = *test::panda();
  VecQ q(7);
  q << 0.3, -0.5, 0.2, -1.8, 0.4, 1.9, -0.7;
  const Kinematics k = robot.forward(q);
  const Pose f7 = compose(k.ee, rz(kPi / 4));
  EXPECT_LT((f7.position - k.frames[test::dh_frame(robot, 7)].position).norm(), 1e-12);
  const Pose f6 = compose(compose(f7, rz(-q[6])), tz(-0.177));
  EXPECT_LT((f6.position - k.frames[test::dh_frame(robot, 6)].position).norm(), 1e-12);
  EXPECT_LT((f6.R() - k.R[test::dh_frame(robot, 6)]).norm(), 1e-12);
  EXPECT_LT((f6.position - 0.088 * f6.R().col(0) - k.frames[test::dh_frame(robot, 5)].position).norm(), 1e-12);
  EXPECT_LT((f6.R().col(1) - k.R[test::dh_frame(robot, 5)].col(2)).norm(), 1e-12);
}

TEST(TargetFeasibility, LinkFiveCylinderCannotKeepTheEuclideanMarginAtTheTarget) {
  const Scenario sc = test::narrow();
  const Robot& robot = *test::panda();
  const int cyl = index_of(robot, "link5_cylinder");
  ASSERT_GE(cyl, 0);
  const Pose f7 = frame7_at_target(sc);
  double best = -1, best_q7 = 0;
  const int n = 3320;  // 0.1° steps over q7's range
  for (int s = 0; s <= n; ++s) {
    const double q7 = robot.q_min()[6] + (robot.q_max()[6] - robot.q_min()[6]) * s / n;
    const Pose f6 = compose(compose(f7, rz(-q7)), tz(-0.177));
    // Frame 5 with its z along y6 (the joint-6 axis); the rotation about z5 (q6) is irrelevant
    // for the cylinder, so any frame with z5 = y6 does: R5 = [x6, −z6, y6].
    Pose f5;
    f5.position = f6.position - 0.088 * f6.R().col(0);
    Mat3 R5;
    R5.col(0) = f6.R().col(0);
    R5.col(1) = -f6.R().col(2);
    R5.col(2) = f6.R().col(1);
    f5.rotation = Quat(R5);
    const Pose pose = compose(f5, robot.primitives()[cyl].pose);
    const EuclideanShape shape(robot.primitives()[cyl].shape);
    double clearance = INFINITY;
    for (int w = 0; w < 2; ++w) {  // wall1, wall2
      const Obstacle& o = sc.obstacles[w];
      clearance = std::min(clearance,
                           euclidean_distance(shape, pose, EuclideanShape(o.shape), o.pose).distance);
    }
    if (clearance > best) {
      best = clearance;
      best_q7 = q7;
    }
  }
  // Closed form: max over φ = π/4 − q7 of 0.135 − |−0.088 cos φ + 0.03 sin φ| − 0.11|sin φ| − 0.06|cos φ|
  // = 0.011518 at q7 = −0.4569.
  EXPECT_NEAR(best, 0.011518, 1e-4);  // grid of 0.1°; the maximum sits on a kink
  EXPECT_NEAR(best_q7, -0.4569, 5e-3);
  EXPECT_LT(best, sc.euclidean_margins.obstacle) << "the target would be Euclidean-feasible";
}

TEST(TargetFeasibility, GapMarginsAreViolatedAtTheTarget) {
  const Scenario sc = test::narrow();
  CbfController c(sc, Metric::gap);
  const Robot& robot = c.robot();
  // The best configuration of the test above, completed to the target pose by the controller's
  // own kinematics (an IK solution found by a null-space sweep of the target's self-motion).
  VecQ q(7);
  q << -0.0119, -0.0350, -0.0481, -1.7792, -0.3354, 3.3249, -0.4569;
  // Polish onto the target pose (Gauss–Newton on position and rotation vector).
  for (int it = 0; it < 50; ++it) {
    const Kinematics k = robot.forward(q);
    Vec6 e;
    e.head<3>() = k.ee.position - sc.target.position;
    const Eigen::AngleAxisd aa(k.ee_R * sc.target.R().transpose());
    e.tail<3>() = aa.angle() * aa.axis();
    const Jac J = robot.ee_jacobian(k);
    q -= J.transpose() * (J * J.transpose()).ldlt().solve(e);
  }
  ASSERT_LT(task_function(robot.forward(q), robot, sc.target).r.norm(), 1e-9);
  for (int i = 0; i < 7; ++i) {
    ASSERT_GT(q[i], robot.q_min()[i]);
    ASSERT_LT(q[i], robot.q_max()[i]);
  }
  std::vector<PairSample> s;
  GradQ grad;
  c.distances(q, s, grad);
  auto D = [&](const std::string& name) -> double {
    for (std::size_t p = 0; p < s.size(); ++p)
      if (c.pairs()[p].name == name) return s[p].distance;
    ADD_FAILURE() << "no pair " << name;
    return std::nan("");
  };
  const double delta = sc.gap_margins.obstacle;
  // Link 7's pose is fixed by the target: these two do not depend on q at all.
  EXPECT_LT(D("link7_box/roof"), delta);        // 0.00153 at 4.50 cm true clearance
  EXPECT_LT(D("link7_gripper/roof"), delta);    // 0.00127 at 4.04 cm
  EXPECT_LT(D("link5_cylinder/wall1"), delta);  // ≈ 2e-5 at 1.15 cm
  EXPECT_LT(D("link5_cylinder/wall2"), delta);
}

}  // namespace
}  // namespace distlab::cbf

namespace distlab::cbf {
namespace {

// target_feasibility (the callable behind `distlab cbf --feasibility` and the API) against the
// bound above: at the target, the link-5 cylinder's clearance is at most 1.152 cm for every q7,
// so the best over the redundancy cannot exceed it; and the configuration it returns must reach
// the target exactly, within the joint limits.
TEST(TargetFeasibility, BestClearanceOverTheRedundancyMeetsTheCylinderBound) {
  const Scenario sc = test::narrow();
  const Feasibility f = target_feasibility(sc);
  ASSERT_TRUE(f.reachable);
  const Robot& robot = *test::panda();
  EXPECT_LT(task_function(robot.forward(f.q), robot, sc.target).r.norm(), 1e-8);
  for (int i = 0; i < 7; ++i) {
    EXPECT_GE(f.q[i], robot.q_min()[i]);
    EXPECT_LE(f.q[i], robot.q_max()[i]);
  }
  EXPECT_LE(f.clearance, 0.01152 + 1e-5);
  EXPECT_GT(f.clearance, 0.0110);  // franka-corridor.md: 1.15 cm, by an independent scan
  EXPECT_EQ(f.limiting_pair.rfind("link5_cylinder/wall", 0), 0u) << f.limiting_pair;
  EXPECT_FALSE(f.euclidean_feasible);
  EXPECT_FALSE(f.gap_feasible);
  // The clearance is the minimum over the obstacle pairs at f.q, recomputed here.
  CbfController c(sc, Metric::euclidean);
  std::vector<PairSample> s;
  GradQ grad;
  c.distances(f.q, s, grad);
  double m = 1e9;
  for (std::size_t p = 0; p < s.size(); ++p)
    if (!c.pairs()[p].self) m = std::min(m, s[p].clearance);
  EXPECT_DOUBLE_EQ(m, f.clearance);
}

}  // namespace
}  // namespace distlab::cbf
