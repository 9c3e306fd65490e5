// Gradients of D near contact (issue 19): with h = 0.1, D falls like a high power of the
// Euclidean distance d (D ~ 1e-6 at d ~ 3-9 mm, 1e-7 at 1.5-4 mm), and the returned gradient
// must stay accurate to 1e-6 relative there, not only where D is large. There a* − b* is ~1e-11
// while |a*| ~ 0.3, so the gradient cannot come from the difference of the two points. Pairs of
// every kind are placed at D in {1e-3, ..., 1e-7} and the gradients that gap_distance returns with the default
// parameters (cold) and gap_distance_warm returns from nearby witnesses are compared with
// Richardson-extrapolated central differences of D along the 12 pose coordinates.
//
// Touching pairs (Euclidean distance d of 1e-6 and 1e-7, D ~ 1e-16 to 1e-22): a* − b* is ~1e-29
// there and a*, b* are the same doubles; D carries rounding noise of up to ~1e-9 relative from
// the coordinates' last bits, which a central difference in double divides by its step. They are
// judged by Λ's independence of the start and by central differences of D solved in long double
// (gap_gradient_extended: 2048× less rounding); for two spheres also by a second method, checked
// against that reference too: the saddle equations reduce to two scalar equations on the centre
// line, solved in 50-digit arithmetic.
#include <gtest/gtest.h>

#include <boost/multiprecision/cpp_bin_float.hpp>
#include <cmath>
#include <string>

#include "distlab/gap/distance.hpp"
#include "distlab/gap/solver.hpp"
#include "gap_test_util.hpp"

