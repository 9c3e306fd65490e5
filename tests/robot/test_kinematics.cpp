// Panda kinematics (assets/robots/panda.urdf): a pose computed by hand from the DH table, every
// frame and collision element at random configurations against the DH table and the primitive
// table of franka-corridor.md as 4×4 matrices, Jacobians against central differences.
#include <cmath>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

#include "robot_test_util.hpp"

namespace distlab::robot {
namespace {

using test::Mat4;

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

// franka-corridor.md, "Kinematics": frame i = frame i−1 · Rz(q_i) · Tz(d_i) · Rx(α_i) · Tx(a_i).
struct DhRow {
  double d, alpha, a;
};
constexpr double kPi = std::numbers::pi;
const DhRow kDh[7] = {{0.333, -kPi / 2, 0}, {0, kPi / 2, 0}, {0.316, kPi / 2, 0.0825}, {0, -kPi / 2, -0.0825}, {0.384, kPi / 2, 0}, {0, kPi / 2, 0.088}, {0.177, 0, 0}};

// The frames 0 … 7 by the table's matrices.
std::vector<Mat4> dh_frames(const VecQ& q) {
  std::vector<Mat4> T = {Mat4::Identity()};
  for (int i = 0; i < 7; ++i)
    T.emplace_back(T.back() * test::rotation(Vec3::UnitZ(), q[i]) * test::translation(Vec3(0, 0, kDh[i].d)) *
                   test::rotation(Vec3::UnitX(), kDh[i].alpha) * test::translation(Vec3(kDh[i].a, 0, 0)));
  return T;
}

TEST(Kinematics, FramesAndElementsMatchTheDhTableAtRandomConfigurations) {
  const Robot& robot = *test::panda();
  // The collision table: link frame and pose in it (M of the link-5 box as the table's rows).
  Mat4 M;
  M << 1, 0, 0, 0, 0, 0, 1, -0.383, 0, -1, 0, 0, 0, 0, 0, 1;
  const auto tz = [](double z) { return test::translation(Vec3(0, 0, z)); };
  const std::vector<std::pair<int, Mat4>> elements = {
      {1, Mat4::Identity()},
      {2, tz(0.18)},
      {3, Mat4::Identity()},
      {4, tz(0.13)},
      {5, M * test::translation(Vec3(0, 0.09, 0.28)) * test::rotation(Vec3::UnitX(), -0.24)},
      {5, tz(-0.03)},
      {6, tz(0.02)},
      {7, tz(-0.05) * test::rotation(Vec3::UnitZ(), -kPi / 4)},
      {7, test::translation(Vec3(0.03, 0.03, -0.095))}};
  ASSERT_EQ(robot.primitives().size(), elements.size());
  std::mt19937_64 rng(2);
  for (int trial = 0; trial < 50; ++trial) {
    const VecQ q = test::random_q(rng, robot);
    const std::vector<Mat4> T = dh_frames(q);
    const Kinematics k = robot.forward(q);
    for (int i = 1; i <= 7; ++i) {
      const int l = test::dh_frame(robot, i);
      EXPECT_LT((k.frames[l].position - T[i].block<3, 1>(0, 3)).norm(), 1e-12) << "frame " << i;
      EXPECT_LT((k.R[l] - T[i].block<3, 3>(0, 0)).norm(), 1e-12) << "frame " << i;
    }
    const Mat4 ee = T[7] * test::rotation(Vec3::UnitZ(), -kPi / 4);
    EXPECT_LT((k.ee.position - ee.block<3, 1>(0, 3)).norm(), 1e-12);
    EXPECT_LT((k.ee_R - ee.block<3, 3>(0, 0)).norm(), 1e-12);
    for (std::size_t e = 0; e < elements.size(); ++e) {
      const Mat4 expected = T[elements[e].first] * elements[e].second;
      const Pose p = robot.primitive_pose(k, static_cast<int>(e));
      EXPECT_LT((p.position - expected.block<3, 1>(0, 3)).norm(), 1e-12) << robot.primitives()[e].name;
      EXPECT_LT((p.R() - expected.block<3, 3>(0, 0)).norm(), 1e-12) << robot.primitives()[e].name;
    }
  }
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
    const VecQ q = test::random_q(rng, robot);
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
      EXPECT_LT((Je.block<3, 1>(3, j) - test::rotvec(kp.ee_R * km.ee_R.transpose()) / (2 * h)).norm(), 1e-8);
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

}  // namespace
}  // namespace distlab::robot
