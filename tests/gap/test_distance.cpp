// The GAP metric end to end (FCL start, libccd overlap): Definition 2 on overlap, Lemma 4 against
// the Euclidean witness, gradients of D against finite differences, differentiability where the
// Euclidean distance has a kink, batch = single calls.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "distlab/gap/distance.hpp"
#include "distlab/geometry/error.hpp"
#include "gap_test_util.hpp"

namespace distlab {
namespace {

GapParams defaults() { return GapParams{}; }

TEST(GapDistance, OverlapGivesZeroAndACommonPoint) {
  const GapParams p = defaults();
  std::mt19937_64 rng(2);
  for (int i = 0; i < 50; ++i) {
    const GapBody a(Box{Vec3(0.3, 0.2, 0.25)}, Pose{Vec3::Zero(), test::random_rotation(rng)}, p);
    const GapBody b(Cylinder{0.1, 0.3}, Pose{0.15 * test::random_unit(rng), test::random_rotation(rng)}, p);
    const GapResult r = gap_distance(a, b, p);
    ASSERT_TRUE(r.overlap);
    EXPECT_EQ(r.lambda, 0.0);
    EXPECT_EQ(r.distance, 0.0);
    EXPECT_EQ(r.witness_a, r.witness_b);
    // The common point lies in both sets: E vanishes there up to rounding of the pose.
    EXPECT_LT(a.p2s().weak(r.witness_a, 0).value, 1e-20);
    EXPECT_LT(b.p2s().weak(r.witness_a, 0).value, 1e-20);
    EXPECT_EQ(r.gradient_a.norm(), 0.0);
  }
}

TEST(GapDistance, SeparatedPairsSatisfyLemma4AndTheFixedPoint) {
  const GapParams p = defaults();
  std::mt19937_64 rng(4);
  for (int i = 0; i < 100; ++i) {
    const GapBody a(test::random_polytope(rng, 10, 0.1), Pose{Vec3::Zero(), test::random_rotation(rng)}, p);
    const GapBody b(test::random_polytope(rng, 8, 0.1),
                    Pose{(0.25 + 0.2 * (i % 3)) * test::random_unit(rng), test::random_rotation(rng)}, p);
    const GapResult r = gap_distance(a, b, p);
    if (r.overlap) continue;
    ASSERT_TRUE(r.converged);
    EXPECT_GT(r.distance, 0.0);
    EXPECT_NEAR(r.distance, std::sqrt(2 * r.lambda), 1e-15);
    // Lemma 4 with the Euclidean witness a0* in A: Λ <= E_B(a0*).
    EXPECT_LE(r.lambda, b.p2s().strict(r.euclidean.witness_a, 0).value * (1 + 1e-9) + 1e-300);
    // Definition 2: a* = Π_A(Π_B(a*)), b* = Π_B(a*), both within the solver's tolerance.
    const Vec3 bb = r.witness_a - b.p2s().strict(r.witness_a, 1).gradient;
    EXPECT_LT((bb - r.witness_b).norm(), p.tol);
    const Vec3 aa = bb - a.p2s().strict(bb, 1).gradient;
    EXPECT_LT((aa - r.witness_a).norm(), p.tol);
  }
}

// dD/d(v, ω) for both shapes against central differences of D.
TEST(GapDistance, DistanceGradientsMatchFiniteDifferences) {
  GapParams p = defaults();
  p.tol = 1e-14;
  std::mt19937_64 rng(8);
  const std::vector<Shape> shapes = {Box{Vec3(0.2, 0.1, 0.3)}, Cylinder{0.08, 0.25}, Capsule{0.05, 0.2},
                                     Sphere{0.1}, test::random_polytope(rng, 12, 0.12)};
  for (size_t i = 0; i < shapes.size(); ++i)
    for (size_t j = 0; j < shapes.size(); ++j) {
      GapBody a(shapes[i], Pose{Vec3(0.1, 0, 0), test::random_rotation(rng)}, p);
      GapBody b(shapes[j], Pose{Vec3(0.1, 0, 0) + 0.45 * test::random_unit(rng), test::random_rotation(rng)}, p);
      const GapResult r = gap_distance(a, b, p);
      ASSERT_FALSE(r.overlap);
      const double d = 1e-6;
      for (int which = 0; which < 2; ++which) {
        GapBody& moved = which == 0 ? a : b;
        const Pose base = moved.pose();
        for (int c = 0; c < 6; ++c) {
          double v[2];
          for (int s = 0; s < 2; ++s) {
            moved.set_pose(test::perturbed(base, c, s ? d : -d));
            v[s] = gap_distance(a, b, p).distance;
          }
          moved.set_pose(base);
          const double want = (which == 0 ? r.gradient_a : r.gradient_b)[c];
          EXPECT_NEAR((v[1] - v[0]) / (2 * d), want, 2e-7 * (1 + std::abs(want)))
              << shape_type_name(shapes[i]) << "-" << shape_type_name(shapes[j]) << " shape " << which
              << " coord " << c;
        }
      }
    }
}

// At h whose 1/h is not an integer Φ has no rational form: the closed form with its tabled
// (1+s)^(−1/h) (BaseFunction). D and its gradients against the long-double solve and its central
// differences (gap_gradient_extended: log1p and exp in long double, no table), for boxes,
// cylinders and polytopes at the benchmark's h.
TEST(GapDistance, SolvesWithoutARationalFormMatchTheLongDoubleReference) {
  std::mt19937_64 rng(21);
  const std::vector<Shape> shapes = {Box{Vec3(0.2, 0.1, 0.3)}, Cylinder{0.08, 0.25}, test::random_polytope(rng, 12, 0.12)};
  double worst_d = 0, worst_g = 0;
  for (double h : {0.0123, 0.03, 0.07, 0.08}) {
    GapParams p = defaults();
    p.h = h;
    p.tol = 1e-12;
    for (size_t i = 0; i < shapes.size(); ++i)
      for (size_t j = 0; j < shapes.size(); ++j) {
        const GapBody a(shapes[i], Pose{Vec3::Zero(), test::random_rotation(rng)}, p);
        const GapBody b(shapes[j], Pose{(0.35 + 0.1 * static_cast<double>(j)) * test::random_unit(rng), test::random_rotation(rng)}, p);
        const GapResult r = gap_distance(a, b, p);
        ASSERT_FALSE(r.overlap);
        ASSERT_TRUE(r.converged);
        const ExtendedGradient ref = gap_gradient_extended(a, b, r, 1e-6);
        ASSERT_TRUE(ref.converged);
        worst_d = std::max(worst_d, std::abs(r.distance - ref.distance) / ref.distance);
        for (int c = 0; c < 6; ++c)
          worst_g = std::max({worst_g, std::abs(r.gradient_a[c] - ref.a[c]) / (1 + std::abs(ref.a[c])),
                              std::abs(r.gradient_b[c] - ref.b[c]) / (1 + std::abs(ref.b[c]))});
      }
  }
  EXPECT_LT(worst_d, 1e-13) << "D";
  EXPECT_LT(worst_g, 1e-9) << "gradients";
  std::printf("worst relative error: D %.3g, gradient %.3g\n", worst_d, worst_g);
}

// Cold solves stop on their estimated error left (solver.cpp, kColdErrorRelative) as well as on
// their step: Λ's gradients and the witnesses must stay at the rounding level of the long-double
// solve, for every shape kind, at h with and without a rational form, from d = 1e-7 to 0.3.
// Measured 9.1e-15 (gradients) and 3.4e-15 (witnesses), the same without the rule; the tracked
// calls' kRelativeStep² in place of kColdErrorRelative gives 6.7e-12 and 7.0e-12 and fails.
TEST(GapDistance, ColdSolvesKeepGradientsAtTheLongDoubleSolvesRounding) {
  using L = long double;
  std::mt19937_64 rng(777);
  double worst_gradient = 0, worst_witness = 0;
  int solved = 0;
  for (double h : {0.01, 0.03, 0.05, 0.1}) {
    GapParams p = defaults();
    p.h = h;
    for (int trial = 0; trial < 150; ++trial) {
      const std::vector<Shape> shapes = {Box{Vec3(0.2, 0.1, 0.3)}, Cylinder{0.08, 0.25},
                                         test::random_polytope(rng, 12, 0.12), Sphere{0.1}, Capsule{0.05, 0.2}};
      const GapBody a(shapes[rng() % shapes.size()], Pose{Vec3::Zero(), test::random_rotation(rng)}, p);
      const Vec3 dir = test::random_unit(rng);
      const Quat rotation = test::random_rotation(rng);
      GapBody b(shapes[rng() % shapes.size()], Pose{0.3 * dir, rotation}, p);
      // B along dir at a Euclidean gap drawn log-uniformly in [1e-7, 0.3] (bisection on the offset).
      const double gap = std::pow(10.0, std::uniform_real_distribution<double>(-7, -0.5)(rng));
      double lo = 0, hi = 3;
      for (int it = 0; it < 60; ++it) {
        const double mid = 0.5 * (lo + hi);
        b.set_pose(Pose{mid * dir, rotation});
        const GapResult e = gap_distance(a, b, p);
        (e.overlap || e.euclidean.distance < gap ? lo : hi) = mid;
      }
      b.set_pose(Pose{hi * dir, rotation});
      const GapResult r = gap_distance(a, b, p);
      ASSERT_FALSE(r.overlap);
      ASSERT_TRUE(r.converged);
      const auto ref = solve_newton(PosedP2S<L>{a.p2s(), PoseT<L>::from(a.pose())},
                                    PosedP2S<L>{b.p2s(), PoseT<L>::from(b.pose())}, r.witness_a.cast<L>(), 1e-18L, 100);
      ASSERT_TRUE(ref.converged);
      // dD/dv_A = (a* − b*)/D, dD/dω_A = (b* − t_A) × (a* − b*)/D (lambda_gradients).
      const L d = std::sqrt(2 * ref.lambda);
      const Vec3T<L> linear = ref.ab / d, angular = (ref.b - a.pose().position.cast<L>()).cross(ref.ab) / d;
      for (int c = 0; c < 3; ++c)
        worst_gradient = std::max({worst_gradient, static_cast<double>(std::abs(r.gradient_a[c] - linear[c])),
                                   static_cast<double>(std::abs(r.gradient_a[3 + c] - angular[c]))});
      worst_witness = std::max(worst_witness, static_cast<double>((r.witness_a.cast<L>() - ref.a).norm()));
      ++solved;
    }
  }
  EXPECT_EQ(solved, 600);
  EXPECT_LT(worst_gradient, 1e-13);
  EXPECT_LT(worst_witness, 1e-13);
  std::printf("worst error against the long-double solve: gradients %.3g, witnesses %.3g\n", worst_gradient,
              worst_witness);
}

// Two parallel boxes: rotating B about the normal axis makes the Euclidean distance kink at
// θ = 0 (one edge or the other comes closer). D's one-sided derivatives agree there.
TEST(GapDistance, DifferentiableWhereTheEuclideanDistanceHasAKink) {
  const GapParams p = defaults();
  const Box box{Vec3(0.3, 0.05, 0.2)};
  const GapBody a(box, Pose{}, p);
  auto at = [&](double theta) {
    const GapBody b(box, Pose{Vec3(0.05, 0.15, 0.0), Quat(Eigen::AngleAxisd(theta, Vec3::UnitZ()))}, p);
    return gap_distance(a, b, p);
  };
  const double h = 1e-4;
  const GapResult m = at(-h), z = at(0), pl = at(h);
  const double e_left = (z.euclidean.distance - m.euclidean.distance) / h;
  const double e_right = (pl.euclidean.distance - z.euclidean.distance) / h;
  const double g_left = (z.distance - m.distance) / h, g_right = (pl.distance - z.distance) / h;
  EXPECT_GT(std::abs(e_right - e_left), 0.1);  // a kink: ~ the box's half length
  const double scale = std::max(std::abs(g_left), std::abs(g_right)) + z.distance;
  EXPECT_LT(std::abs(g_right - g_left), 1e-2 * scale + 1e-12);
  // and the analytic gradient sits between the one-sided slopes (ω_z of shape B)
  EXPECT_NEAR(z.gradient_b[5], 0.5 * (g_left + g_right), 1e-3 * scale + 1e-12);
}

// B slides along A while tilting through parallel (the paper's Fig. 3): the Euclidean witness on
// B jumps from one end of its face to the other at θ = 0, so the Euclidean angular gradient
// jumps; GAP's changes by O(step).
TEST(GapDistance, GradientIsContinuousWhileBoxesSlidePastEachOther) {
  const GapParams p = defaults();
  const Box box{Vec3(0.2, 0.05, 0.2)};
  const GapBody a(box, Pose{}, p);
  double gap_jump = 0, euclid_jump = 0;
  Vec6 prev_gap = Vec6::Zero(), prev_euclid = Vec6::Zero();
  const double step = 2e-3;
  for (int i = 0; i <= 200; ++i) {
    const double tau = -0.2 + i * step;
    const GapBody b(box, Pose{Vec3(0.5 * tau, 0.1, 0.0), Quat(Eigen::AngleAxisd(0.05 * tau, Vec3::UnitZ()))}, p);
    const GapResult r = gap_distance(a, b, p);
    ASSERT_FALSE(r.overlap);
    if (i > 0) {
      gap_jump = std::max(gap_jump, (r.gradient_b - prev_gap).norm());
      euclid_jump = std::max(euclid_jump, (r.euclidean.gradient_b - prev_euclid).norm());
    }
    prev_gap = r.gradient_b;
    prev_euclid = r.euclidean.gradient_b;
  }
  EXPECT_GT(euclid_jump, 0.05);
  EXPECT_LT(gap_jump, 20 * step);
}

// The long-double reference refuses a step it cannot difference with, naming it.
TEST(GapDistance, ExtendedGradientRefusesABadStep) {
  const GapParams p = defaults();
  const GapBody a(Box{Vec3(0.1, 0.1, 0.1)}, Pose{}, p);
  const GapBody b(Box{Vec3(0.1, 0.1, 0.1)}, Pose{Vec3(0.5, 0, 0), Quat::Identity()}, p);
  const GapResult r = gap_distance(a, b, p);
  for (const double step : {0.0, -1e-6, std::nan(""), std::numeric_limits<double>::infinity()}) {
    try {
      gap_gradient_extended(a, b, r, step);
      ADD_FAILURE() << "step " << step << " accepted";
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.field(), "step");
    }
  }
  EXPECT_TRUE(gap_gradient_extended(a, b, r, 1e-6).converged);
}

TEST(GapDistance, BatchEqualsSingleCalls) {
  const GapParams p = defaults();
  std::mt19937_64 rng(12);
  std::vector<std::unique_ptr<GapBody>> bodies;
  std::vector<std::pair<const GapBody*, const GapBody*>> pairs;
  for (size_t i = 0; i < 2 * kBatchBlock + 5; ++i) {  // a partial last block
    bodies.push_back(std::make_unique<GapBody>(test::random_polytope(rng, 10, 0.1),
                                               Pose{Vec3::Zero(), test::random_rotation(rng)}, p));
    bodies.push_back(std::make_unique<GapBody>(Box{Vec3(0.1, 0.2, 0.1)},
                                               Pose{0.3 * test::random_unit(rng), test::random_rotation(rng)}, p));
    pairs.emplace_back(bodies[bodies.size() - 2].get(), bodies.back().get());
  }
  const auto batch = gap_distance_batch(pairs, p, 2);
  std::vector<GapResult> into(pairs.size());
  gap_distance_batch(pairs, p, into, 2);
  ASSERT_EQ(batch.size(), pairs.size());
  for (size_t i = 0; i < pairs.size(); ++i) {
    const GapResult single = gap_distance(*pairs[i].first, *pairs[i].second, p);
    EXPECT_EQ(batch[i].distance, single.distance);
    EXPECT_EQ(batch[i].witness_a, single.witness_a);
    EXPECT_EQ(into[i].distance, single.distance);
    EXPECT_EQ(into[i].witness_b, single.witness_b);
  }
  into.pop_back();
  try {
    gap_distance_batch(pairs, p, into, 2);
    ADD_FAILURE() << "storage for fewer results than pairs accepted";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "results");
  }
}

