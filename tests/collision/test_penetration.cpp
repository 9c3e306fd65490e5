// penetration() against closed forms (sphere/sphere, axis-aligned box/box) and, for every shape
// pair, the definition: B moved by the depth along the direction only just stops overlapping.
#include <gtest/gtest.h>

#include <cstdio>
#include <limits>
#include <string>

#include "collision/collision_test_util.hpp"

namespace distlab {
namespace {

using test::random_pose;
using test::world_signed_distance;

TEST(Penetration, SphereSphereClosedForm) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0.1, 1.0), f(0.05, 0.95);
  double worst = 0;
  for (int k = 0; k < 50; ++k) {
    const double r1 = u(rng), r2 = u(rng);
    const Pose pa = random_pose(rng, 1.0);
    Pose pb = random_pose(rng, 1.0);
    // Centres apart by a fraction of r1 + r2 (not concentric: the direction is then defined).
    const Vec3 e = test::random_unit(rng);
    const double L = std::max(f(rng) * (r1 + r2), 0.05);
    pb.position = pa.position + L * e;
    const auto p = penetration(EuclideanShape(Sphere{r1}), pa, EuclideanShape(Sphere{r2}), pb);
    ASSERT_TRUE(p.has_value());
    const double depth = r1 + r2 - L;
    worst = std::max({worst, std::abs(p->depth - depth), (p->direction - e).norm()});
    EXPECT_NEAR(p->depth, depth, 1e-9 * (r1 + r2));
    EXPECT_LT((p->direction - e).norm(), 1e-6);
    EXPECT_LT((p->witness_a - (pa.position + r1 * e)).norm(), 1e-6);
    EXPECT_LT((p->witness_b - (pb.position - r2 * e)).norm(), 1e-6);
  }
  std::printf("sphere/sphere: worst depth or direction error %.3g\n", worst);
}

// Axis-aligned boxes overlapping by o_i = (a_i + b_i)/2 - |c_i| along each axis: the depth is the
// smallest o_i, along that axis towards B, in any rotated scene.
TEST(Penetration, BoxBoxAxisAligned) {
  std::mt19937_64 rng(12);
  std::uniform_real_distribution<double> u(0.3, 1.0), s(-1, 1);
  for (int k = 0; k < 50; ++k) {
    const Vec3 sa(u(rng), u(rng), u(rng)), sb(u(rng), u(rng), u(rng));
    const Vec3 half = 0.5 * (sa + sb);
    const int axis = k % 3;
    Vec3 c;
    for (int i = 0; i < 3; ++i) c[i] = s(rng) * 0.3 * half[i];  // overlap >= 0.7 half_i
    c[axis] = (s(rng) < 0 ? -1 : 1) * 0.9 * half[axis];         // the shallowest axis: 0.1 half
    Vec3 o = half - c.cwiseAbs();
    Eigen::Index best;
    const double depth = o.minCoeff(&best);
    const Pose scene = random_pose(rng, 2.0);
    Pose wa = scene, wb = scene;
    wb.position = scene.to_world(c);
    const auto p = penetration(EuclideanShape(Box{sa}), wa, EuclideanShape(Box{sb}), wb);
    ASSERT_TRUE(p.has_value());
    const Vec3 n = scene.dir_to_world(Vec3::Unit(best) * (c[best] < 0 ? -1.0 : 1.0));
    EXPECT_NEAR(p->depth, depth, 1e-12);
    EXPECT_LT((p->direction - n).norm(), 1e-9);
    // Witnesses on A's face towards B and on B's face towards A, depth apart along n.
    EXPECT_NEAR(std::abs(world_signed_distance(Box{sa}, wa, p->witness_a)), 0, 1e-9);
    EXPECT_NEAR(std::abs(world_signed_distance(Box{sb}, wb, p->witness_b)), 0, 1e-9);
    EXPECT_LT((p->witness_a - p->witness_b - depth * n).norm(), 1e-9);
  }
}

// The depth is the overlap min over unit n of h_A(n) + h_B(-n) (h: support value, B's seen from
// A); a second method: the minimum over 20k directions spread on the sphere.
double sampled_depth(const Shape& a, const Pose& pa, const Shape& b, const Pose& pb) {
  double best = std::numeric_limits<double>::infinity();
  const int n = 20000;
  for (int i = 0; i < n; ++i) {
    const double z = 1 - (2 * i + 1.0) / n, r = std::sqrt(1 - z * z), phi = 2.399963229728653 * i;
    const Vec3 d(r * std::cos(phi), r * std::sin(phi), z);
    best = std::min(best, -test::separation_along(a, pa, b, pb, d));
  }
  return best;
}

// Every pair of the zoo, overlapping at random: the depth is not above the sampled minimum, B
// moved by the depth along the direction touches A (apart just beyond, overlapping just short of
// it), and the witness points lie on the shapes' supporting planes, depth apart along n.
TEST(Penetration, EveryPairSeparatesByTheDepth) {
  std::mt19937_64 rng(13);
  const auto zoo = test::shape_zoo();
  int checked = 0;
  double worst_rel = 0;
  for (const auto& [na, a] : zoo)
    for (const auto& [nb, b] : zoo)
      for (int k = 0; k < 10; ++k) {
        const Pose pa = random_pose(rng, 0.2), pb = random_pose(rng, 0.2);
        const EuclideanShape ea(a), eb(b);
        if (euclidean_distance(ea, pa, eb, pb).distance > 0) continue;
        const auto p = penetration(ea, pa, eb, pb);
        const std::string pair = na + "/" + nb;
        ASSERT_TRUE(p.has_value()) << pair;
        ++checked;
        const Vec3 n = p->direction;
        EXPECT_NEAR(n.norm(), 1, 1e-12);
        EXPECT_GT(p->depth, 0) << pair;
        const double sampled = sampled_depth(a, pa, b, pb);
        EXPECT_LE(p->depth, sampled + 1e-12) << pair;
        worst_rel = std::max(worst_rel, (p->depth - sampled) / sampled);
        EXPECT_NEAR(p->depth, -test::separation_along(a, pa, b, pb, n), 1e-12) << pair;
        Pose out = pb, in = pb;
        out.position += (p->depth + 1e-7) * n;
        in.position += (p->depth - 1e-7) * n;
        EXPECT_GT(euclidean_distance(ea, pa, eb, out).distance, 0) << pair;
        EXPECT_EQ(euclidean_distance(ea, pa, eb, in).distance, 0) << pair;
        EXPECT_NEAR(n.dot(p->witness_a), n.dot(test::world_support(a, pa, n)), 1e-8) << pair;
        EXPECT_NEAR(n.dot(p->witness_b), n.dot(test::world_support(b, pb, -n)), 1e-8) << pair;
        EXPECT_LT((p->witness_a - p->witness_b - p->depth * n).norm(), 1e-8) << pair;
        EXPECT_LT(std::abs(world_signed_distance(a, pa, p->witness_a)), 1e-8) << pair;
        EXPECT_LT(std::abs(world_signed_distance(b, pb, p->witness_b)), 1e-8) << pair;
      }
  EXPECT_GT(checked, 100);
  // Below 0 where the sampling's spacing (about 0.025 rad) leaves it above the true minimum.
  std::printf("%d overlapping pairs; largest (depth - sampled) / sampled: %.3g\n", checked, worst_rel);
}

TEST(Penetration, ApartIsNullopt) {
  Pose pb;
  pb.position = Vec3(3, 0, 0);
  EXPECT_FALSE(penetration(EuclideanShape(Sphere{1}), Pose{}, EuclideanShape(Sphere{1}), pb));
}

}  // namespace
}  // namespace distlab
