// CBF rows (eq. 7): ∇_q D · u against central differences of D along the motion q + τu, for
// every robot–obstacle and self-collision pair of the corridor, with both metrics.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "panda.hpp"

#include "distlab/cbf/rollout.hpp"

namespace distlab::cbf {
namespace {

using Grad = GradQ;

// Configurations the corridor rollout visits (q0, 2.5 s, 5 s, 10 s, and 25 s, where the GAP
// controller has stalled at ‖r‖ ≈ 0.19 with five distance rows active: link5_cylinder/wall2,
// link6_cylinder/wall1, link7_box/roof, link7_gripper/wall1, link5_cylinder/link7_gripper).
std::vector<VecQ> configurations() {
  Scenario sc = test::narrow();
  sc.duration = 25.01;
  RolloutOptions opt;
  opt.record_pairs = false;
  opt.audit_clearance = false;
  const RolloutRecord r = rollout(sc, Metric::gap, opt);
  return {r.steps[0].q, r.steps[250].q, r.steps[500].q, r.steps[1000].q, r.steps[2500].q};
}

void check_rows(Metric metric, double tol) {
  CbfController c(test::narrow(), metric);
  std::mt19937_64 rng(5);
  std::normal_distribution<double> g;
  const double tau = 1e-6;
  int checked = 0;
  for (const VecQ& q : configurations()) {
    for (int trial = 0; trial < 3; ++trial) {
      VecQ u(7);
      for (int i = 0; i < 7; ++i) u[i] = g(rng);
      std::vector<PairSample> s0, sp, sm;
      Grad grad, unused;
      c.distances(q, s0, grad);
      c.distances(q + tau * u, sp, unused);
      c.distances(q - tau * u, sm, unused);
      for (std::size_t p = 0; p < s0.size(); ++p) {
        ASSERT_FALSE(s0[p].overlap) << c.pairs()[p].name;
        const double fd = (sp[p].distance - sm[p].distance) / (2 * tau);
        const double row = grad.row(static_cast<Eigen::Index>(p)).dot(u);
        EXPECT_NEAR(row, fd, tol * (1 + std::abs(fd))) << to_string(metric) << " "
                                                       << c.pairs()[p].name;
        ++checked;
      }
    }
  }
  EXPECT_EQ(checked, 15 * 52);
}

TEST(CbfRows, GapGradientMatchesDifferencesAlongTheMotion) { check_rows(Metric::gap, 1e-6); }

TEST(CbfRows, EuclideanGradientMatchesDifferencesAlongTheMotion) {
  // At these configurations no pair has parallel nearest features, so the Euclidean
  // distance is differentiable there.
  check_rows(Metric::euclidean, 1e-6);
}

}  // namespace
}  // namespace distlab::cbf