// Starting from the uncertified GJK answer (no certified Euclidean result) changes nothing in
// GAP's output.
TEST(GapDistance, UncertifiedGjkStartGivesTheSameResult) {
  GapParams certified = defaults(), raw = defaults();
  raw.euclidean = false;
  std::mt19937_64 rng(41);
  int separated = 0;
  for (int i = 0; i < 100; ++i) {
    const GapBody a(test::random_polytope(rng, 10, 0.1), Pose{Vec3::Zero(), test::random_rotation(rng)}, raw);
    const GapBody b(Capsule{0.05, 0.1}, Pose{0.3 * test::random_unit(rng), test::random_rotation(rng)}, raw);
    const GapResult rc = gap_distance(a, b, certified), rr = gap_distance(a, b, raw);
    EXPECT_EQ(rc.overlap, rr.overlap);
    if (rc.overlap) continue;
    ++separated;
    EXPECT_FALSE(rr.euclidean_computed);
    EXPECT_NEAR(rr.distance, rc.distance, 1e-12 * (1 + rc.distance));
    EXPECT_LT((rr.witness_a - rc.witness_a).norm(), 1e-10);
    EXPECT_LT((rr.gradient_a - rc.gradient_a).norm(), 1e-8);
  }
  EXPECT_GT(separated, 30);
}

