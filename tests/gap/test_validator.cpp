// The Property 2 validator: accepts the documented defaults, refuses parameters that break
// 0 < ∂²E < I, and reports an eigenvalue that a direct evaluation confirms.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <numbers>

#include "distlab/gap/validator.hpp"
#include "gap_test_util.hpp"
#include "hessian_search.hpp"

namespace distlab {
namespace {

double max_eigenvalue_at(const PointToSet& p2s, const Vec3& p) {
  Eigen::SelfAdjointEigenSolver<Mat3> es(p2s.strict(p, 2).hessian, Eigen::EigenvaluesOnly);
  return es.eigenvalues()[2];
}

TEST(Validator, AcceptsDefaultsOnEveryShapeType) {
  std::mt19937_64 rng(2);
  std::vector<Shape> shapes = {Box{Vec3(0.05, 0.21, 0.1)}, Box{Vec3(0.35, 0.05, 0.9)},
                               Sphere{0.1}, Cylinder{0.08, 0.28},
                               Capsule{0.05, 0.2}, test::random_polytope(rng, 10, 0.1),
                               test::random_polytope(rng, 20, 0.3)};
  for (const Shape& s : shapes) {
    const PointToSet p2s(s, BaseFunction(0.1, 2), StrictParams{}, P2SOptions{}, "a");
    const ValidationReport r = validate_p2s(p2s, 3000, 3);
    EXPECT_TRUE(r.ok) << shape_type_name(s) << ": " << r.message;
    EXPECT_GT(r.max_eigenvalue, 0.1);
    EXPECT_LT(r.max_eigenvalue, 1.0);
    EXPECT_EQ(r.max_inside_norm, 0.0);
  }
}

TEST(Validator, RefusesWeightsThatBreakProperty2) {
  P2SOptions heavy;
  heavy.weights = VecX::Constant(6, 5.0);
  const PointToSet p2s(Box{Vec3(0.2, 0.2, 0.2)}, BaseFunction(0.1, 2), StrictParams{}, heavy, "a");
  const ValidationReport r = validate_p2s(p2s, 2000, 1);
  EXPECT_FALSE(r.ok);
  EXPECT_GE(r.max_eigenvalue, 1.0);
  // The reported worst point really has that eigenvalue.
  EXPECT_NEAR(max_eigenvalue_at(p2s, r.worst_point), r.max_eigenvalue, 1e-12 * r.max_eigenvalue);
  EXPECT_NE(r.message.find("Property 2"), std::string::npos);
  // e_S's own Hessian (Σ W_i Φ'' u_i u_iᵀ, up to 3 × 5 at a corner) is what breaks it.
  EXPECT_NE(r.message.find("the Hessian of e_S alone has eigenvalue"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find("decrease the weights or sigma"), std::string::npos) << r.message;
}

// The published package's ρ ball (R² = 1.2 × half diagonal²) breaks Property 2 for a gripper-
// sized box with ε = 0.01 — the reason distlab's default ball is larger (kDefaultRhoScale).
TEST(Validator, RefusesThePackagesTightRhoBallOnAGripperBox) {
  const Box box{Vec3(0.05, 0.21, 0.1)};
  P2SOptions tight;
  tight.rho = Ball{Vec3::Zero(), bounding_ball(box).radius * std::sqrt(1.2)};
  const PointToSet p2s(box, BaseFunction(0.1, 2), StrictParams{}, tight, "a");
  const ValidationReport r = validate_p2s(p2s, 3000, 1);
  EXPECT_FALSE(r.ok);
  EXPECT_GT(max_eigenvalue_at(p2s, r.worst_point), 1.0);
}

}  // namespace
}  // namespace distlab

namespace distlab {
namespace {

// On random polytopes the verdicts are right both ways: a refusal names a point whose Hessian
// (checked by finite differences of the gradient) really has an eigenvalue >= 1, and an
// acceptance survives an independent sampling. Rounding-level negative eigenvalues (−1e-46
// next to 1e-30) must not count as non-convexity.
TEST(Validator, VerdictsOnRandomPolytopesAreConfirmedIndependently) {
  std::mt19937_64 rng(123);
  int refused = 0;
  for (int i = 0; i < 150; ++i) {
    const Polytope poly = test::random_polytope(rng, 6 + i % 10, 0.05 + 0.002 * i);
    const PointToSet p2s(poly, BaseFunction(0.1, 2), StrictParams{}, P2SOptions{}, "a");
    const ValidationReport r = validate_p2s(p2s, 1500, i);
    EXPECT_GE(r.min_eigenvalue, -r.min_eigenvalue_tolerance) << i;
    if (!r.ok) {
      ++refused;
      Mat3 fd;
      const double d = 1e-7 * (1 + r.worst_point.norm());
      for (int c = 0; c < 3; ++c) {
        Vec3 dp = Vec3::Zero();
        dp[c] = d;
        fd.col(c) = (p2s.strict(r.worst_point + dp, 1).gradient -
                     p2s.strict(r.worst_point - dp, 1).gradient) /
                    (2 * d);
      }
      Eigen::SelfAdjointEigenSolver<Mat3> es(0.5 * (fd + fd.transpose()), Eigen::EigenvaluesOnly);
      EXPECT_GE(es.eigenvalues()[2], 1.0 - 1e-6) << i;
      continue;
    }
    for (int j = 0; j < 2000; ++j) {
      const Vec3 p = support(poly, test::random_unit(rng)) + 0.3 * std::pow(1e-3, (j % 7) / 6.0) * test::random_unit(rng);
      if (p2s.contains(p)) continue;
      EXPECT_LT(max_eigenvalue_at(p2s, p), 1.0) << i;
    }
  }
  // The paper's ε and σ break Property 2 on many of these shapes (Lemma 7 guarantees it only
  // for small σ): a needle-like vertex leaves e_S small far beyond its tip, so the spike at the
  // sphere ρ = 0 exceeds 1 (every refusal above is confirmed at its point). Most pass.
  EXPECT_GT(refused, 0);
  EXPECT_LT(refused, 150 / 2);
}

}  // namespace
}  // namespace distlab

namespace distlab {
namespace {

// Shapes whose E_S breaks Property 2 only in the thin shell at the sphere ρ = 0: a ρ ball given
// by the user that clears one vertex (one rim point) by `clearance` (< 0: the default ball),
// with the paper's ε = 0.01 and σ = sqrt(1 − 2ε). There e_S is small and eq. 18's term ε²R²/(σ e_S) exceeds 1, within a
// millimetre-thick shell that random sampling misses (the sampling validator passed all five).
struct ShellCase {
  const char* name;
  Shape shape;
  Vec3 rho_center;
  double clearance;
};

double farthest_point(const Shape& s, const Vec3& c) {
  if (const auto* p = std::get_if<Polytope>(&s)) {
    double d = 0;
    for (const Vec3& v : p->vertices) d = std::max(d, (v - c).norm());
    return d;
  }
  if (const auto* b = std::get_if<Box>(&s)) return (c.cwiseAbs() + b->size / 2).norm();
  const auto& cyl = std::get<Cylinder>(s);
  return std::hypot(std::hypot(c.x(), c.y()) + cyl.radius, std::abs(c.z()) + cyl.height / 2);
}

std::vector<ShellCase> shell_cases() {
  std::vector<ShellCase> cases;
  cases.push_back({"gripper box", Box{Vec3(0.05, 0.21, 0.1)}, Vec3(-0.02, -0.03, -0.01), 0.019});
  cases.push_back({"cylinder", Cylinder{0.08, 0.28}, Vec3(-0.03, 0, 0), 0.016});
  for (const auto& [seed, clearance] : {std::pair{4, 0.03}, std::pair{7, 0.04}}) {
    std::mt19937_64 rng(static_cast<std::uint64_t>(seed));
    const Polytope poly = test::random_polytope(rng, 12, 0.08);
    cases.push_back({"polytope", poly, bounding_ball(poly).center, clearance});
  }
  // All defaults (ρ ball 1.5 × the bounding ball): a needle vertex 0.67 m out leaves the faces
  // violated by only 0.02 m at the sphere 0.34 m beyond it; the eigenvalue there is about 19.
  std::mt19937_64 rng(1);
  cases.push_back({"needle polytope, defaults", test::random_polytope(rng, 10, 0.1), Vec3::Zero(), -1});
  return cases;
}

PointToSet shell_p2s(const ShellCase& c) {
  P2SOptions options;
  if (c.clearance > 0)
    options.rho = Ball{c.rho_center, farthest_point(c.shape, c.rho_center) + c.clearance};
  return PointToSet(c.shape, BaseFunction(0.1, 2), StrictParams{}, options, "a");
}

TEST(Validator, RefusesShapesThatBreakProperty2OnlyNearTheRhoSphere) {
  for (const ShellCase& c : shell_cases()) {
    const PointToSet p2s = shell_p2s(c);
    const Vec3 center = p2s.rho_ball().center;
    const double R = p2s.rho_ball().radius;
    // The violation is real: the independent search finds an eigenvalue >= 1, on the shell.
    const test::SearchResult truth = test::independent_max(p2s);
    ASSERT_GE(truth.value, 1.0) << c.name;
    EXPECT_LT(std::abs((truth.point - center).norm() - R), 0.01 * R) << c.name;

    const ValidationReport r = validate_p2s(p2s);
    EXPECT_FALSE(r.ok) << c.name << ": " << r.message;
    EXPECT_GE(r.max_eigenvalue, 1.0) << c.name;
    // At least what the independent search found, and the named point really has it
    // (finite differences of the gradient, not eq. 18's Hessian).
    EXPECT_GE(r.max_eigenvalue, truth.value * (1 - 1e-5)) << c.name;
    const double fd = test::fd_lambda_max(p2s, r.worst_point);
    EXPECT_GE(fd, 1.0) << c.name;
    EXPECT_NEAR(fd, r.max_eigenvalue, 1e-5 * r.max_eigenvalue) << c.name;
    EXPECT_LT(std::abs((r.worst_point - center).norm() - R), 0.01 * R) << c.name;
    EXPECT_NE(r.message.find("Property 2 fails: the Hessian of E_S has eigenvalue"),
              std::string::npos)
        << r.message;
    // On the ρ sphere ∂²E has ε²∇ρ∇ρᵀ/(σe): the advice is a smaller eps or a larger ball.
    EXPECT_NE(r.message.find("decrease eps"), std::string::npos) << r.message;
    EXPECT_NE(r.message.find("enlarge the rho ball (the point is near its sphere)"), std::string::npos) << r.message;
  }
}

// The advice follows the regime of eq. 6 at the worst point, and following it works: small
// weights (e and ∇e scale with them) break Property 2 through ε²/σ terms, so a halved eps passes
// and a smaller sigma makes it worse (a Kinova base hull of 2,886 facets failed this way, and the
// advice said to decrease sigma).
TEST(Validator, TheAdviceNamesTheParametersThatLowerTheHessianThere) {
  P2SOptions small;
  small.weights = VecX::Constant(6, 0.02);
  const Box box{Vec3(0.1, 0.1, 0.1)};
  auto report = [&](double eps, double sigma) {
    StrictParams sp;
    sp.eps = eps, sp.sigma = sigma;
    return validate_p2s(PointToSet(box, BaseFunction(0.1, 2), sp, small, "a"));
  };
  const StrictParams defaults;
  const ValidationReport r = report(defaults.eps, defaults.sigma);
  ASSERT_FALSE(r.ok);
  EXPECT_NE(r.message.find("there it grows like eps^2/sigma: decrease eps"), std::string::npos) << r.message;
  EXPECT_TRUE(report(defaults.eps / 2, defaults.sigma).ok);
  EXPECT_GT(report(defaults.eps, 0.7).max_eigenvalue, r.max_eigenvalue);
}

// A shape far smaller than h (an IMU's 1.5 mm collision box in a quadruped's description, a1 of
// Gepetto/example-robot-data): Φ(s) ≈ s³/(6h) over it, so the growth falls with h. The advice
// says so and gives a bound on h; an h below it passes, the weights left as they are.
TEST(Validator, TheAdviceForAShapeFarSmallerThanHNamesH) {
  const Box imu{Vec3(0.0015, 0.0015, 0.0015)};
  auto report = [&](double h) { return validate_p2s(PointToSet(imu, BaseFunction(h, 2), StrictParams{}, P2SOptions{}, "a")); };
  const ValidationReport r = report(0.1);
  ASSERT_FALSE(r.ok);
  const std::string says = "is far smaller than h = 0.100000, and this growth falls in proportion to h: h below about ";
  const auto at = r.message.find(says);
  ASSERT_NE(at, std::string::npos) << r.message;
  const double bound = std::stod(r.message.substr(at + says.size()));
  EXPECT_NEAR(bound, 0.1 / r.max_eigenvalue, 1e-6);
  EXPECT_TRUE(report(0.8 * bound).ok) << report(0.8 * bound).message;
}

// Robot-link sized shapes with the defaults (README) satisfy Property 2, and the validator's
// largest eigenvalue is at least the independent search's.
TEST(Validator, PassesRobotLinkShapesAndFindsTheIndependentMaximum) {
  std::mt19937_64 rng(5);
  const std::vector<Shape> shapes = {Box{Vec3(0.05, 0.21, 0.1)}, Cylinder{0.08, 0.28},
                                     Sphere{0.1}, Capsule{0.05, 0.2},
                                     test::random_polytope(rng, 10, 0.1)};
  for (const Shape& s : shapes) {
    const PointToSet p2s(s, BaseFunction(0.1, 2), StrictParams{}, P2SOptions{}, "a");
    const test::SearchResult truth = test::independent_max(p2s);
    EXPECT_LT(truth.value, 1.0) << shape_type_name(s);
    const ValidationReport r = validate_p2s(p2s);
    EXPECT_TRUE(r.ok) << shape_type_name(s) << ": " << r.message;
    EXPECT_GE(r.max_eigenvalue, truth.value * (1 - 1e-5)) << shape_type_name(s);
    EXPECT_LT(r.max_eigenvalue, 1.0) << shape_type_name(s);
  }
}

// A hull weighted by facet area passes the validator (whose maximum an independent search
// confirms), and the same hull weighted 1/(m + margin) is refused.
void expect_area_passes_and_count_fails(const PointToSet& by_area, const PointToSet& by_count) {
  const ValidationReport area = validate_p2s(by_area), count = validate_p2s(by_count);
  EXPECT_TRUE(area.ok) << area.message;
  EXPECT_FALSE(count.ok);
  EXPECT_GT(count.max_eigenvalue, 1.0);
  const test::SearchResult truth = test::independent_max(by_area);
  EXPECT_LT(truth.value, 1.0);
  EXPECT_GE(area.max_eigenvalue, truth.value * (1 - 1e-5));
}

// A robot's base as meshed: a cylinder of 300 sides (r 4 cm, 16 cm long), 302 hull rows. With
// W = 1/(m + margin) its end caps weigh as little as one of 300 slivers (m = 150), e_S is tiny
// near the ρ sphere beyond them and ∂²E there reaches ~ε²R²/(σ e_S) > 1; by facet area (the
// default above kAreaWeightedRows rows) the caps weigh what they cover, and Property 2 holds.
// Both weightings keep ∂²e_S < I, checked at points around the hull.
TEST(Validator, AManyFacetedHullKeepsProperty2WithTheDefaults) {
  std::vector<Vec3> points;
  for (int k = 0; k < 300; ++k) {
    const double t = 2 * std::numbers::pi * k / 300;
    for (double z : {-0.08, 0.08}) points.emplace_back(0.04 * std::cos(t), 0.04 * std::sin(t), z);
  }
  const Polytope hull = polytope_from_points(points, "base");
  ASSERT_GT(hull.rows(), kAreaWeightedRows);
  const PointToSet by_area(hull, BaseFunction(0.1, 2), StrictParams{}, P2SOptions{}, "a");
  P2SOptions uniform;
  uniform.weights = VecX::Constant(hull.rows(), 1.0 / (max_violated_halfspaces(hull.A) + uniform.weight_margin));
  const PointToSet by_count(hull, BaseFunction(0.1, 2), StrictParams{}, uniform, "a");

  expect_area_passes_and_count_fails(by_area, by_count);

  std::mt19937_64 rng(9);
  for (int s = 0; s < 3000; ++s) {
    const Vec3 p = test::random_unit(rng) * (0.04 + 0.3 * std::uniform_real_distribution<double>()(rng));
    for (const PointToSet* f : {&by_area, &by_count}) {
      Eigen::SelfAdjointEigenSolver<Mat3> es(f->weak(p, 2).hessian, Eigen::EigenvaluesOnly);
      EXPECT_LT(es.eigenvalues()[2], 1.0) << p.transpose();
    }
  }
}

// A D-shaped plate as a finger's mesh has it (radius 16 mm, 4 mm thick, a half circle of 40
// segments): 43 hull rows, fewer than kAreaWeightedRows, but one point beyond the round edge
// violates 41 of them (m = 41), so 1/(m + margin) weighs the flat back as one of 41 slivers and
// Property 2 fails beyond it. A hull is weighted by area at any size, and passes; the same rows
// written as A, b keep the paper's 1/(m + margin).
TEST(Validator, AFewFacetedHullIsWeightedByAreaToo) {
  std::vector<Vec3> points;
  for (int k = 0; k <= 40; ++k) {
    const double t = std::numbers::pi * k / 40;
    for (double z : {-0.002, 0.002}) points.emplace_back(0.016 * std::cos(t), 0.016 * std::sin(t), z);
  }
  const Polytope hull = polytope_from_points(points, "finger");
  ASSERT_LE(hull.rows(), kAreaWeightedRows);
  const int m = max_violated_halfspaces(hull.A);
  EXPECT_EQ(m, hull.rows() - 2);
  const Polytope written = make_polytope(hull.A, hull.b, "finger");
  EXPECT_FALSE(written.is_hull);

  const PointToSet by_area(hull, BaseFunction(0.1, 2), StrictParams{}, P2SOptions{}, "a");
  const PointToSet by_count(written, BaseFunction(0.1, 2), StrictParams{}, P2SOptions{}, "a");
  EXPECT_TRUE(by_count.weights().isApproxToConstant(1.0 / (m + P2SOptions{}.weight_margin), 1e-15));
  // The flat back (3.2 cm by 4 mm, the row along −y) weighs what it covers: about five times a
  // side segment (1.3 mm by 4 mm) with the mean added to each.
  Eigen::Index back = 0;
  (hull.A * Vec3(0, -1, 0)).maxCoeff(&back);
  for (Eigen::Index i = 0; i < hull.rows(); ++i)
    if (hull.A(i, 1) > 1e-3 && std::abs(hull.A(i, 2)) < 0.5) {
      EXPECT_GT(by_area.weights()[back], 4 * by_area.weights()[i]) << i;
    }

  expect_area_passes_and_count_fails(by_area, by_count);
}

}  // namespace
}  // namespace distlab
