// The corridor rollout (paper Section IV-B) with both metrics: outcomes, never times.
#include <cmath>

#include <gtest/gtest.h>

#include "distlab/cbf/rollout.hpp"

namespace distlab::cbf {
namespace {

// One rollout per metric and process (ctest runs each test in its own process).
const RolloutRecord& run(Metric m) {
  if (m == Metric::gap) {
    static const RolloutRecord gap = rollout(corridor_scenario(), Metric::gap);
    return gap;
  }
  static const RolloutRecord euclid = rollout(corridor_scenario(), Metric::euclidean);
  return euclid;
}

class Corridor : public ::testing::TestWithParam<Metric> {};

// True clearance > 0 at every step, every QP solved without relaxation, a complete record.
TEST_P(Corridor, SafeFeasibleAndComplete) {
  const RolloutRecord& r = run(GetParam());
  ASSERT_EQ(r.steps.size(), 3500u);
  for (const StepRecord& s : r.steps) {
    ASSERT_TRUE(std::isfinite(s.min_clearance));
    ASSERT_GT(s.min_clearance, 0.0) << "t = " << s.t;
  }
  EXPECT_TRUE(r.infeasible_steps.empty()) << r.infeasible_steps.size() << " relaxed steps";
  ASSERT_EQ(r.pairs.size(), 27u + 25u);  // 9 primitives × 3 boxes, 25 self pairs
  for (const StepRecord& s : r.steps) {
    ASSERT_EQ(s.pairs.size(), r.pairs.size());
    for (const PairSample& p : s.pairs) {
      ASSERT_TRUE(std::isfinite(p.distance));
      ASSERT_TRUE(p.converged);
      // The controller's D never exceeds the true distance (GAP is a lower bound here).
      ASSERT_LE(p.distance, p.clearance + 1e-9);
    }
  }
}

// DISABLED (issue 6): with the facts of franka-corridor.md the target pose lies outside the CBF
// safe set {D ≥ δ} for both metrics, so no CBF-QP rollout can converge to it. Evidence, asserted
// in test_target_feasibility.cpp: at the target the link-5 cylinder's placement depends on q7 only,
// and its clearance to the corridor walls is at most 1.152 cm over q7's whole range (δ_obs = 3 cm
// Euclidean; GAP D ≈ 2e-5 there, δ_obs = 0.002); with GAP, link 7's boxes (fixed by the target)
// have D = 0.00153 / 0.00127 < 0.002 to the roof. Observed: GAP stalls at ‖r‖ = 0.19, Euclidean at
// 0.024 (after its margin leaked to 2.2 cm through witness switching on the parallel
// cylinder/wall contact). Re-enable when the reference's scene, model or margins are corrected;
// the criterion itself (‖r‖ < 1e-3 after 35 s) must not be weakened.
TEST_P(Corridor, DISABLED_ReachesTheTarget) {
  // The requirement: ‖r‖ below the scenario's goal tolerance (1e-3) after 35 s.
  const RolloutRecord& r = run(GetParam());
  EXPECT_TRUE(r.reached) << to_string(GetParam()) << ": final ‖r‖ = " << r.final_task_error;
}

INSTANTIATE_TEST_SUITE_P(BothMetrics, Corridor, ::testing::Values(Metric::gap, Metric::euclidean),
                         [](const auto& p) { return std::string(to_string(p.param)); });

}  // namespace
}  // namespace distlab::cbf
