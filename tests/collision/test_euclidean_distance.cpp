// euclidean_distance against closed forms, and witness points in the world frame.
#include <gtest/gtest.h>

#include "collision/collision_test_util.hpp"

namespace distlab {
namespace {

using test::random_pose;
using test::random_rotation;
using test::world_signed_distance;

// Applies the same rigid motion to a pair of poses (distances are invariant).
Pose moved(const Pose& m, const Pose& p) {
  Pose q;
  q.rotation = (m.rotation * p.rotation).normalized();
  q.position = m.to_world(p.position);
  return q;
}

TEST(EuclideanDistance, SphereSphere) {
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(0.1, 1.0);
  for (int k = 0; k < 50; ++k) {
    const double r1 = u(rng), r2 = u(rng);
    const Pose pa = random_pose(rng, 1.0);
    Pose pb = random_pose(rng, 1.0);
    pb.position = pa.position + test::random_unit(rng) * (r1 + r2 + u(rng));
    const EuclideanResult r = euclidean_distance(EuclideanShape(Sphere{r1}), pa,
                                                 EuclideanShape(Sphere{r2}), pb);
    const Vec3 n = (pb.position - pa.position).normalized();
    EXPECT_NEAR(r.distance, (pb.position - pa.position).norm() - r1 - r2, 1e-12);
    EXPECT_LT((r.witness_a - (pa.position + r1 * n)).norm(), 1e-12);
    EXPECT_LT((r.witness_b - (pb.position - r2 * n)).norm(), 1e-12);
  }
}

// Boxes separated along x whose y/z extents overlap: d = gap along x, in any rotated scene.
TEST(EuclideanDistance, BoxBoxFaceToFace) {
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> u(0.2, 1.0), v(-0.15, 0.15);
  for (int k = 0; k < 50; ++k) {
    const Vec3 sa(u(rng), u(rng), u(rng)), sb(u(rng), u(rng), u(rng));
    const double gap = u(rng);
    Pose pa, pb;
    pb.position = Vec3(0.5 * (sa.x() + sb.x()) + gap, v(rng), v(rng));
    const Pose scene = random_pose(rng, 2.0);
    const Pose wa = moved(scene, pa), wb = moved(scene, pb);
    const EuclideanResult r =
        euclidean_distance(EuclideanShape(Box{sa}), wa, EuclideanShape(Box{sb}), wb);
    EXPECT_NEAR(r.distance, gap, 1e-12);
    // Witnesses: on A's +x face and B's -x face, joined by the scene's x axis.
    const Vec3 la = wa.to_local(r.witness_a), lb = wb.to_local(r.witness_b);
    EXPECT_NEAR(la.x(), 0.5 * sa.x(), 1e-12);
    EXPECT_NEAR(lb.x(), -0.5 * sb.x(), 1e-12);
    EXPECT_LT((r.witness_b - r.witness_a - scene.dir_to_world(Vec3(gap, 0, 0))).norm(), 1e-12);
  }
}

// A cube turned so that a vertex points at the other box: d = gap - s sqrt(3), unique witnesses.
TEST(EuclideanDistance, BoxBoxVertexToFace) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0.2, 1.0), v(-0.1, 0.1);
  for (int k = 0; k < 50; ++k) {
    const double a = u(rng), s = 0.5 * u(rng), gap = u(rng);
    Pose pa, pb;
    pb.rotation = Quat::FromTwoVectors(Vec3(1, 1, 1).normalized(), -Vec3::UnitX());
    pb.position = Vec3(a + s * std::sqrt(3.0) + gap, v(rng), v(rng));
    const Pose scene = random_pose(rng, 2.0);
    const Pose wa = moved(scene, pa), wb = moved(scene, pb);
    const EuclideanResult r = euclidean_distance(EuclideanShape(Box{Vec3::Constant(2 * a)}), wa,
                                                 EuclideanShape(Box{Vec3::Constant(2 * s)}), wb);
    EXPECT_NEAR(r.distance, gap, 1e-12);
    const Vec3 vertex = pb.position - Vec3(s * std::sqrt(3.0), 0, 0);
    EXPECT_LT((r.witness_b - scene.to_world(vertex)).norm(), 1e-10);
    EXPECT_LT((r.witness_a - scene.to_world(Vec3(a, vertex.y(), vertex.z()))).norm(), 1e-10);
  }
}

// A cylinder tilted by theta about x above a wide flat box (a "plane"): the lowest rim point.
TEST(EuclideanDistance, CylinderAbovePlaneLikeBox) {
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> th(0.05, 1.5), u(0.2, 1.0);
  const Box plane{Vec3(20, 20, 1)};
  for (int k = 0; k < 50; ++k) {
    const double r = u(rng), h = 2 * u(rng), theta = th(rng), gap = u(rng);
    const double drop = r * std::sin(theta) + 0.5 * h * std::cos(theta);
    Pose pc;
    pc.rotation = Quat(Eigen::AngleAxisd(theta, Vec3::UnitX()));
    pc.position = Vec3(0.3, -0.2, 0.5 + drop + gap);
    const Pose scene = random_pose(rng, 2.0);
    const Pose wp = moved(scene, Pose{}), wc = moved(scene, pc);
    const EuclideanResult res =
        euclidean_distance(EuclideanShape(plane), wp, EuclideanShape(Cylinder{r, h}), wc);
    EXPECT_NEAR(res.distance, gap, 1e-10);
    const Vec3 low = pc.to_world(Vec3(0, -r, -0.5 * h));
    EXPECT_LT((res.witness_b - scene.to_world(low)).norm(), 1e-6);
    EXPECT_LT((res.witness_a - scene.to_world(Vec3(low.x(), low.y(), 0.5))).norm(), 1e-6);
  }
}

