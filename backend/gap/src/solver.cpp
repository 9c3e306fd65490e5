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

namespace {

// Joint Newton on the saddle-point equations of Lemma 3 in (a, b):
//   r_b = b − Π_B(a) = 0,  r_a = a − Π_A(b) = 0,
// Jacobian [[∂²E_B − I, I], [I, ∂²E_A − I]], eliminated to one 3×3 solve. Two P2S evaluations a
// step; backtracking on ‖r‖. Returns false if it cannot make progress (then the nested method,
// which is globally convergent, takes over from the best point found).
bool joint_newton(const PointToSet& A, const PointToSet& B, Vec3& a, Vec3& b, double tol,
                  int max_iter, int& iterations) {
  const Mat3 I = Mat3::Identity();
  P2SValue eb = B.strict(a, 2), ea = A.strict(b, 2);
  auto residual = [&](const Vec3& x, const Vec3& y, const P2SValue& ex_b, const P2SValue& ey_a,
                      Vec3& rb, Vec3& ra) {
    rb = y - x + ex_b.gradient;
    ra = x - y + ey_a.gradient;
    return rb.squaredNorm() + ra.squaredNorm();
  };
  Vec3 rb, ra;
  double merit = residual(a, b, eb, ea, rb, ra);
  while (iterations < max_iter) {
    ++iterations;
    const Mat3 Hb = eb.hessian - I, Ha = ea.hessian - I;
    // (Hb δa + δb = −rb, δa + Ha δb = −ra)  =>  (I − Hb Ha) δb = −rb + Hb ra.
    const Vec3 db = (I - Hb * Ha).partialPivLu().solve(-rb + Hb * ra);
    const Vec3 da = -ra - Ha * db;
    if (!da.allFinite() || !db.allFinite()) return false;
    double alpha = 1.0;
    for (int ls = 0;; ++ls, alpha *= 0.5) {
      if (ls == 6) return false;
      const Vec3 an = a + alpha * da, bn = b + alpha * db;
      const P2SValue ebn = B.strict(an, 2), ean = A.strict(bn, 2);
      Vec3 rbn, ran;
      const double m = residual(an, bn, ebn, ean, rbn, ran);
      if (m < (1 - 1e-4 * alpha) * merit || m == 0.0) {
        a = an, b = bn, eb = ebn, ea = ean, rb = rbn, ra = ran, merit = m;
        break;
      }
    }
    if (alpha * std::max(da.norm(), db.norm()) < tol) return true;
  }
  return false;
}

// Newton on Λ_B(a) = max_b Λ(a, b) (nested), from a with b warm.
bool nested_newton(const PointToSet& A, const PointToSet& B, Vec3& a, Vec3& b, double tol,
                   int max_iter, int& iterations) {
  P2SValue ea = maximise_inner(A, a, b);
  P2SValue eb = B.strict(a, 2);
  double lam = ea.value + eb.value - 0.5 * (a - b).squaredNorm();
  const Mat3 I = Mat3::Identity();
  while (iterations < max_iter) {
    ++iterations;
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
        a = an, b = bn, ea = ean, eb = ebn, lam = lamn;
        moved = true;
        break;
      }
    }
    if (!moved) return false;  // no decrease possible at working precision
    if (alpha * d.norm() < tol) return true;
  }
  return false;
}

}  // namespace

WitnessSolution solve_newton(const PointToSet& A, const PointToSet& B, const Vec3& a0, double tol,
                             int max_iter) {
  WitnessSolution s;
  Vec3 a = a0, b = a0 - B.strict(a0, 1).gradient;  // b = Π_B(a0)
  const Vec3 a_start = a, b_start = b;
  s.converged = joint_newton(A, B, a, b, tol, max_iter, s.iterations);
  if (!s.converged) {
    if (!a.allFinite() || !b.allFinite()) a = a_start, b = b_start;
    b = a;  // the nested method's inner solve starts from b = a (exact when a is in A)
    s.converged = nested_newton(A, B, a, b, tol, max_iter, s.iterations);
  }
  // Report the fixed point's own pair: b* = Π_B(a*), with Λ from eq. (3).
  s.a = a;
  s.b = a - B.strict(a, 1).gradient;
  s.lambda = lambda_at(A, B, s.a, s.b);
  if (!s.converged) {
    const Vec3 fa = s.b - A.strict(s.b, 1).gradient;
    s.converged = (fa - a).norm() < tol;  // converged to working precision after all
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
