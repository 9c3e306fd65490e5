// Pose gradients of the distance against central finite differences, every shape pair.
#include <gtest/gtest.h>

#include <cstdio>

#include "collision/collision_test_util.hpp"

namespace distlab {
namespace {

// d distance along coordinate c of the 12 (v_A, w_A, v_B, w_B), by central differences.
double finite_difference(const EuclideanShape& a, const Pose& pa, const EuclideanShape& b,
                         const Pose& pb, int c, double h) {
  const auto perturb = [&](const Pose& p, int k, double s) {
    return k < 3 ? test::translated(p, k, s) : test::rotated(p, k - 3, s);
  };
  const auto dist = [&](double s) {
    return c < 6 ? euclidean_distance(a, perturb(pa, c, s), b, pb).distance
                 : euclidean_distance(a, pa, b, perturb(pb, c - 6, s)).distance;
  };
  return (dist(h) - dist(-h)) / (2 * h);
}

TEST(EuclideanGradient, MatchesFiniteDifferencesForEveryPair) {
  const auto zoo = test::shape_zoo();
  for (const auto& [na, a] : zoo) {
    for (const auto& [nb, b] : zoo) {
      SCOPED_TRACE(na + " vs " + nb);
      const EuclideanShape ea(a), eb(b);
      std::mt19937_64 rng(11);
      int tested = 0;
      double worst = 0;
      while (tested < 25) {
        const Pose pa = test::random_pose(rng, 1.0);
        Pose pb = test::random_pose(rng, 1.5);
        pb.position += pa.position;
        const EuclideanResult r = euclidean_distance(ea, pa, eb, pb);
        if (r.distance < 0.05) continue;
        ++tested;
        for (int c = 0; c < 12; ++c) {
          const double analytic = c < 6 ? r.gradient_a[c] : r.gradient_b[c - 6];
          const double fd = finite_difference(ea, pa, eb, pb, c, 1e-5);
          const double err = std::abs(fd - analytic) / std::max(1.0, std::abs(analytic));
          worst = std::max(worst, err);
          EXPECT_LT(err, 1e-6) << "coordinate " << c << ": analytic " << analytic << ", fd " << fd;
        }
      }
      char buf[32];
      std::snprintf(buf, sizeof buf, "%.2e", worst);
      RecordProperty(na + "_" + nb + "_worst_rel_error", buf);
    }
  }
}

// The gradients are those of rigid motions: translating both shapes together leaves d alone
// (g_vA + g_vB = 0), and so does rotating both about any common point.
TEST(EuclideanGradient, RigidMotionInvariance) {
  const auto zoo = test::shape_zoo();
  std::mt19937_64 rng(12);
  for (const auto& [na, a] : zoo) {
    for (const auto& [nb, b] : zoo) {
      const Pose pa = test::random_pose(rng, 1.0);
      Pose pb = test::random_pose(rng, 1.0);
      pb.position = pa.position + 3.0 * test::random_unit(rng);
      const EuclideanResult r = euclidean_distance(EuclideanShape(a), pa, EuclideanShape(b), pb);
      ASSERT_GT(r.distance, 0) << na << " vs " << nb;
      const Vec3 gva = r.gradient_a.head<3>(), gwa = r.gradient_a.tail<3>();
      const Vec3 gvb = r.gradient_b.head<3>(), gwb = r.gradient_b.tail<3>();
      EXPECT_LT((gva + gvb).norm(), 1e-12);
      EXPECT_NEAR(gva.norm(), 1.0, 1e-12);
      // A common angular velocity w about the world origin moves each origin by w x t.
      const Vec3 total = gwa + gwb + pa.position.cross(gva) + pb.position.cross(gvb);
      EXPECT_LT(total.norm(), 1e-9) << na << " vs " << nb;
    }
  }
}

}  // namespace
}  // namespace distlab
