// Panda kinematics: a pose computed by hand from the DH table, Jacobians against central
// differences, the task Jacobian against differences of r.
#include <cmath>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

#include "panda.hpp"

#include "distlab/cbf/controller.hpp"

namespace distlab::cbf {
namespace {

VecQ random_q(std::mt19937_64& rng, const Robot& robot) {
  VecQ q(7);
  for (int i = 0; i < 7; ++i)
    q[i] = std::uniform_real_distribution<double>(robot.q_min()[i], robot.q_max()[i])(rng);
  return q;
}

// log of a rotation close to I, as a rotation vector.
Vec3 rotvec(const Mat3& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}

TEST(Kinematics, ZeroConfigurationByHand) {
  // q = 0: R1 = Rx(−π/2), R2 = I, frame 3 at (0.0825, 0, 0.333 + 0.316) with R3 = Rx(π/2),
  // frame 4 back at x = 0, frame 5 up d5 = 0.384 to z = 1.033, R6 = Rx(π) = diag(1, −1, −1),
  // frame 6 out a6 = 0.088 along x, frame 7 down d7 = 0.177 along z6 = −z: (0.088, 0, 0.856).
  const Robot& robot = *test::panda();
  const Kinematics k = robot.forward(VecQ::Zero(7));
  EXPECT_LT((k.frames[test::dh_frame(robot, 3)].position - Vec3(0.0825, 0, 0.649)).norm(), 1e-12);
  EXPECT_LT((k.frames[test::dh_frame(robot, 4)].position - Vec3(0, 0, 0.649)).norm(), 1e-12);
  EXPECT_LT((k.frames[test::dh_frame(robot, 5)].position - Vec3(0, 0, 1.033)).norm(), 1e-12);
  EXPECT_LT((k.frames[test::dh_frame(robot, 6)].position - Vec3(0.088, 0, 1.033)).norm(), 1e-12);
  EXPECT_LT((k.ee.position - Vec3(0.088, 0, 0.856)).norm(), 1e-12);
  // End effector = frame 7 · Rz(−π/4): x = R6 (c, −c, 0) = (c, c, 0), z = −e_z.
  const double c = std::sqrt(0.5);
  EXPECT_LT((k.ee_R.col(0) - Vec3(c, c, 0)).norm(), 1e-12);
  EXPECT_LT((k.ee_R.col(1) - Vec3(c, -c, 0)).norm(), 1e-12);
  EXPECT_LT((k.ee_R.col(2) - Vec3(0, 0, -1)).norm(), 1e-12);
}

TEST(Kinematics, ModelCounts) {
  const Robot& robot = *test::panda();
  EXPECT_EQ(robot.primitives().size(), 9u);
  // Links 1..4 have one primitive, 5 two, 6 one, 7 two; pairs with j ≥ i + 2: 7+6+5+3+4 = 25.
  EXPECT_EQ(robot.self_pairs().size(), 25u);
  for (const auto& [i, j] : robot.self_pairs())
    EXPECT_GE(robot.primitives()[j].link, robot.primitives()[i].link + 4);  // DH frames are every second link
}

TEST(Kinematics, PointJacobiansMatchCentralDifferences) {
  const Robot& robot = *test::panda();
  std::mt19937_64 rng(7);
  const double h = 1e-6;
  for (int trial = 0; trial < 20; ++trial) {
    const VecQ q = random_q(rng, robot);
    const Kinematics k = robot.forward(q);
    for (int i = 1; i <= 7; ++i)  // a point fixed to each DH frame
      test::expect_jacobian_matches_differences(robot, q, test::dh_frame(robot, i),
                                                Vec3(0.1 * (trial % 3) - 0.1, 0.05, -0.07));
    // End effector (frame 7 · Rz(−π/4)): same point, same angular part.
    const Jac Je = robot.ee_jacobian(k);
    for (int j = 0; j < 7; ++j) {
      VecQ qp = q, qm = q;
      qp[j] += h;
      qm[j] -= h;
      const Kinematics kp = robot.forward(qp), km = robot.forward(qm);
      EXPECT_LT((Je.block<3, 1>(0, j) - (kp.ee.position - km.ee.position) / (2 * h)).norm(), 1e-8);
      EXPECT_LT((Je.block<3, 1>(3, j) - rotvec(kp.ee_R * km.ee_R.transpose()) / (2 * h)).norm(),
                1e-8);
    }
  }
}

TEST(Kinematics, PrimitivePosesFollowTheirLinks) {
  // The link-5 box: M · T(0, 0.09, 0.28) · Rx(−0.24) with M(x, y, z) = (x, z − 0.383, −y),
  // so its centre is (0, 0.28 − 0.383, −0.09) in frame 5.
  const Robot& robot = *test::panda();
  const Kinematics k = robot.forward(VecQ::Zero(7));
  const Pose box = robot.primitive_pose(k, 4);
  EXPECT_EQ(robot.primitives()[4].name, "link5_box");
  EXPECT_LT((k.frames[test::dh_frame(robot, 5)].to_local(box.position) - Vec3(0, -0.103, -0.09)).norm(), 1e-12);
  // Its long (local z) axis is M's image of Rx(−0.24) e_z = (0, sin 0.24, cos 0.24):
  // (0, cos 0.24, −sin 0.24) in frame 5.
  const Vec3 axis = k.frames[test::dh_frame(robot, 5)].dir_to_local(box.dir_to_world(Vec3::UnitZ()));
  EXPECT_LT((axis - Vec3(0, std::cos(0.24), -std::sin(0.24))).norm(), 1e-12);
}

TEST(Task, JacobianMatchesDifferencesOfR) {
  const Robot& robot = *test::panda();
  const Scenario sc = test::narrow();
  std::mt19937_64 rng(11);
  const double h = 1e-6;
  for (int trial = 0; trial < 20; ++trial) {
    const VecQ q = random_q(rng, robot);
    const Task t = task_function(robot.forward(q), robot, sc.target);
    if (t.r.tail<3>().minCoeff() < 1e-3) continue;  // the kink of max(0, ·) is not differentiable
    for (int j = 0; j < 7; ++j) {
      VecQ qp = q, qm = q;
      qp[j] += h;
      qm[j] -= h;
      const Vec6 dr = (task_function(robot.forward(qp), robot, sc.target).r -
                       task_function(robot.forward(qm), robot, sc.target).r) /
                      (2 * h);
      EXPECT_LT((t.J.col(j) - dr).norm(), 1e-8) << "joint " << j;
    }
  }
}

}  // namespace
}  // namespace distlab::cbf
