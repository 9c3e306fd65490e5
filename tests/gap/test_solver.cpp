// Witness points: Newton on Lemma 3's min–max against the plain iteration (eq. 2); the fixed
// point itself; Lemma 4's bounds; Propositions 2 and 3; gradients (envelope theorem) against
// finite differences of Λ under rigid motions.
#include <gtest/gtest.h>

#include "distlab/gap/distance.hpp"
#include "distlab/gap/solver.hpp"
#include "gap_test_util.hpp"

namespace distlab {
namespace {

struct Pair {
  PointToSet a, b;
  Vec3 start;
};

PointToSet make(const Shape& s, const Pose& pose, double h = 0.1, int k = 2) {
  PointToSet p(s, BaseFunction(h, k), StrictParams{}, P2SOptions{}, "s");
  p.set_pose(pose);
  return p;
}

// Two random shapes whose bounding balls are `gap` apart; start at A's support point toward B.
Pair random_pair(std::mt19937_64& rng, double gap, int kind) {
  auto shape = [&](int which) -> Shape {
    switch ((kind + which) % 5) {
      case 0:
        return test::random_polytope(rng, 10, 0.15);
      case 1:
        return Box{Vec3(0.2, 0.1, 0.3)};
      case 2:
        return Cylinder{0.08, 0.28};
      case 3:
        return Capsule{0.06, 0.2};
      default:
        return Sphere{0.12};
    }
  };
  const Shape sa = shape(0), sb = shape(1);
  const Ball ba = bounding_ball(sa), bb = bounding_ball(sb);
  const Vec3 dir = test::random_unit(rng);
  const Pose pa{Vec3(0.1, -0.2, 0.3), test::random_rotation(rng)};
  const Pose pb{pa.position + dir * (ba.radius + bb.radius + gap) + Vec3(0, 0, 0),
                test::random_rotation(rng)};
  Pair p{make(sa, pa), make(sb, pb), Vec3::Zero()};
  p.start = pa.to_world(support(sa, pa.dir_to_local(dir)));
  return p;
}

Vec3 fixed_point_residual(const PointToSet& A, const PointToSet& B, const Vec3& a) {
  const Vec3 b = a - B.strict(a, 1).gradient;
  return (b - A.strict(b, 1).gradient) - a;
}

TEST(Solver, NewtonAndPlainIterationReachTheSameFixedPoint) {
  std::mt19937_64 rng(21);
  int compared = 0;
  for (int i = 0; i < 60; ++i) {
    const Pair p = random_pair(rng, 0.05 + 0.1 * (i % 4), i);
    const WitnessSolution n = solve_newton(p.a, p.b, p.start, 1e-12, 100);
    ASSERT_TRUE(n.converged) << i;
    EXPECT_LT(fixed_point_residual(p.a, p.b, n.a).norm(), 1e-12);
    const WitnessSolution f = solve_fixed_point(p.a, p.b, p.start, 1e-15, 2'000'000);
    if (!f.converged) continue;  // contraction too close to 1 for the budget; Newton stands
    ++compared;
    EXPECT_LT((n.a - f.a).norm(), 1e-10) << i;
    EXPECT_LT((n.b - f.b).norm(), 1e-10) << i;
    EXPECT_NEAR(n.lambda, f.lambda, 1e-12 * (1 + f.lambda));
  }
  EXPECT_GT(compared, 40);
}

// Proposition 2: the iteration converges to one point whatever the start.
TEST(Solver, PlainIterationConvergesToAUniquePointFromAnyStart) {
  std::mt19937_64 rng(17);
  for (int i = 0; i < 20; ++i) {
    const Pair p = random_pair(rng, 0.1, i);
    const WitnessSolution ref = solve_fixed_point(p.a, p.b, p.start, 1e-15, 2'000'000);
    ASSERT_TRUE(ref.converged);
    for (int j = 0; j < 3; ++j) {
      const Vec3 start = p.start + 2.0 * test::random_unit(rng);  // far away, any side
      const WitnessSolution s = solve_fixed_point(p.a, p.b, start, 1e-15, 2'000'000);
      ASSERT_TRUE(s.converged);
      EXPECT_LT((s.a - ref.a).norm(), 1e-10);
      const WitnessSolution n = solve_newton(p.a, p.b, start, 1e-12, 200);
      ASSERT_TRUE(n.converged);
      EXPECT_LT((n.a - ref.a).norm(), 1e-10);
    }
  }
}

// Lemma 4: E_B(a) >= Λ for every a in A (in particular the Euclidean witness), and
// Λ >= min_x E_A(x) + E_B(x) > 0 (Proposition 3).
TEST(Solver, Lemma4BoundsAndPositivity) {
  std::mt19937_64 rng(5);
  for (int i = 0; i < 40; ++i) {
    const Pair p = random_pair(rng, 0.02 + 0.05 * (i % 3), i);
    const WitnessSolution n = solve_newton(p.a, p.b, p.start, 1e-12, 100);
    ASSERT_TRUE(n.converged);
    EXPECT_GT(n.lambda, 0.0);
    // Upper bound from points of A: its support points in many directions.
    for (int j = 0; j < 50; ++j) {
      const Vec3 local = support(p.a.shape(), test::random_unit(rng));
      const Vec3 x = p.a.pose().to_world(local);
      EXPECT_GE(p.b.strict(x, 0).value, n.lambda * (1 - 1e-12));
    }
    // Lower bound: minimise the convex E_A + E_B by damped Newton from the witness midpoint.
    Vec3 x = 0.5 * (n.a + n.b);
    for (int it = 0; it < 200; ++it) {
      const P2SValue ea = p.a.strict(x, 2), eb = p.b.strict(x, 2);
      const Vec3 g = ea.gradient + eb.gradient;
      const Mat3 H = ea.hessian + eb.hessian + 1e-14 * Mat3::Identity();
      Vec3 step = -H.ldlt().solve(g);
      double t = 1;
      const double f0 = ea.value + eb.value;
      while (t > 1e-12 && p.a.strict(x + t * step, 0).value + p.b.strict(x + t * step, 0).value > f0)
        t *= 0.5;
      x += t * step;
    }
    const double lower = p.a.strict(x, 0).value + p.b.strict(x, 0).value;
    EXPECT_GT(lower, 0.0);
    EXPECT_GE(n.lambda, lower * (1 - 1e-9));
  }
}

// Proposition 3: Λ decreases to 0 as two boxes approach contact.
TEST(Solver, LambdaVanishesContinuouslyAtContact) {
  const Box box{Vec3(0.2, 0.2, 0.2)};
  const PointToSet a = make(box, Pose{});
  double previous = INFINITY;
  for (double gap : {0.2, 0.1, 0.03, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4}) {
    const Pose pb{Vec3(0.2 + gap, 0.05, -0.03), Quat::Identity()};
    const PointToSet b = make(box, pb);
    const WitnessSolution s = solve_newton(a, b, Vec3(0.1, 0.05, -0.03), 1e-13, 200);
    ASSERT_TRUE(s.converged) << gap;
    EXPECT_GT(s.lambda, 0.0);
    EXPECT_LT(s.lambda, previous);
    previous = s.lambda;
  }
  EXPECT_LT(previous, 1e-15);
}

// The envelope-theorem gradients against central differences of Λ in all 12 pose coordinates.
TEST(Solver, LambdaGradientsMatchFiniteDifferences) {
  std::mt19937_64 rng(99);
  for (int i = 0; i < 25; ++i) {
    Pair p = random_pair(rng, 0.05 + 0.05 * (i % 3), i);
    const WitnessSolution s = solve_newton(p.a, p.b, p.start, 1e-13, 100);
    ASSERT_TRUE(s.converged);
    Vec6 ga, gb;
    lambda_gradients(s, p.a.pose(), p.b.pose(), ga, gb);
    const double d = 1e-6;
    for (int which = 0; which < 2; ++which) {
      PointToSet& moved = which == 0 ? p.a : p.b;
      const Pose base = moved.pose();
      for (int c = 0; c < 6; ++c) {
        double value[2];
        for (int sgn = 0; sgn < 2; ++sgn) {
          moved.set_pose(test::perturbed(base, c, sgn ? d : -d));
          value[sgn] = solve_newton(p.a, p.b, s.a, 1e-14, 100).lambda;
        }
        moved.set_pose(base);
        const double fd = (value[1] - value[0]) / (2 * d);
        const double want = which == 0 ? ga[c] : gb[c];
        EXPECT_NEAR(fd, want, 1e-7 * (1 + std::abs(want))) << "pair " << i << " shape " << which
                                                           << " coord " << c;
      }
    }
  }
}

}  // namespace
}  // namespace distlab
