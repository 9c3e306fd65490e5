// The P2S functions against Definition 1: Properties 1, 2, 4 on random points, derivatives
// against finite differences, the capsule's exact zero set and C² continuity.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include "distlab/gap/point_to_set.hpp"
#include "distlab/geometry/error.hpp"
#include "gap_test_util.hpp"

namespace distlab {
namespace {

std::vector<Shape> sample_shapes(std::mt19937_64& rng) {
  std::vector<Shape> shapes = {Box{Vec3(0.3, 0.2, 0.5)}, Sphere{0.25}, Cylinder{0.15, 0.6},
                               Capsule{0.1, 0.4}};
  for (int rows : {4, 6, 10, 16}) shapes.emplace_back(test::random_polytope(rng, rows, 0.3));
  return shapes;
}

Eigen::Vector3d eigenvalues(const Mat3& H) {
  Eigen::SelfAdjointEigenSolver<Mat3> es;
  es.compute(H, Eigen::EigenvaluesOnly);
  return es.eigenvalues();
}

// A point near the shape: its support point in a random direction plus an offset.
Vec3 near_point(std::mt19937_64& rng, const Shape& s, double lo, double hi) {
  std::uniform_real_distribution<double> u(std::log(lo), std::log(hi));
  return support(s, test::random_unit(rng)) + std::exp(u(rng)) * test::random_unit(rng);
}

TEST(PointToSet, Definition1PropertiesOnRandomPoints) {
  std::mt19937_64 rng(7);
  const BaseFunction phi(0.1, 2);
  for (const Shape& shape : sample_shapes(rng)) {
    const PointToSet p2s(shape, phi, StrictParams{}, P2SOptions{}, "s");
    int outside = 0, inside = 0;
    for (int i = 0; i < 3000; ++i) {
      const Vec3 p = near_point(rng, shape, 1e-4, 2.0);
      const P2SValue weak = p2s.weak(p, 2), strict = p2s.strict(p, 2);
      ASSERT_GE(weak.value, 0.0);  // Property 1
      ASSERT_GE(strict.value, 0.0);
      const auto ew = eigenvalues(weak.hessian), es = eigenvalues(strict.hessian);
      if (weak.value == 0.0) {  // Property 4 and the inside half of Property 2
        ++inside;
        EXPECT_EQ(strict.value, 0.0);
        EXPECT_EQ(strict.gradient.norm(), 0.0);
        EXPECT_EQ(strict.hessian.norm(), 0.0);
      } else {
        ++outside;
        EXPECT_GT(strict.value, 0.0);
        EXPECT_GT(strict.gradient.norm(), 0.0);  // Proposition 1: ∇E = 0 only in S
        EXPECT_GE(ew[0], -1e-14) << shape_type_name(shape);
        EXPECT_LT(ew[2], 1.0) << shape_type_name(shape);
        // > 0 up to the eigen solver's rounding (relative to the largest eigenvalue).
        EXPECT_GT(es[0], -1e-13 * es[2]) << shape_type_name(shape) << " at " << p.transpose();
        EXPECT_LT(es[2], 1.0) << shape_type_name(shape);
      }
    }
    EXPECT_GT(outside, 1000);
    EXPECT_GT(inside, 30) << shape_type_name(shape);
  }
}

// Gradient and Hessian against central differences, in a rotated and translated frame.
TEST(PointToSet, DerivativesMatchFiniteDifferences) {
  std::mt19937_64 rng(11);
  for (int k : {2, 3}) {
    const BaseFunction phi(0.1, k);
    for (const Shape& shape : sample_shapes(rng)) {
      PointToSet p2s(shape, phi, StrictParams{}, P2SOptions{}, "s");
      const Pose pose{Vec3(0.3, -0.2, 0.5), test::random_rotation(rng)};
      p2s.set_pose(pose);
      for (int i = 0; i < 200; ++i) {
        const Vec3 p = pose.to_world(near_point(rng, shape, 1e-2, 1.0));
        for (bool strict : {false, true}) {
          auto f = [&](const Vec3& x, int order) {
            return strict ? p2s.strict(x, order) : p2s.weak(x, order);
          };
          const P2SValue v = f(p, 2);
          const double d = 1e-6;
          for (int c = 0; c < 3; ++c) {
            Vec3 dp = Vec3::Zero();
            dp[c] = d;
            const P2SValue hi = f(p + dp, 1), lo = f(p - dp, 1);
            const double gfd = (f(p + dp, 0).value - f(p - dp, 0).value) / (2 * d);
            EXPECT_NEAR(gfd, v.gradient[c], 1e-7 * (1 + std::abs(v.gradient[c])))
                << shape_type_name(shape) << (strict ? " strict" : " weak");
            const Vec3 hfd = (hi.gradient - lo.gradient) / (2 * d);
            EXPECT_LT((hfd - v.hessian.col(c)).norm(), 1e-6 * (1 + v.hessian.norm()))
                << shape_type_name(shape) << (strict ? " strict" : " weak") << " k=" << k;
          }
        }
      }
    }
  }
}

// The double evaluation in world coordinates (rows, or centre and axis, rotated once in set_pose)
// against the long-double one in the shape's frame (strict_at, the reference of
// gap_gradient_extended), at rotated poses, for every shape kind, relative to the distance t
// from the shape: s = ‖q‖ − r or u·p − b carries ~ε|p| of rounding, which E ∝ Φ(s)² amplifies
// by 2(k + 1) relative to s. A rim, an edge or a vertex makes some violated rows' s ≪ t: polytopes
// get 10× the round shapes' 1e-13/t. Measured: round shapes and boxes ≤ 5.7e-14/t, polytopes
// 1.6e-13/t (and the same before spheres and cylinders moved to world coordinates).
TEST(PointToSet, WorldFrameEvaluationMatchesTheShapeFrameReference) {
  std::mt19937_64 rng(23);
  for (const double h : {0.1, 0.03}) {
    for (const int k : {2, 3}) {
      const BaseFunction phi(h, k);
      for (const Shape& shape : sample_shapes(rng)) {
        PointToSet p2s(shape, phi, StrictParams{}, P2SOptions{}, "s");
        const Pose pose{Vec3(0.3, -0.2, 0.5), test::random_rotation(rng)};
        p2s.set_pose(pose);
        const auto pose_l = PoseT<long double>::from(pose);
        const double bound = std::holds_alternative<Polytope>(shape) ? 1e-12 : 1e-13;
        for (int i = 0; i < 2000; ++i) {
          // At distance t from the shape: its support point along u, moved along u.
          const Vec3 u = test::random_unit(rng);
          const double t = std::exp(std::uniform_real_distribution<double>(std::log(1e-3), 0.0)(rng));
          const Vec3 p = pose.to_world(support(shape, u) + t * u);
          const P2SValue v = p2s.strict(p, 2);
          const auto r = p2s.strict_at<long double>(p.cast<long double>(), pose_l, 2);
          const double value = static_cast<double>(r.value);
          const Vec3 g = r.gradient.cast<double>();
          const Mat3 H = r.hessian.cast<double>();
          ASSERT_GT(value, 0.0);
          const std::string at = shape_type_name(shape) + " h=" + std::to_string(h) + " k=" + std::to_string(k);
          EXPECT_LT(std::abs(v.value - value), bound / t * value) << at;
          EXPECT_LT((v.gradient - g).norm(), bound / t * g.norm()) << at;
          EXPECT_LT((v.hessian - H).norm(), bound / t * H.norm()) << at;
        }
      }
    }
  }
}

double capsule_distance(const Capsule& c, const Vec3& p) {
  const double z = std::clamp(p.z(), -c.height / 2, c.height / 2);
  return (p - Vec3(0, 0, z)).norm() - c.radius;
}

TEST(PointToSet, CapsuleZeroSetIsExactlyTheCapsule) {
  std::mt19937_64 rng(3);
  const Capsule cap{0.1, 0.4};
  const PointToSet p2s(cap, BaseFunction(0.1, 2), StrictParams{}, P2SOptions{}, "s");
  std::uniform_real_distribution<double> u(-0.45, 0.45);
  for (int i = 0; i < 20000; ++i) {
    const Vec3 p(u(rng) * 0.4, u(rng) * 0.4, u(rng));
    const double d = capsule_distance(cap, p);
    if (std::abs(d) < 1e-12) continue;
    EXPECT_EQ(p2s.contains(p), d < 0) << p.transpose() << " d=" << d;
  }
}

// Across the planes z = ±l/2 (cylinder part to cap part) the Hessian has no jump.
TEST(PointToSet, CapsuleHessianIsContinuousAcrossCapPlanes) {
  const Capsule cap{0.1, 0.4};
  const PointToSet p2s(cap, BaseFunction(0.1, 2), StrictParams{}, P2SOptions{}, "s");
  for (double x : {0.15, 0.3, 0.8}) {
    const Vec3 lo(x, 0.02, 0.2 - 1e-9), hi(x, 0.02, 0.2 + 1e-9);
    const Mat3 jump = p2s.weak(hi, 2).hessian - p2s.weak(lo, 2).hessian;
    EXPECT_LT(jump.norm(), 1e-7) << "x=" << x;
    // and the jump of the plain Φ(dist − r) construction would be Φ'(x − r)/x along z:
    const double plain = BaseFunction(0.1, 2).jet(x - 0.1).d1 / x;
    EXPECT_GT(plain, 100 * jump.norm() + 1e-6);
  }
}

TEST(PointToSet, DefaultWeightsUseTheExactViolationCount) {
  const PointToSet box(Box{Vec3(1, 1, 1)}, BaseFunction(0.1, 2), StrictParams{}, P2SOptions{}, "s");
  ASSERT_EQ(box.weights().size(), 6);
  EXPECT_DOUBLE_EQ(box.weights()[0], 1.0 / 3.01);  // a corner violates 3 faces
}

TEST(PointToSet, RejectsBadOptions) {
  const BaseFunction phi(0.1, 2);
  auto field_of = [&](const Shape& s, const P2SOptions& o) -> std::string {
    try {
      PointToSet(s, phi, StrictParams{}, o, "a");
    } catch (const InvalidInput& e) {
      return e.field();
    }
    return "";
  };
  P2SOptions o;
  o.weights = VecX::Constant(5, 0.2);
  EXPECT_EQ(field_of(Box{Vec3(1, 1, 1)}, o), "a.weights");
  o.weights = VecX::Constant(6, 0.2);
  (*o.weights)[3] = -1;
  EXPECT_EQ(field_of(Box{Vec3(1, 1, 1)}, o), "a.weights[3]");
  o.weights.reset();
  o.rho = Ball{Vec3::Zero(), 0.8};  // half diagonal of the unit box is 0.866
  EXPECT_EQ(field_of(Box{Vec3(1, 1, 1)}, o), "a.rho.radius");
  o.rho = Ball{Vec3::Zero(), 0.9};
  EXPECT_EQ(field_of(Box{Vec3(1, 1, 1)}, o), "");
  o.rho = Ball{Vec3(0, 0, 0.5), 0.6};  // covers the sphere of radius 0.1? no: reach 0.6
  EXPECT_EQ(field_of(Sphere{0.1}, o), "a.rho.radius");
}

}  // namespace
}  // namespace distlab