namespace distlab {
namespace {

constexpr double kBound = 1e-6;  // relative, issue 19

struct Case {
  const char* name;
  Shape a, b;
};

std::vector<Case> cases() {
  std::mt19937_64 rng(19);
  return {{"sphere-sphere", Sphere{0.1}, Sphere{0.15}},
          {"box-box", Box{Vec3(0.2, 0.1, 0.3)}, Box{Vec3(0.15, 0.25, 0.1)}},
          {"polytope-polytope", test::random_polytope(rng, 10, 0.12), test::random_polytope(rng, 12, 0.1)},
          {"capsule-box", Capsule{0.05, 0.2}, Box{Vec3(0.2, 0.1, 0.3)}},
          {"capsule-polytope", Capsule{0.06, 0.15}, test::random_polytope(rng, 10, 0.12)},
          {"cylinder-sphere", Cylinder{0.08, 0.25}, Sphere{0.1}}};
}

// B's position along `n` from A's such that D is within 2% of `target` (bisection on the
// offset: D is 0 on overlap and grows with the offset).
Pose place_at(const GapBody& a, GapBody& b, const Vec3& n, const Quat& rot, double target,
              const GapParams& p) {
  double lo = 0.0, hi = 2.0;
  Pose pose{a.pose().position + hi * n, rot};
  for (int it = 0; it < 200; ++it) {
    const double t = 0.5 * (lo + hi);
    pose.position = a.pose().position + t * n;
    b.set_pose(pose);
    const double D = gap_distance(a, b, p).distance;
    if (std::abs(D - target) < 0.02 * target) return pose;
    (D < target ? lo : hi) = t;
  }
  ADD_FAILURE() << "no offset gives D = " << target;
  return pose;
}

// ‖FD − g‖∞ / ‖g‖∞ over both poses' 12 coordinates, the slope along coordinate c taken by
// slope(D, c) from D(x), D at tol 1e-14 with the pose moved by x.
template <class Slope>
double fd_error(GapBody& a, GapBody& b, const GapResult& r, Slope&& slope, std::string& worst_at) {
  GapParams fd;
  fd.tol = 1e-14;
  double worst = 0, scale = 0;
  for (int which = 0; which < 2; ++which) {
    GapBody& moved = which == 0 ? a : b;
    const Pose base = moved.pose();
    const Vec6& g = which == 0 ? r.gradient_a : r.gradient_b;
    for (int c = 0; c < 6; ++c) {
      auto D = [&](double x) {
        moved.set_pose(test::perturbed(base, c, x));
        return gap_distance(a, b, fd).distance;
      };
      const double e = std::abs(slope(D, c) - g[c]);
      moved.set_pose(base);
      if (e > worst) worst = e, worst_at = "shape " + std::to_string(which) + " coord " + std::to_string(c);
      scale = std::max(scale, std::abs(g[c]));
    }
  }
  return worst / scale;
}

// Central differences at steps s and s/2, Richardson-extrapolated (error O(s⁴)); s scales with
// the Euclidean distance d (D ~ d^2.5 near contact) and, for rotations, with the pair's size.
double gradient_error(GapBody& a, GapBody& b, const GapResult& r, std::string& worst_at) {
  const double d = r.euclidean.distance;
  auto richardson = [&](auto& D, int c) {
    const double s = (c < 3 ? 1e-3 : 3e-3) * d;
    auto central = [&](double h) { return (D(h) - D(-h)) / (2 * h); };
    return (4 * central(0.5 * s) - central(s)) / 3;
  };
  return fd_error(a, b, r, richardson, worst_at);
}

TEST(GapGradientNearContact, MatchesFiniteDifferencesDownToDOf1em9) {
  const GapParams p;  // the defaults: tol 1e-10, what the API uses
  std::mt19937_64 rng(7);
  for (const Case& c : cases()) {
    for (int draw = 0; draw < 2; ++draw) {
      const Quat ra = test::random_rotation(rng), rb = test::random_rotation(rng);
      const Vec3 n = test::random_unit(rng);
      GapBody a(c.a, Pose{Vec3(0.1, -0.2, 0.3), ra}, p);
      GapBody b(c.b, Pose{Vec3::Zero(), rb}, p);
      for (const double target : {1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9}) {
        const Pose pose = place_at(a, b, n, rb, target, p);
        b.set_pose(pose);
        const GapResult r = gap_distance(a, b, p);
        ASSERT_FALSE(r.overlap);
        ASSERT_TRUE(r.converged);
        std::string where;
        EXPECT_LE(gradient_error(a, b, r, where), kBound)
            << c.name << " draw " << draw << " D " << r.distance << " d " << r.euclidean.distance << " at "
            << where << " iterations " << r.iterations;
        // Tracking: from the witnesses of a pose 0.1 d away, as a control loop would call it.
        b.set_pose(test::perturbed(pose, 0, 1e-1 * r.euclidean.distance));
        const GapResult prev = gap_distance(a, b, p);
        b.set_pose(pose);
        GapResult w = gap_distance_warm(a, b, p, prev.witness_a, prev.witness_b);
        ASSERT_FALSE(w.overlap);
        w.euclidean = r.euclidean;  // the FD steps' scale
        EXPECT_LE(gradient_error(a, b, w, where), kBound)
            << c.name << " warm, draw " << draw << " D " << w.distance << " at " << where << " iterations "
            << w.iterations;
      }
    }
  }
}

// B moved along the Euclidean separating direction to a Euclidean distance `d` from A (moving
// B by −s n lowers the distance by exactly s: the separating plane stays one).
void place_touching(const GapBody& a, GapBody& b, double d) {
  const GapParams p;
  const GapResult far = gap_distance(a, b, p);
  const Vec3 n = (far.euclidean.witness_b - far.euclidean.witness_a).normalized();
  Pose pose = b.pose();
  pose.position -= (far.euclidean.distance - d) * n;
  b.set_pose(pose);
}

// ‖FD − g‖∞ / ‖g‖∞ over both poses' 12 coordinates, FD from D in long double (central at 1e-4 d:
// truncation ~1e-8 of the gradient, rounding ~1e-9 where double's was ~1e-5).
double extended_gradient_error(const GapBody& a, const GapBody& b, const GapResult& r, double d) {
  const ExtendedGradient fd = gap_gradient_extended(a, b, r, 1e-4 * d);
  EXPECT_TRUE(fd.converged);
  const double scale = std::max(r.gradient_a.cwiseAbs().maxCoeff(), r.gradient_b.cwiseAbs().maxCoeff());
  return std::max((fd.a - r.gradient_a).cwiseAbs().maxCoeff(), (fd.b - r.gradient_b).cwiseAbs().maxCoeff()) / scale;
}

// Touching pairs: Newton reaches the same Λ from starts 10 d apart (before, a failed line search
// handed over to a nested method that stopped where it started: Λ off by up to 4×), and the
// gradient matches the long-double differences of D at 1e-6, as does no gradient 2e-6 off (the
// reference resolves the bound; a gradient from a* − b*, the same doubles here, was 0).
TEST(GapGradientNearContact, TouchingPairsSolveToOneLambdaWithTheGradientOfD) {
  const GapParams p;
  std::mt19937_64 rng(11);
  for (const Case& c : cases()) {
    for (int draw = 0; draw < 2; ++draw) {
      const Quat ra = test::random_rotation(rng), rb = test::random_rotation(rng);
      const Vec3 n = test::random_unit(rng);
      for (const double d : {1e-6, 1e-7}) {
        GapBody a(c.a, Pose{Vec3(0.1, -0.2, 0.3), ra}, p);
        GapBody b(c.b, Pose{Vec3(0.1, -0.2, 0.3) + 0.6 * n, rb}, p);
        place_touching(a, b, d);
        const GapResult r = gap_distance(a, b, p);
        ASSERT_FALSE(r.overlap) << c.name;
        ASSERT_TRUE(r.converged) << c.name;
        ASSERT_GT(r.lambda, 0) << c.name;
        for (int start = 0; start < 4; ++start) {
          const Vec3 a0 = r.witness_a + 10 * d * test::random_unit(rng);
          const WitnessSolution s = solve_newton(a.p2s(), b.p2s(), a0, p.tol, 100);
          EXPECT_TRUE(s.converged) << c.name << " draw " << draw << " d " << d << " start " << start;
          EXPECT_LE(std::abs(s.lambda - r.lambda), 1e-8 * r.lambda)
              << c.name << " draw " << draw << " d " << d << " start " << start << ": Λ " << s.lambda
              << " against " << r.lambda << " (" << s.iterations << " iterations)";
        }
        const double error = extended_gradient_error(a, b, r, d);
        EXPECT_LE(error, kBound) << c.name << " draw " << draw << " d " << d << " D " << r.distance << " iterations "
                                 << r.iterations;
        GapResult off = r;
        off.gradient_b[0] += 2 * kBound * std::max(r.gradient_a.cwiseAbs().maxCoeff(), r.gradient_b.cwiseAbs().maxCoeff());
        EXPECT_GT(extended_gradient_error(a, b, off, d), kBound) << c.name << " draw " << draw << " d " << d;
      }
    }
  }
}

// Two spheres: E_S(p) = f_S(‖p − c_S‖), so a*, b* lie on the centre line, at distances s_A of b*
// outside A and s_B of a* outside B. With δ = ‖b* − a*‖ = s_A + s_B − d the saddle equations are
// f_A'(r_A + s_A) = δ = f_B'(r_B + s_B), and by the envelope theorem dΛ/dL = f_B'(r_B + s_B) = δ
// for the centre distance L: dD/dc_B = (δ / D) n. Solved here in 50 digits (f' is increasing:
// nested bisections), with Φ = s²/2 − ((1 + s)⁻⁸ − 1 + 8s)/72 (eq. 4, k = 2, h = 0.1) and
// E = B²/(V − A) (eq. 6, A = ερ < 0 near the sphere), independent of the library's evaluation.
using Big = boost::multiprecision::cpp_bin_float_50;

struct RoundP2S {
  Big r, rho_r, w, eps, sigma;  // radius, ρ ball radius, round weight, ε, σ
  // E and dE/dt at distance t from the centre.
  void at(const Big& t, Big& e, Big& de) const {
    const Big s = t - r;
    Big phi = 0, dphi = 0;
    if (s > 0) {
      const Big x = 1 / (1 + s), x8 = pow(x, 8);
      phi = s * s / 2 - (x8 - 1 + 8 * s) / 72;
      dphi = s - (1 - x8 * x) / 9;
    }
    const Big A = eps * (t * t - rho_r * rho_r) / 2, B = sigma * w * phi;
    const Big V = sqrt(A * A + B * B);
    e = B * B / (V - A);
    de = (e * eps * t + B * sigma * w * dphi) / V;
  }
  Big slope(const Big& s) const {
    Big e, de;
    at(r + s, e, de);
    return de;
  }
  // The s >= 0 with f'(r + s) = δ.
  Big inverse(const Big& delta, Big hi) const {
    Big lo = 0;
    for (int i = 0; i < 200; ++i) {
      const Big mid = (lo + hi) / 2;
      (slope(mid) < delta ? lo : hi) = mid;
    }
    return (lo + hi) / 2;
  }
};

TEST(GapGradientNearContact, SpheresMatchA50DigitSolutionOfTheCentreLine) {
  const GapParams p;
  const double ra = 0.1, rb = 0.15;
  auto p2s = [&](double r) {
    return RoundP2S{Big(r), Big(r) * Big(kDefaultRhoScale), 1 / (1 + Big(p.weight_margin)), Big(p.eps), Big(p.sigma)};
  };
  const RoundP2S fa = p2s(ra), fb = p2s(rb);
  std::mt19937_64 rng(5);
  for (const double gap : {1e-3, 1e-5, 1e-6, 3e-7, 1e-7}) {
    const Vec3 ca(0.1, -0.2, 0.3), n = test::random_unit(rng);
    GapBody a(Sphere{ra}, Pose{ca, test::random_rotation(rng)}, p);
    GapBody b(Sphere{rb}, Pose{ca + (ra + rb + gap) * n, test::random_rotation(rng)}, p);
    const GapResult r = gap_distance(a, b, p);
    ASSERT_FALSE(r.overlap);
    // The reference from the double centres as they are.
    const Vec3 cb = b.pose().position;
    Big L2 = 0;
    for (int i = 0; i < 3; ++i) L2 += (Big(cb[i]) - Big(ca[i])) * (Big(cb[i]) - Big(ca[i]));
    const Big L = sqrt(L2), d = L - fa.r - fb.r;
    Big lo = 0, hi = fa.slope(d);  // there s_A >= d: the sum below is >= 0
    auto excess = [&](const Big& delta) { return fa.inverse(delta, d) + fb.inverse(delta, d) - d - delta; };
    for (int i = 0; i < 200; ++i) {
      const Big mid = (lo + hi) / 2;
      (excess(mid) < 0 ? lo : hi) = mid;
    }
    const Big delta = (lo + hi) / 2, sa = fa.inverse(delta, d), sb = fb.inverse(delta, d);
    Big ea, eb, unused;
    fa.at(fa.r + sa, ea, unused);
    fb.at(fb.r + sb, eb, unused);
    const Big lambda = ea + eb - delta * delta / 2;
    const double D = static_cast<double>(sqrt(2 * lambda)), slope = static_cast<double>(delta / sqrt(2 * lambda));
    Vec3 unit;
    for (int i = 0; i < 3; ++i) unit[i] = static_cast<double>((Big(cb[i]) - Big(ca[i])) / L);
    EXPECT_LE(std::abs(r.distance - D), 1e-8 * D) << "gap " << gap << ": D " << r.distance << " against " << D;
    const Vec3 g = r.gradient_b.head<3>();
    EXPECT_LE((g - slope * unit).norm(), kBound * slope)
        << "gap " << gap << ": dD/dc_B " << g.transpose() << " against " << (slope * unit).transpose();
    EXPECT_LE((r.gradient_a.head<3>() + slope * unit).norm(), kBound * slope) << "gap " << gap;
    // The long-double reference the other kinds are judged by, against the 50-digit solution:
    // D to its rounding (5e-20 of |p| ~ 0.3 against s ~ 5e-8, times D's power ~3; measured
    // 1.1e-12 at gap 1e-7), the differences to their truncation ((1e-4)² scale; measured 3e-9).
    const ExtendedGradient fd = gap_gradient_extended(a, b, r, 1e-4 * gap);
    EXPECT_TRUE(fd.converged);
    EXPECT_LE(std::abs(fd.distance - D), 1e-11 * D) << "gap " << gap << ": long-double D " << fd.distance;
    EXPECT_LE((fd.b.head<3>() - slope * unit).norm(), 1e-8 * slope)
        << "gap " << gap << ": long-double differences " << fd.b.head<3>().transpose();
  }
}

}  // namespace
}  // namespace distlab
