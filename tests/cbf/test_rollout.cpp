// The narrow corridor rollout (paper Section IV-B, corridor_narrow) with both metrics: outcomes,
// never times.
#include <atomic>
#include <cmath>

#include <gtest/gtest.h>

#include "panda.hpp"

#include "distlab/cbf/rollout.hpp"
#include "distlab/geometry/progress.hpp"

namespace distlab::cbf {
namespace {

// One rollout per metric and process (ctest runs each test in its own process).
const RolloutRecord& run(Metric m) {
  if (m == Metric::gap) {
    static const RolloutRecord gap = rollout(test::narrow(), Metric::gap);
    return gap;
  }
  static const RolloutRecord euclid = rollout(test::narrow(), Metric::euclidean);
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

// Where the corridors' rollouts end (in the slot, within 2 cm, why they stop) is asserted on the
// scenario files in test_corridor_outcomes.cpp; this file's scene (corridor_narrow) cannot reach
// its exact target with either metric (test_target_feasibility.cpp).

INSTANTIATE_TEST_SUITE_P(BothMetrics, Corridor, ::testing::Values(Metric::gap, Metric::euclidean),
                         [](const auto& p) { return std::string(to_string(p.param)); });

// Building the controller's GAP model calls its checkpoint before each body (one per robot element
// and obstacle), and a checkpoint that throws at any of its calls stops the build with that
// exception. A rollout passes its cancel there: cancelled before it starts, it stops while the
// model is built, with nothing reported and an empty record (not even the model's pairs).
TEST(Rollout, CancelStopsTheModelsConstruction) {
  const Scenario sc = test::narrow();
  int calls = 0;
  {
    const CbfController counted(sc, Metric::gap, [&] { ++calls; });
  }
  EXPECT_GE(calls, static_cast<int>(sc.robot->primitives().size() + sc.obstacles.size()));
  struct Stop {};
  for (int k = 1; k <= calls; ++k) {
    int seen = 0;
    EXPECT_THROW(CbfController(sc, Metric::gap,
                               [&] {
                                 if (++seen == k) throw Stop{};
                               }),
                 Stop)
        << "call " << k;
    EXPECT_EQ(seen, k);
  }
  std::atomic<bool> cancel{true};
  int reports = 0;
  RolloutOptions options;
  options.progress = Progress{[&](const std::string&, double) { ++reports; }, &cancel};
  RolloutRecord record;
  record.steps.resize(2);
  EXPECT_THROW(rollout(sc, Metric::gap, options, record), Cancelled);
  EXPECT_EQ(reports, 0);
  EXPECT_TRUE(record.steps.empty());
  EXPECT_TRUE(record.pairs.empty());
}

}  // namespace
}  // namespace distlab::cbf