TEST(EuclideanDistance, CapsuleSphere) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0.1, 1.0);
  for (int k = 0; k < 50; ++k) {
    const double rc = u(rng), h = 2 * u(rng), rs = u(rng);
    const Pose pc = random_pose(rng, 1.0);
    Pose ps = random_pose(rng, 1.0);
    const Vec3 axis = pc.dir_to_world(Vec3::UnitZ());
    Vec3 q, c;
    do {
      ps.position = pc.position + test::random_unit(rng) * (rc + rs + 1.5 * u(rng) + h);
      const double t = std::clamp(axis.dot(ps.position - pc.position), -0.5 * h, 0.5 * h);
      q = pc.position + t * axis;  // closest core point
      c = ps.position;
    } while ((c - q).norm() <= rc + rs + 0.05);
    const Vec3 n = (c - q).normalized();
    const EuclideanResult r =
        euclidean_distance(EuclideanShape(Capsule{rc, h}), pc, EuclideanShape(Sphere{rs}), ps);
    EXPECT_NEAR(r.distance, (c - q).norm() - rc - rs, 1e-12);
    EXPECT_LT((r.witness_a - (q + rc * n)).norm(), 1e-10);
    EXPECT_LT((r.witness_b - (c - rs * n)).norm(), 1e-10);
  }
}

// A cube given by its six rows is the same set as the box: same distance, witnesses, gradients.
TEST(EuclideanDistance, PolytopeCubeMatchesBox) {
  const Box box{Vec3(1.0, 0.6, 0.8)};
  MatX3 A;
  VecX b;
  box_halfspaces(box, A, b);
  const EuclideanShape cube(make_polytope(A, b, "a")), as_box(box);
  const EuclideanShape other(Box{Vec3(0.7, 0.9, 0.5)});
  std::mt19937_64 rng(6);
  int checked = 0;
  for (int k = 0; k < 200; ++k) {
    const Pose pa = random_pose(rng, 1.0), pb = random_pose(rng, 1.5);
    const EuclideanResult rb = euclidean_distance(as_box, pa, other, pb);
    const EuclideanResult rp = euclidean_distance(cube, pa, other, pb);
    EXPECT_NEAR(rp.distance, rb.distance, 1e-12);
    if (rb.distance < 1e-3) continue;
    ++checked;
    EXPECT_LT((rp.witness_a - rb.witness_a).norm(), 1e-9);
    EXPECT_LT((rp.witness_b - rb.witness_b).norm(), 1e-9);
    EXPECT_LT((rp.gradient_a - rb.gradient_a).norm(), 1e-9);
    EXPECT_LT((rp.gradient_b - rb.gradient_b).norm(), 1e-9);
  }
  EXPECT_GT(checked, 100);
}

// Every pair, random poses with both shapes moved off the origin (so local-frame witnesses
// would show): witnesses on the surfaces, |wb - wa| = d, and d certified by a separating
// direction; swapping A and B swaps everything.
TEST(EuclideanDistance, WitnessesOnSurfacesInWorldFrame) {
  const auto zoo = test::shape_zoo();
  for (const auto& [na, a] : zoo) {
    for (const auto& [nb, b] : zoo) {
      SCOPED_TRACE(na + " vs " + nb);
      const EuclideanShape ea(a), eb(b);
      std::mt19937_64 rng(7);
      int separated = 0;
      for (int k = 0; k < 60; ++k) {
        const Pose pa = random_pose(rng, 3.0);
        Pose pb = random_pose(rng, 1.0);
        pb.position += pa.position;
        const EuclideanResult r = euclidean_distance(ea, pa, eb, pb);
        if (r.distance < 1e-3) continue;
        ++separated;
        EXPECT_NEAR(world_signed_distance(a, pa, r.witness_a), 0, 1e-9);
        EXPECT_NEAR(world_signed_distance(b, pb, r.witness_b), 0, 1e-9);
        EXPECT_NEAR((r.witness_b - r.witness_a).norm(), r.distance, 1e-12);
        const Vec3 n = (r.witness_b - r.witness_a) / r.distance;
        // Optimality (a looser bound: on flat features it is first order in n's rounding).
        EXPECT_LT(r.distance - test::separation_along(a, pa, b, pb, n), 1e-9);
        const EuclideanResult s = euclidean_distance(eb, pb, ea, pa);
        EXPECT_NEAR(s.distance, r.distance, 1e-12);
        EXPECT_LT((s.witness_a - r.witness_b).norm(), 1e-5);
        EXPECT_LT((s.witness_b - r.witness_a).norm(), 1e-5);
      }
      EXPECT_GT(separated, 20);
    }
  }
}

TEST(EuclideanDistance, OverlapGivesZeroAndCommonWitness) {
  const auto zoo = test::shape_zoo();
  std::mt19937_64 rng(8);
  for (const auto& [na, a] : zoo) {
    for (const auto& [nb, b] : zoo) {
      SCOPED_TRACE(na + " vs " + nb);
      const Pose pa = random_pose(rng, 1.0);
      Pose pb = random_pose(rng, 1.0);
      pb.position = pa.position + 0.1 * test::random_unit(rng);
      const EuclideanResult r = euclidean_distance(EuclideanShape(a), pa, EuclideanShape(b), pb);
      EXPECT_EQ(r.distance, 0.0);
      EXPECT_EQ(r.witness_a, r.witness_b);
      EXPECT_LE(world_signed_distance(a, pa, r.witness_a), 1e-9);
      EXPECT_LE(world_signed_distance(b, pb, r.witness_b), 1e-9);
      EXPECT_EQ(r.gradient_a, Vec6::Zero());
      EXPECT_EQ(r.gradient_b, Vec6::Zero());
    }
  }
}

}  // namespace
}  // namespace distlab
