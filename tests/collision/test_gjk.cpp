// The internal GJK (polish of FCL's answer, repair of MPR's point), tested directly.
#include <gtest/gtest.h>

#include "../../backend/collision/src/gjk.hpp"
#include "collision/collision_test_util.hpp"

namespace distlab {
namespace {

using detail::gjk_closest;
using detail::Placed;

// 30 random poses of a pair: B's origin `offset` from A's, in a random direction.
template <class F>
void for_random_poses(std::mt19937_64& rng, double offset, F&& f) {
  for (int k = 0; k < 30; ++k) {
    const Pose pa = test::random_pose(rng, 1.0);
    Pose pb = test::random_pose(rng, 1.0);
    pb.position = pa.position + offset * test::random_unit(rng);
    f(pa, pb);
  }
}

// for_random_poses over every ordered pair of the shape zoo, each pair from its own seed.
template <class F>
void for_zoo_pairs(std::uint64_t seed, double offset, F&& f) {
  const auto zoo = test::shape_zoo();
  for (const auto& [na, a] : zoo) {
    for (const auto& [nb, b] : zoo) {
      SCOPED_TRACE(na + " vs " + nb);
      std::mt19937_64 rng(seed);
      for_random_poses(rng, offset, [&, &a = a, &b = b](const Pose& pa, const Pose& pb) { f(a, b, pa, pb); });
    }
  }
}

TEST(Gjk, SeparatedPairsBracketTheDistance) {
  for_zoo_pairs(31, 2.5, [&](const Shape& a, const Shape& b, const Pose& pa, const Pose& pb) {
    const EuclideanResult ref = euclidean_distance(EuclideanShape(a), pa, EuclideanShape(b), pb);
    if (ref.distance < 0.05) return;
    // Cold start from an arbitrary direction, tight tolerance.
    const auto g = gjk_closest(Placed(a, pa), Placed(b, pb), Vec3::UnitX(), 1e-13, 1e-12, 128);
    EXPECT_FALSE(g.overlap);
    EXPECT_LE(g.lower, g.upper);
    EXPECT_LT(g.upper - g.lower, 1e-12 * (1 + g.upper));
    EXPECT_NEAR(g.upper, ref.distance, 1e-11);
    EXPECT_NEAR((g.pb - g.pa).norm(), g.upper, 1e-12);
    EXPECT_NEAR(test::world_signed_distance(a, pa, g.pa), 0, 1e-9);
    EXPECT_NEAR(test::world_signed_distance(b, pb, g.pb), 0, 1e-9);
  });
}

TEST(Gjk, OverlapGivesACommonPoint) {
  for_zoo_pairs(32, 0.2, [&](const Shape& a, const Shape& b, const Pose& pa, const Pose& pb) {
    const auto g = gjk_closest(Placed(a, pa), Placed(b, pb), Vec3::UnitY(), 0, 1e-12, 128);
    ASSERT_TRUE(g.overlap);
    const Vec3 p = 0.5 * (g.pa + g.pb);
    EXPECT_LE(test::world_signed_distance(a, pa, p), 1e-12);
    EXPECT_LE(test::world_signed_distance(b, pb, p), 1e-12);
  });
}

// A separating direction that proves the distance exceeds stop_above ends the search early.
TEST(Gjk, StopsOnceSeparationIsProved) {
  const Shape s = Sphere{0.5};
  Pose pb;
  pb.position = Vec3(3, 0, 0);
  const auto g = gjk_closest(Placed(s, Pose{}), Placed(s, pb), Vec3(1, 1, 0), 0, 1e-12, 128, 1e-9);
  EXPECT_GT(g.lower, 1e-9);
  EXPECT_FALSE(g.overlap);
}

// The double-precision start (gjk_distance): on every shape pair, points of A and B whose
// distance is the certified one to ~1e-9 (stalls on curved shapes stop it a little early).
TEST(GjkDistance, MatchesTheCertifiedDistanceOnEveryShapePair) {
  const auto zoo = test::shape_zoo();
  for (const auto& [na, a] : zoo) {
    for (const auto& [nb, b] : zoo) {
      SCOPED_TRACE(na + " vs " + nb);
      std::mt19937_64 rng(33);
      int separated = 0;
      for_random_poses(rng, 2.5, [&, &a = a, &b = b](const Pose& pa, const Pose& pb) {
        const EuclideanResult ref = euclidean_distance(EuclideanShape(a), pa, EuclideanShape(b), pb);
        if (ref.distance < 0.05) return;
        ++separated;
        const double scale = bounding_ball(a).radius + bounding_ball(b).radius;
        const EuclideanResult g = gjk_distance(a, pa, b, pb, scale);
        EXPECT_NEAR(g.distance, ref.distance, 1e-9 * scale);
        EXPECT_NEAR((g.witness_b - g.witness_a).norm(), g.distance, 1e-12);
        EXPECT_NEAR(test::world_signed_distance(a, pa, g.witness_a), 0, 1e-9);
        EXPECT_NEAR(test::world_signed_distance(b, pb, g.witness_b), 0, 1e-9);
      });
      EXPECT_GT(separated, 10);
    }
  }
}

// Stopped at a relative duality gap (the GAP start's kStartRelativeGap): the distance found is
// an upper bound within that fraction of the certified one, and the points are points of A and
// B that far apart; overlap is still 0 (its lower bound never gets above 0).
TEST(GjkDistance, RelativeGapBoundsTheDistanceFound) {
  const double rel = 0.1;
  int stopped_early = 0;
  for_zoo_pairs(35, 2.5, [&](const Shape& a, const Shape& b, const Pose& pa, const Pose& pb) {
    const EuclideanResult ref = euclidean_distance(EuclideanShape(a), pa, EuclideanShape(b), pb);
    const double scale = bounding_ball(a).radius + bounding_ball(b).radius;
    const EuclideanResult g = gjk_distance(a, pa, b, pb, scale, rel);
    if (ref.distance <= 0) {
      EXPECT_EQ(g.distance, 0.0);
      return;
    }
    if (ref.distance < 1e-3) return;
    EXPECT_GE(g.distance, ref.distance - 1e-9 * scale);
    EXPECT_LE(g.distance, ref.distance / (1 - rel) + 1e-9 * scale);
    if (g.distance > ref.distance * (1 + 1e-6)) ++stopped_early;
    EXPECT_NEAR((g.witness_b - g.witness_a).norm(), g.distance, 1e-12);
    EXPECT_LT(test::world_signed_distance(a, pa, g.witness_a), 1e-9);
    EXPECT_LT(test::world_signed_distance(b, pb, g.witness_b), 1e-9);
  });
  EXPECT_GT(stopped_early, 10);  // the relative stop is exercised
}

TEST(GjkDistance, OverlapGivesZero) {
  for_zoo_pairs(34, 0.2, [&](const Shape& a, const Shape& b, const Pose& pa, const Pose& pb) {
    EXPECT_EQ(gjk_distance(a, pa, b, pb, 1.0).distance, 0.0);
    EXPECT_EQ(gjk_distance(a, pa, b, pb, 1.0, 0.1).distance, 0.0);
  });
}

}  // namespace
}  // namespace distlab
