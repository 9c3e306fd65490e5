// common_point: inside both shapes when they overlap, nullopt when separated, and agreement
// with FCL's signed distance away from contact.
#include <gtest/gtest.h>

#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>

#include "collision/collision_test_util.hpp"

namespace distlab {
namespace {

using test::random_pose;
using test::world_signed_distance;

fcl::Transform3d to_fcl(const Pose& p) {
  fcl::Transform3d tf = fcl::Transform3d::Identity();
  tf.linear() = p.R();
  tf.translation() = p.position;
  return tf;
}

// Raw FCL (libccd): the distance when separated, minus the contact's penetration depth when
// colliding. (FCL 0.7's signed-distance EPA trips an assertion on some polytope pairs.)
double fcl_signed_distance(const EuclideanShape& a, const Pose& pa, const EuclideanShape& b,
                           const Pose& pb) {
  fcl::DistanceRequestd request(false, false, 0, 0, 1e-9, fcl::GST_LIBCCD);
  fcl::DistanceResultd result;
  const double d = fcl::distance(a.fcl_geometry().get(), to_fcl(pa), b.fcl_geometry().get(),
                                 to_fcl(pb), request, result);
  if (d > 0) return d;
  fcl::CollisionRequestd creq(1, true);
  creq.gjk_solver_type = fcl::GST_LIBCCD;
  fcl::CollisionResultd cres;
  fcl::collide(a.fcl_geometry().get(), to_fcl(pa), b.fcl_geometry().get(), to_fcl(pb), creq, cres);
  return cres.isCollision() ? -cres.getContact(0).penetration_depth : 0.0;
}

TEST(CommonPoint, InsideBothForOverlappingPairs) {
  const auto zoo = test::shape_zoo();
  for (const auto& [na, a] : zoo) {
    for (const auto& [nb, b] : zoo) {
      SCOPED_TRACE(na + " vs " + nb);
      std::mt19937_64 rng(21);
      std::uniform_real_distribution<double> u(-1, 1);
      for (int k = 0; k < 100; ++k) {
        // B's origin at a random point of A (rejection sampling in A's bounding box): overlap.
        const Pose pa = random_pose(rng, 1.0);
        Vec3 local;
        do local = Vec3(u(rng), u(rng), u(rng));
        while (test::signed_distance(a, local) > 0);
        Pose pb = random_pose(rng, 1.0);
        pb.position = pa.to_world(local);
        const auto p = common_point(a, pa, b, pb);
        ASSERT_TRUE(p.has_value());
        EXPECT_LE(world_signed_distance(a, pa, *p), 1e-9);
        EXPECT_LE(world_signed_distance(b, pb, *p), 1e-9);
      }
    }
  }
}

TEST(CommonPoint, AgreesWithFclAndSeparatedGivesNullopt) {
  const auto zoo = test::shape_zoo();
  for (const auto& [na, a] : zoo) {
    for (const auto& [nb, b] : zoo) {
      SCOPED_TRACE(na + " vs " + nb);
      const EuclideanShape ea(a), eb(b);
      std::mt19937_64 rng(22);
      int hits = 0, misses = 0;
      for (int k = 0; k < 200; ++k) {
        const Pose pa = random_pose(rng, 1.0);
        Pose pb = random_pose(rng, 0.8);
        pb.position += pa.position;
        const double d = fcl_signed_distance(ea, pa, eb, pb);
        if (std::abs(d) < 1e-6) continue;  // contact: either answer is right
        const auto p = common_point(a, pa, b, pb);
        EXPECT_EQ(p.has_value(), d < 0) << "FCL signed distance " << d;
        EXPECT_EQ(euclidean_distance(ea, pa, eb, pb).distance == 0, d < 0);
        if (p) {
          ++hits;
          EXPECT_LE(world_signed_distance(a, pa, *p), 1e-9);
          EXPECT_LE(world_signed_distance(b, pb, *p), 1e-9);
        } else {
          ++misses;
        }
      }
      EXPECT_GT(hits, 20);
      EXPECT_GT(misses, 20);
    }
  }
}

// Boxes a hair apart or a hair into each other, in a rotated scene: nothing breaks at contact.
TEST(CommonPoint, NearTouchingBoxes) {
  std::mt19937_64 rng(23);
  const Box box{Vec3(1, 1, 1)};
  const EuclideanShape e(box);
  for (double gap : {1e-6, 1e-7, -1e-7, -1e-6}) {
    for (int k = 0; k < 20; ++k) {
      const Pose scene = random_pose(rng, 2.0);
      Pose pa = scene, pb = scene;
      pb.position = scene.to_world(Vec3(1 + gap, 0.3, -0.2));
      const auto p = common_point(box, pa, box, pb);
      const EuclideanResult r = euclidean_distance(e, pa, e, pb);
      EXPECT_EQ(p.has_value(), gap < 0) << "gap " << gap;
      if (gap > 0) {
        EXPECT_NEAR(r.distance, gap, 1e-12);
      } else {
        ASSERT_TRUE(p.has_value());
        EXPECT_EQ(r.distance, 0.0);
        EXPECT_LE(world_signed_distance(box, pa, *p), 1e-9);
        EXPECT_LE(world_signed_distance(box, pb, *p), 1e-9);
      }
    }
  }
}

// Shallow overlaps and hair-thin gaps, built by sliding B along the nearest-point direction of
// a separated pair. Sliding by d + depth overlaps whenever B is a sphere or a capsule (a ball of
// B touches the witness from inside); sliding by d - gap leaves exactly `gap` for every pair.
// libccd's GJK alone misses about one in four such overlaps at depth 1e-6.
TEST(CommonPoint, ShallowOverlapsAndThinGaps) {
  const auto zoo = test::shape_zoo();
  for (const auto& [na, a] : zoo) {
    for (const auto& [nb, b] : zoo) {
      SCOPED_TRACE(na + " vs " + nb);
      const EuclideanShape ea(a), eb(b);
      const bool ball_inside_b = nb == "sphere" || nb == "capsule";
      std::mt19937_64 rng(25);
      for (int k = 0; k < 40; ++k) {
        const Pose pa = random_pose(rng, 1.0);
        Pose pb = random_pose(rng, 1.5);
        pb.position += pa.position;
        const EuclideanResult r = euclidean_distance(ea, pa, eb, pb);
        if (r.distance < 0.01) continue;
        const Vec3 n = (r.witness_b - r.witness_a) / r.distance;
        for (double shift : {1e-6, 1e-8, -1e-7}) {
          Pose moved = pb;
          moved.position -= (r.distance + shift) * n;
          const auto p = common_point(a, pa, b, moved);
          const EuclideanResult m = euclidean_distance(ea, pa, eb, moved);
          EXPECT_EQ(p.has_value(), m.distance == 0) << "shift " << shift;
          if (shift < 0) {
            EXPECT_FALSE(p.has_value());
            EXPECT_NEAR(m.distance, -shift, 1e-9);
          } else if (ball_inside_b) {
            EXPECT_TRUE(p.has_value()) << "overlap " << shift;
          }
          if (p) {
            EXPECT_LE(world_signed_distance(a, pa, *p), 1e-9);
            EXPECT_LE(world_signed_distance(b, moved, *p), 1e-9);
          }
        }
      }
    }
  }
}

// Exactly touching or within the touch tolerance: the two answers stay consistent.
TEST(CommonPoint, TouchingIsConsistentWithDistance) {
  std::mt19937_64 rng(24);
  const Sphere s{0.5};
  const EuclideanShape e(s);
  for (double gap : {0.0, 1e-12, 5e-10, -1e-12}) {
    const Pose pa = random_pose(rng, 1.0);
    Pose pb = random_pose(rng, 1.0);
    pb.position = pa.position + test::random_unit(rng) * (1.0 + gap);
    const auto p = common_point(s, pa, s, pb);
    const EuclideanResult r = euclidean_distance(e, pa, e, pb);
    EXPECT_LE(r.distance, 1e-9);
    if (p) {
      EXPECT_LE(world_signed_distance(s, pa, *p), 1e-9);
      EXPECT_LE(world_signed_distance(s, pb, *p), 1e-9);
    }
    if (r.distance == 0) {
      EXPECT_LE(world_signed_distance(s, pa, r.witness_a), 1e-9);
      EXPECT_LE(world_signed_distance(s, pb, r.witness_a), 1e-9);
    }
  }
}

}  // namespace
}  // namespace distlab