// Overlap from the uncertified start: its GJK settles a clear overlap with a checked common
// point, the certified path with FCL and libccd. Pairs of every kind moved along their
// Euclidean separating direction n to gaps and depths from 1e-7 to 3 cm: the same verdict and
// Definition 2's answer on overlap. (Moving B along n changes the distance by exactly the move
// while it stays positive; past contact the certified verdict is the reference.)
TEST(GapDistance, OverlapVerdictOfTheGjkStartIsTheCertifiedOne) {
  GapParams certified = defaults(), raw = defaults();
  raw.euclidean = false;
  std::mt19937_64 rng(43);
  const std::vector<Shape> shapes = {Box{Vec3(0.2, 0.1, 0.3)}, Cylinder{0.08, 0.25}, Capsule{0.05, 0.2},
                                     Sphere{0.1}, test::random_polytope(rng, 10, 0.12)};
  int overlaps = 0, apart = 0;
  for (const Shape& sa : shapes)
    for (const Shape& sb : shapes)
      for (int i = 0; i < 6; ++i) {
        const GapBody a(sa, Pose{Vec3::Zero(), test::random_rotation(rng)}, raw);
        GapBody b(sb, Pose{0.6 * test::random_unit(rng), test::random_rotation(rng)}, raw);
        const EuclideanResult e = euclidean_distance(a.euclidean(), a.pose(), b.euclidean(), b.pose());
        ASSERT_GT(e.distance, 1e-3);
        const Vec3 n = (e.witness_b - e.witness_a) / e.distance;
        const Pose base = b.pose();
        for (const double target : {-3e-2, -1e-4, -1e-7, 1e-7, 1e-4}) {
          b.set_pose(Pose{base.position - (e.distance - target) * n, base.rotation});
          const GapResult rc = gap_distance(a, b, certified), rr = gap_distance(a, b, raw);
          SCOPED_TRACE(shape_type_name(sa) + " vs " + shape_type_name(sb) + " at " + std::to_string(target));
          ASSERT_EQ(rr.overlap, rc.overlap);
          if (target > 0) {
            EXPECT_FALSE(rc.overlap);
          }
          if (!rr.overlap) {
            ++apart;
            continue;
          }
          ++overlaps;
          EXPECT_EQ(rr.lambda, 0.0);
          EXPECT_EQ(rr.distance, 0.0);
          EXPECT_EQ(rr.gradient_a.norm() + rr.gradient_b.norm(), 0.0);
          EXPECT_EQ(rr.witness_a, rr.witness_b);
          EXPECT_TRUE(rr.euclidean_computed);
          EXPECT_EQ(rr.euclidean.distance, 0.0);
          EXPECT_EQ(rr.euclidean.witness_a, rr.witness_a);
          // a common point: within 1e-9 of both sets, where e_S ~ Φ(1e-9) ~ 1e-27
          EXPECT_LT(a.p2s().weak(rr.witness_a, 0).value, 1e-20);
          EXPECT_LT(b.p2s().weak(rr.witness_a, 0).value, 1e-20);
        }
      }
  EXPECT_GT(overlaps, 250);
  EXPECT_GT(apart, 250);
}

