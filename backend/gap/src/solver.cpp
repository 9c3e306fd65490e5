#include "distlab/gap/solver.hpp"

#include <Eigen/Cholesky>
#include <cmath>
#include <limits>

namespace distlab {
namespace {

constexpr double kArmijo = 1e-4;
constexpr double kRound = 64 * std::numeric_limits<double>::epsilon();

// Inner problem of Lemma 3: b°(a) maximises φ(b) = E_A(b) − ½‖a − b‖², i.e. Π_A(b°) = a.
// φ is strongly concave (∂²E_A < I); Newton with an Armijo ascent test. Returns E_A at b°.
P2SValue maximise_inner(const PointToSet& A, const Vec3& a, Vec3& b) {
  P2SValue ea = A.strict(b, 2);
  for (int it = 0; it < 60; ++it) {
    const Vec3 r = b - ea.gradient - a;  // −∇φ
    if (r.norm() <= 1e-15 * (1.0 + a.norm())) break;
    const Mat3 J = Mat3::Identity() - ea.hessian;  // −∂²φ, SPD
    const Vec3 delta = -J.llt().solve(r);
    const double slope = -r.dot(delta);            // ∇φ·δ > 0
    const double phi0 = ea.value - 0.5 * (a - b).squaredNorm();
    double alpha = 1.0;
    bool moved = false;
    for (int ls = 0; ls < 40; ++ls, alpha *= 0.5) {
      const Vec3 bn = b + alpha * delta;
      P2SValue en = A.strict(bn, 2);
      const double phin = en.value - 0.5 * (a - bn).squaredNorm();
      if (phin >= phi0 + kArmijo * alpha * slope - kRound * (std::abs(phi0) + 1e-300)) {
        b = bn;
        ea = en;
        moved = true;
        break;
      }
    }
    if (!moved || alpha * delta.norm() <= 1e-16 * (1.0 + b.norm())) break;
  }
  return ea;
}

}  // namespace

double lambda_at(const PointToSet& A, const PointToSet& B, const Vec3& a, const Vec3& b) {
  return A.strict(b, 0).value + B.strict(a, 0).value - 0.5 * (a - b).squaredNorm();
}

WitnessSolution solve_fixed_point(const PointToSet& A, const PointToSet& B, const Vec3& a0,
                                  double tol, int max_iter) {
  WitnessSolution s;
  Vec3 a = a0;
  for (s.iterations = 0; s.iterations < max_iter;) {
    const Vec3 b = a - B.strict(a, 1).gradient;                   // Π_B(a)
    const Vec3 next = b - A.strict(b, 1).gradient;                // Π_A(Π_B(a))
    ++s.iterations;
    const double step = (next - a).norm();
    a = next;
    if (step < tol) {
      s.converged = true;
      break;
    }
  }
  s.a = a;
  s.b = a - B.strict(a, 1).gradient;
  s.lambda = lambda_at(A, B, s.a, s.b);
  return s;
}

WitnessSolution solve_newton(const PointToSet& A, const PointToSet& B, const Vec3& a0, double tol,
                             int max_iter) {
  WitnessSolution s;
  Vec3 a = a0, b = a0;
  P2SValue ea = maximise_inner(A, a, b);
  P2SValue eb = B.strict(a, 2);
  double lam = ea.value + eb.value - 0.5 * (a - b).squaredNorm();
  const Mat3 I = Mat3::Identity();
  for (s.iterations = 0; s.iterations < max_iter;) {
    ++s.iterations;
    const Vec3 g = eb.gradient - (a - b);  // ∇Λ_B(a) = b° − Π_B(a)
    const Eigen::LLT<Mat3> inner(I - ea.hessian);
    const Mat3 M = eb.hessian - I + inner.solve(I);  // eq. (11), SPD
    Eigen::LLT<Mat3> outer(M);
    Vec3 d = outer.info() == Eigen::Success ? Vec3(-outer.solve(g)) : Vec3(-g);
    if (!d.allFinite() || g.dot(d) >= 0) d = -g;
    const Vec3 db = inner.solve(d);  // b° moves by (I − ∂²E_A)⁻¹ da
    const double slope = g.dot(d);
    double alpha = 1.0;
    bool moved = false;
    for (int ls = 0; ls < 60; ++ls, alpha *= 0.5) {
      const Vec3 an = a + alpha * d;
      Vec3 bn = b + alpha * db;
      const P2SValue ean = maximise_inner(A, an, bn);
      const P2SValue ebn = B.strict(an, 2);
      const double lamn = ean.value + ebn.value - 0.5 * (an - bn).squaredNorm();
      if (lamn <= lam + kArmijo * alpha * slope + kRound * std::abs(lam)) {
        a = an;
        b = bn;
        ea = ean;
        eb = ebn;
        lam = lamn;
        moved = true;
        break;
      }
    }
    const double step = alpha * d.norm();
    if (!moved) break;  // no decrease possible at working precision
    if (step < tol) {
      s.converged = true;
      break;
    }
  }
  // Report the fixed point's own pair: b* = Π_B(a*), with Λ from eq. (3).
  s.a = a;
  s.b = a - eb.gradient;
  s.lambda = lambda_at(A, B, s.a, s.b);
  if (!s.converged) {
    // Converged to working precision if Π_A(Π_B(a)) = a within tol.
    const Vec3 fa = s.b - A.strict(s.b, 1).gradient;
    s.converged = (fa - a).norm() < tol;
  }
  return s;
}

void lambda_gradients(const Vec3& a_star, const Vec3& b_star, const Pose& pose_a,
                      const Pose& pose_b, Vec6& grad_a, Vec6& grad_b) {
  const Vec3 ab = a_star - b_star;
  grad_a.head<3>() = ab;
  grad_a.tail<3>() = -(b_star - pose_a.position).cross(-ab);
  grad_b.head<3>() = -ab;
  grad_b.tail<3>() = -(a_star - pose_b.position).cross(ab);
}

}  // namespace distlab
