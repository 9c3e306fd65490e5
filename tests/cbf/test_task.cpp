// The task function r(q) of the corridor controller: its Jacobian against differences of r.
#include <cmath>
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