// The same verdict against closed forms: spheres overlap iff the centres are closer than the
// sum of the radii, axis-aligned boxes iff they overlap along every axis.
TEST(GapDistance, OverlapVerdictMatchesClosedFormsForSpheresAndBoxes) {
  GapParams raw = defaults();
  raw.euclidean = false;
  const GapBody sphere(Sphere{0.1}, Pose{}, raw), box(Box{Vec3(0.2, 0.1, 0.3)}, Pose{}, raw);
  std::mt19937_64 rng(44);
  for (int i = 0; i < 40; ++i)
    for (const double gap : {-5e-2, -1e-6, -1e-8, 1e-8, 1e-6}) {
      const Vec3 u = test::random_unit(rng);
      const GapBody s2(Sphere{0.05}, Pose{(0.15 + gap) * u, test::random_rotation(rng)}, raw);
      const GapResult r = gap_distance(sphere, s2, raw);
      EXPECT_EQ(r.overlap, gap < 0) << gap;
      if (r.overlap) {
        EXPECT_LE(r.witness_a.norm(), 0.1 + 1e-9);
        EXPECT_LE((r.witness_a - s2.pose().position).norm(), 0.05 + 1e-9);
      }
      // Boxes: B offset by the sum of the half sizes plus `gap` along one axis, inside the
      // other axes' overlap.
      const int axis = i % 3;
      Vec3 offset = 0.02 * Vec3(u.x(), u.y(), u.z());
      offset[axis] = (u[axis] < 0 ? -1 : 1) * (0.5 * Vec3(0.2, 0.1, 0.3)[axis] + 0.05 + gap);
      const GapBody b2(Box{Vec3(0.1, 0.1, 0.1)}, Pose{offset, Quat::Identity()}, raw);
      const GapResult rb = gap_distance(box, b2, raw);
      EXPECT_EQ(rb.overlap, gap < 0) << gap;
      if (rb.overlap) {
        EXPECT_LE((rb.witness_a.cwiseAbs() - 0.5 * Vec3(0.2, 0.1, 0.3)).maxCoeff(), 1e-9);
        EXPECT_LE(((rb.witness_a - offset).cwiseAbs() - Vec3::Constant(0.05)).maxCoeff(), 1e-9);
      }
    }
}

