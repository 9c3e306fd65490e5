// The Property 2 verdict cache: a repeated shape is answered from the cache with the same
// verdict; any defining number (shape, weights, ρ ball, ε, σ, h, k) changes the key; the
// cache is bounded and evicts the least recently used; concurrent callers agree. A hull's
// weights are computed once per hull and margin.
#include <gtest/gtest.h>

#include <numbers>
#include <thread>

#include "distlab/gap/validator.hpp"
#include "gap_test_util.hpp"

namespace distlab {
namespace {

PointToSet make(const Shape& s, double sigma = StrictParams{}.sigma, double h = 0.1) {
  StrictParams strict;
  strict.sigma = sigma;
  return PointToSet(s, BaseFunction(h, 2), strict, P2SOptions{}, "a");
}

void expect_same(const ValidationReport& a, const ValidationReport& b) {
  EXPECT_EQ(a.ok, b.ok);
  EXPECT_EQ(a.max_eigenvalue, b.max_eigenvalue);
  EXPECT_EQ(a.worst_point, b.worst_point);
  EXPECT_EQ(a.samples, b.samples);
  EXPECT_EQ(a.message, b.message);
}

TEST(ValidatorCache, IsDeterministicAndAnswersARepeatedShapeFromTheCache) {
  clear_validation_cache();
  const PointToSet p2s = make(Cylinder{0.1, 0.3});
  const ValidationReport first = validate_p2s(p2s, 500, 9);
  EXPECT_FALSE(first.cached);
  clear_validation_cache();
  const ValidationReport again = validate_p2s(p2s, 500, 9);  // computed again: deterministic
  expect_same(first, again);
  // The pose does not matter: the check runs in the shape frame.
  PointToSet moved = p2s;
  moved.set_pose(Pose{Vec3(1, 2, 3), Quat(Eigen::AngleAxisd(0.7, Vec3::UnitY()))});
  const ValidationReport hit = validate_p2s(moved, 500, 9);
  EXPECT_TRUE(hit.cached);
  expect_same(first, hit);
  const CacheStats st = validation_cache_stats();
  EXPECT_EQ(st.entries, 1u);
  EXPECT_EQ(st.hits, 1u);
  EXPECT_LE(st.bytes, st.capacity);
}

TEST(ValidatorCache, EveryDefiningNumberChangesTheKey) {
  clear_validation_cache();
  validate_p2s(make(Box{Vec3(0.1, 0.2, 0.3)}), 200);
  EXPECT_FALSE(validate_p2s(make(Box{Vec3(0.1, 0.2, 0.30001)}), 200).cached);
  EXPECT_FALSE(validate_p2s(make(Box{Vec3(0.1, 0.2, 0.3)}, 0.9), 200).cached);
  EXPECT_FALSE(validate_p2s(make(Box{Vec3(0.1, 0.2, 0.3)}, StrictParams{}.sigma, 0.2), 200).cached);
  P2SOptions rho;
  rho.rho = Ball{Vec3(0.01, 0, 0), 0.4};
  EXPECT_FALSE(validate_p2s(PointToSet(Box{Vec3(0.1, 0.2, 0.3)}, BaseFunction(0.1, 2),
                                       StrictParams{}, rho, "a"),
                            200)
                   .cached);
  P2SOptions weights;
  weights.weights = VecX::Constant(6, 0.2);
  EXPECT_FALSE(validate_p2s(PointToSet(Box{Vec3(0.1, 0.2, 0.3)}, BaseFunction(0.1, 2),
                                       StrictParams{}, weights, "a"),
                            200)
                   .cached);
  EXPECT_FALSE(validate_p2s(make(Box{Vec3(0.1, 0.2, 0.3)}), 201).cached);  // other samples
  EXPECT_TRUE(validate_p2s(make(Box{Vec3(0.1, 0.2, 0.3)}), 200).cached);
  EXPECT_EQ(validation_cache_stats().entries, 7u);
}

TEST(ValidatorCache, StaysWithinItsCapacityAndEvictsTheLeastRecentlyUsed) {
  clear_validation_cache();
  const PointToSet a = make(Sphere{0.1}), b = make(Sphere{0.2}), c = make(Sphere{0.3});
  validate_p2s(a, 100);
  const std::size_t one = validation_cache_stats().bytes;
  ASSERT_GT(one, 0u);
  set_validation_cache_capacity(2 * one + one / 2);  // room for two entries
  validate_p2s(b, 100);
  EXPECT_TRUE(validate_p2s(a, 100).cached);  // a is now the most recently used
  validate_p2s(c, 100);                      // evicts b
  const CacheStats st = validation_cache_stats();
  EXPECT_EQ(st.entries, 2u);
  EXPECT_LE(st.bytes, st.capacity);
  EXPECT_TRUE(validate_p2s(a, 100).cached);
  EXPECT_TRUE(validate_p2s(c, 100).cached);
  EXPECT_FALSE(validate_p2s(b, 100).cached);
  set_validation_cache_capacity(kValidationCacheBytes);
}

TEST(ValidatorCache, ConcurrentCallersGetTheSequentialVerdicts) {
  std::mt19937_64 rng(3);
  std::vector<PointToSet> shapes;
  for (int i = 0; i < 6; ++i) shapes.push_back(make(test::random_polytope(rng, 8 + i, 0.1)));
  shapes.push_back(make(Box{Vec3(0.5, 0.5, 0.5)}, 0.999));
  clear_validation_cache();
  std::vector<ValidationReport> sequential;
  for (const auto& s : shapes) sequential.push_back(validate_p2s(s, 300));
  clear_validation_cache();
  std::vector<std::vector<ValidationReport>> got(4);
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([&, t] {
      for (int round = 0; round < 3; ++round)
        for (std::size_t i = 0; i < shapes.size(); ++i)
          got[t].push_back(validate_p2s(shapes[(i + t) % shapes.size()], 300));
    });
  for (auto& th : threads) th.join();
  for (int t = 0; t < 4; ++t)
    for (std::size_t k = 0; k < got[t].size(); ++k)
      expect_same(got[t][k], sequential[(k % shapes.size() + t) % shapes.size()]);
  EXPECT_EQ(validation_cache_stats().entries, shapes.size());
}

// A prism of `sides` sides, radius 4 cm, `height` long, as a mesh's hull.
Polytope prism_hull(int sides, double height) {
  std::vector<Vec3> points;
  for (int k = 0; k < sides; ++k) {
    const double t = 2 * std::numbers::pi * k / sides;
    for (double z : {-height / 2, height / 2}) points.emplace_back(0.04 * std::cos(t), 0.04 * std::sin(t), z);
  }
  return polytope_from_points(points, "hull");
}

TEST(HullWeightCache, ComputesAHullsWeightsOncePerHullAndMargin) {
  clear_hull_weight_cache();
  const Polytope hull = prism_hull(200, 0.16);
  const VecX first = make(hull).weights();
  CacheStats st = hull_weight_cache_stats();
  EXPECT_EQ(st.misses, 1u);
  EXPECT_EQ(st.hits, 0u);
  EXPECT_TRUE(make(hull).weights() == first);  // from the cache, bit for bit
  EXPECT_EQ(hull_weight_cache_stats().hits, 1u);
  clear_hull_weight_cache();
  EXPECT_TRUE(make(hull).weights() == first);  // computed again: deterministic

  // Another margin is another entry: W = w / (K (1 + margin)).
  P2SOptions wider;
  wider.weight_margin = 0.02;
  const VecX w2 = PointToSet(hull, BaseFunction(0.1, 2), StrictParams{}, wider, "a").weights();
  EXPECT_TRUE(w2.isApprox(first * (1.01 / 1.02), 1e-14));
  // A longer prism has the same row normals but larger sides: the key holds the geometry, and
  // its sides weigh more against its caps than the short prism's do.
  const Polytope longer = prism_hull(200, 0.32);
  const VecX w3 = make(longer).weights();
  st = hull_weight_cache_stats();
  EXPECT_EQ(st.misses, 3u);
  EXPECT_EQ(st.entries, 3u);
  const auto side_over_cap = [](const Polytope& p, const VecX& w) {
    Eigen::Index cap = 0, side = 0;
    p.A.col(2).maxCoeff(&cap);
    p.A.col(0).maxCoeff(&side);
    return w[side] / w[cap];
  };
  EXPECT_GT(side_over_cap(longer, w3), 1.5 * side_over_cap(hull, first));
}

}  // namespace
}  // namespace distlab
