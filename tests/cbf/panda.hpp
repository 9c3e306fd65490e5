#pragma once
// The Panda of the tests: assets/robots/panda.urdf, and the DH frame i as a link index; a
// Jacobian check by central differences for any robot.
#include <memory>
#include <string>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "distlab/cbf/scenario.hpp"

namespace distlab::cbf::test {

inline std::shared_ptr<const Robot> panda() {
  return Robot::load(std::string(DISTLAB_SOURCE_DIR) + "/assets/robots/panda.urdf");
}
inline int dh_frame(const Robot& robot, int i) { return robot.link_index("panda_link" + std::to_string(i)); }
inline Scenario narrow() { return corridor_narrow_scenario(panda()); }

// point_jacobian of the point `local` fixed to `link` against central differences (step 1e-6) of
// its world position and of the link's rotation (as a rotation vector), every joint.
inline void expect_jacobian_matches_differences(const Robot& robot, const VecQ& q, int link, const Vec3& local) {
  const double h = 1e-6;
  const Kinematics k = robot.forward(q);
  const Jac J = robot.point_jacobian(k, link, k.frames[link].to_world(local));
  for (int j = 0; j < robot.dof(); ++j) {
    VecQ qp = q, qm = q;
    qp[j] += h;
    qm[j] -= h;
    const Kinematics kp = robot.forward(qp), km = robot.forward(qm);
    const Vec3 v = (kp.frames[link].to_world(local) - km.frames[link].to_world(local)) / (2 * h);
    const Eigen::AngleAxisd aa(kp.R[link] * km.R[link].transpose());
    const Vec3 w = aa.angle() * aa.axis() / (2 * h);
    EXPECT_LT((J.block<3, 1>(0, j) - v).norm(), 1e-8) << robot.links()[link] << " joint " << j;
    EXPECT_LT((J.block<3, 1>(3, j) - w).norm(), 1e-8) << robot.links()[link] << " joint " << j;
  }
}

}  // namespace distlab::cbf::test