TEST(GapDistance, PlainIterationAgreesWithNewton) {
  GapParams newton = defaults(), plain = defaults();
  plain.solver = GapSolver::fixed_point;
  plain.tol = 1e-14;
  plain.max_iter = 3'000'000;
  std::mt19937_64 rng(13);
  for (int i = 0; i < 20; ++i) {
    const GapBody a(Cylinder{0.08, 0.3}, Pose{Vec3::Zero(), test::random_rotation(rng)}, newton);
    const GapBody b(Box{Vec3(0.1, 0.2, 0.1)}, Pose{0.4 * test::random_unit(rng), test::random_rotation(rng)}, newton);
    const GapResult rn = gap_distance(a, b, newton), rp = gap_distance(a, b, plain);
    ASSERT_TRUE(rp.converged);
    EXPECT_LT((rn.witness_a - rp.witness_a).norm(), 1e-10);
    EXPECT_NEAR(rn.distance, rp.distance, 1e-12);
  }
}

}  // namespace
}  // namespace distlab

namespace distlab {
namespace {

// Tracking: the warm-started call from the previous witnesses gives the cold call's answer.
TEST(GapDistance, WarmStartAlongAMotionMatchesColdCalls) {
  const GapParams p;
  std::mt19937_64 rng(31);
  const GapBody a(Box{Vec3(0.1, 0.2, 0.1)}, Pose{}, p);
  GapBody b(Cylinder{0.06, 0.2}, Pose{Vec3(0.3, 0.0, 0.0), Quat::Identity()}, p);
  Vec3 start_a = Vec3(0.15, 0, 0), start_b = start_a;
  int warm_iterations = 0, cold_iterations = 0;
  for (int i = 0; i < 100; ++i) {
    const double t = 0.01 * i;
    b.set_pose(Pose{Vec3(0.3, 0.2 * std::sin(3 * t), 0.1 * t), Quat(Eigen::AngleAxisd(t, Vec3::UnitX()))});
    const GapResult warm = gap_distance_warm(a, b, p, start_a, start_b);
    const GapResult cold = gap_distance(a, b, p);
    ASSERT_TRUE(warm.converged);
    EXPECT_FALSE(warm.euclidean_computed);
    EXPECT_NEAR(warm.distance, cold.distance, 1e-12);
    EXPECT_LT((warm.gradient_b - cold.gradient_b).norm(), 1e-8);
    if (i > 0) warm_iterations += warm.iterations, cold_iterations += cold.iterations;
    start_a = warm.witness_a, start_b = warm.witness_b;
  }
  EXPECT_LT(warm_iterations, cold_iterations);
  // and overlap is still detected
  b.set_pose(Pose{Vec3(0.05, 0, 0), Quat::Identity()});
  EXPECT_TRUE(gap_distance_warm(a, b, p, start_a, start_b).overlap);
}

}  // namespace
}  // namespace distlab

namespace distlab {
namespace {

// predict_witnesses is first-order continuation: its error against the solution at the moved
// poses is of second order in the move, while the old witnesses
// are off by first order. Both shapes move (the rigid carrying of E's derivatives) or one only; the
// solutions at tol 1e-12.
TEST(GapDistance, PredictedWitnessesAreSecondOrderInThePoseChange) {
  const GapParams p;
  std::mt19937_64 rng(51);
  const std::vector<std::pair<Shape, Shape>> pairs = {
      {test::random_polytope(rng, 10, 0.12), Box{Vec3(0.1, 0.2, 0.15)}},
      {Cylinder{0.06, 0.2}, Capsule{0.05, 0.15}},
      {Sphere{0.08}, test::random_polytope(rng, 12, 0.1)}};
  for (const auto& [sa, sb] : pairs)
    for (int moving = 0; moving < 2; ++moving) {
      const Pose pa0{Vec3::Zero(), test::random_rotation(rng)};
      const Pose pb0{0.5 * test::random_unit(rng), test::random_rotation(rng)};
      GapBody a(sa, pa0, p), b(sb, pb0, p);
      ASSERT_GT(gap_distance(a, b, p).euclidean.distance, 0.05);
      const Vec3 mid = 0.5 * (a.pose().position + b.pose().position);
      const WitnessSolution last = solve_newton(a.p2s(), b.p2s(), mid, 1e-12, 100);
      ASSERT_TRUE(last.converged && last.evaluated);
      const Vec3 va = test::random_unit(rng), wa = test::random_unit(rng);
      const Vec3 vb = test::random_unit(rng), wb = test::random_unit(rng);
      double err_pred[2], err_old[2];
      for (int half = 0; half < 2; ++half) {
        const double step = half ? 1.25e-4 : 2e-3;  // metres and radians
        const Pose pa = moving ? Pose{pa0.position + step * va, test::rotate_world(pa0.rotation, step * wa)} : pa0;
        const Pose pb{pb0.position + step * vb, test::rotate_world(pb0.rotation, step * wb)};
        a.set_pose(pa), b.set_pose(pb);
        const WitnessSolution exact = solve_newton(a.p2s(), b.p2s(), last.a, 1e-12, 100, &last.b);
        ASSERT_TRUE(exact.converged);
        Vec3 pred_a, pred_b;
        ASSERT_TRUE(predict_witnesses(last, pa0, pb0, pa, pb, pred_a, pred_b));
        err_pred[half] = std::max((pred_a - exact.a).norm(), (pred_b - exact.b).norm());
        err_old[half] = std::max((last.a - exact.a).norm(), (last.b - exact.b).norm());
      }
      SCOPED_TRACE(shape_type_name(sa) + " vs " + shape_type_name(sb) + (moving ? ", both move" : ", B moves"));
      EXPECT_LT(err_pred[0], 0.1 * err_old[0]);
      EXPECT_LT(err_pred[1], err_pred[0] / 64);  // second order: a 16 times smaller move, ~1/256
      EXPECT_GT(err_old[1], err_old[0] / 32);    // first order: ~1/16
    }
}

// A pair tracked with gap_distance_tracked along a motion of both shapes gives the cold calls'
// answers, in fewer Newton steps than gap_distance_warm from the old witnesses; overlap on the
// way is detected and the track restarts after it.
TEST(GapDistance, TrackedMotionMatchesColdCallsInFewerSteps) {
  const GapParams p;
  std::mt19937_64 rng(52);
  GapBody a(test::random_polytope(rng, 10, 0.1), Pose{}, p);
  GapBody b(Box{Vec3(0.1, 0.15, 0.08)}, Pose{Vec3(0.3, 0.0, 0.0), Quat::Identity()}, p);
  GapTrack track;
  Vec3 start_a = a.pose().position, start_b = b.pose().position;
  int tracked_iterations = 0, warm_iterations = 0;
  for (int i = 0; i < 100; ++i) {
    const double t = 0.01 * i;
    a.set_pose(Pose{Vec3(0, 0.02 * std::sin(2 * t), 0), Quat(Eigen::AngleAxisd(0.3 * t, Vec3::UnitZ()))});
    b.set_pose(Pose{Vec3(0.3, 0.1 * std::sin(3 * t), 0.05 * t), Quat(Eigen::AngleAxisd(t, Vec3::UnitX()))});
    const GapResult tracked = gap_distance_tracked(a, b, p, track);
    const GapResult warm = gap_distance_warm(a, b, p, start_a, start_b);
    const GapResult cold = gap_distance(a, b, p);
    ASSERT_FALSE(cold.overlap);
    ASSERT_TRUE(tracked.converged);
    EXPECT_TRUE(track.valid);
    EXPECT_NEAR(tracked.distance, cold.distance, 1e-12);
    EXPECT_LT((tracked.witness_a - cold.witness_a).norm(), 1e-9);
    EXPECT_LT((tracked.gradient_a - cold.gradient_a).norm() + (tracked.gradient_b - cold.gradient_b).norm(), 1e-8);
    if (i > 1) tracked_iterations += tracked.iterations, warm_iterations += warm.iterations;
    start_a = warm.witness_a, start_b = warm.witness_b;
  }
  EXPECT_LT(tracked_iterations, 0.8 * warm_iterations);
  // B closes in on A by 2 mm and 0.5° a step until they overlap: the tracked call reuses its
  // separating plane only while the motion cannot have closed it, so it sees the overlap at
  // the same step as the cold call.
  const Pose from = b.pose();
  int overlapping = 0;
  for (int i = 1; overlapping < 3; ++i) {
    ASSERT_LT(i, 500);
    b.set_pose(Pose{from.position - 2e-3 * i * (from.position - a.pose().position).normalized(),
                    Quat(Eigen::AngleAxisd(0.5 * M_PI / 180 * i, Vec3::UnitY())) * from.rotation});
    const GapResult tracked = gap_distance_tracked(a, b, p, track), cold = gap_distance(a, b, p);
    ASSERT_EQ(tracked.overlap, cold.overlap) << "step " << i;
    EXPECT_EQ(track.valid, !cold.overlap);
    if (cold.overlap) ++overlapping;
    else EXPECT_NEAR(tracked.distance, cold.distance, 1e-12);
  }
  b.set_pose(Pose{Vec3(0.4, 0, 0), Quat::Identity()});
  const GapResult again = gap_distance_tracked(a, b, p, track), cold = gap_distance(a, b, p);
  EXPECT_NEAR(again.distance, cold.distance, 1e-12);
  EXPECT_TRUE(track.valid);
}

// Along control-loop motions (steps of at most 1 mm and 1°, one or both shapes moving, some
// pairs coming within 1e-5 of contact), a tracked call stops as soon as its error estimate
// allows (solve_predicted), often after the one evaluation at the predicted witnesses: fewer
// than one Newton step a call on average (the predicted start alone took ~1.5), and every
// answer within tol of a converged cold solve (tol 1e-13): witnesses within tol = 1e-10, D
// within 1e-14 relative.
TEST(GapDistance, TrackedCallsStopOnTheirErrorEstimateWithinTolerance) {
  const GapParams p;
  GapParams reference = p;
  reference.tol = 1e-13;
  std::mt19937_64 rng(77);
  std::uniform_real_distribution<double> unit(0, 1);
  auto step_pose = [&](Pose& pose) {
    pose.position += test::random_unit(rng) * (1e-3 * unit(rng));
    pose.rotation = test::rotate_world(pose.rotation, test::random_unit(rng) * (unit(rng) * M_PI / 180));
  };
  const std::vector<std::pair<Shape, Shape>> kinds = {
      {test::random_polytope(rng, 10, 0.1), Box{Vec3(0.1, 0.15, 0.08)}},
      {test::random_polytope(rng, 12, 0.1), test::random_polytope(rng, 8, 0.1)},
      {Cylinder{0.05, 0.2}, Sphere{0.06}},
      {Capsule{0.04, 0.15}, Box{Vec3(0.2, 0.1, 0.05)}}};
  int calls = 0, single = 0, iterations = 0;
  double worst_witness = 0, worst_distance = 0, closest = INFINITY;
  for (const auto& [shape_a, shape_b] : kinds)
    for (const bool both : {false, true}) {
      Pose pa{Vec3::Zero(), test::random_rotation(rng)};
      Pose pb{0.4 * test::random_unit(rng), test::random_rotation(rng)};
      GapBody a(shape_a, pa, p), b(shape_b, pb, p);
      GapTrack track;
      for (int i = 0; i < 150; ++i) {
        if (both) step_pose(pa), a.set_pose(pa);
        step_pose(pb), b.set_pose(pb);
        const GapResult tracked = gap_distance_tracked(a, b, p, track);
        const GapResult cold = gap_distance(a, b, reference);
        ASSERT_FALSE(cold.overlap);
        ASSERT_TRUE(tracked.converged);
        if (i < 2) continue;  // the track's cold start and its first warm call
        ++calls;
        iterations += tracked.iterations;
        if (tracked.iterations == 0) ++single;
        closest = std::min(closest, cold.distance);
        worst_witness = std::max({worst_witness, (tracked.witness_a - cold.witness_a).norm(),
                                  (tracked.witness_b - cold.witness_b).norm()});
        worst_distance = std::max(worst_distance, std::abs(tracked.distance - cold.distance) / cold.distance);
      }
    }
  EXPECT_LT(closest, 1e-4);  // the motions include near contact, where Newton contracts slowly
  EXPECT_LT(iterations, calls);
  EXPECT_GT(single, calls / 10);
  EXPECT_LT(worst_witness, p.tol);
  EXPECT_LT(worst_distance, 1e-14);
}

}  // namespace
}  // namespace distlab
