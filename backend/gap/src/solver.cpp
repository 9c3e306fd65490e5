#include "distlab/gap/solver.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>
#include <utility>

namespace distlab {
namespace {

constexpr double kArmijo = 1e-4;
// Rounding allowance, relative to T's precision; the solver's relative stop rules are scaled by
// kPrecisionScale<T> (point_to_set.hpp; long double: solve_newton's reference overload).
template <class T>
constexpr T kRound = 64 * std::numeric_limits<T>::epsilon();
constexpr int kJointHalvings = 30;
constexpr int kDampedSteps = 3;
// Near contact E_B varies on the length ℓ = ‖∇E_B‖ / tr ∂²E_B (a fifth of the distance to B
// where E_B ~ s⁶), far below 1 m at touching (ℓ ~ 1e-8 at d ~ 1e-7), so an absolute step of
// tol = 1e-10 left ∇E_B, the gradient of Λ, off by up to 5e-6 relative (touching pairs of the
// public benchmark). The step must also be below kRelativeStep ℓ: after joint Newton's final step
// the error is ~ |δ|²/ℓ, so ∇E_B is then right to ~kRelativeStep². Far from contact ℓ > 1e-6 and
// tol decides alone.
constexpr double kRelativeStep = 1e-4;
// A cold solve also stops on its estimated error left (error_after_step) when ∇E_B's relative error
// it implies is below this, not kRelativeStep² as tracked calls, which answer to tol: Λ's gradients
// stay at the long-double solve's rounding level (test ColdSolvesKeepGradientsAtTheLongDouble…:
// 9.1e-15, as without the rule; 6.7e-12 at kRelativeStep²), and the box/cylinder benchmark's
// solves take 0.35 Newton steps fewer (of 3.3–3.9).
constexpr double kColdErrorRelative = 1e-13;

// True if a step of length `step` at a with E_B's derivatives `eb` is below the relative rule.
template <class T>
bool below_local_scale(T step, const P2SValueT<T>& eb, double rel) {
  return step * eb.hessian.trace() <= rel * eb.gradient.norm();
}

// Inner problem of Lemma 3: b°(a) maximises φ(b) = E_A(b) − ½‖a − b‖², i.e. Π_A(b°) = a.
// φ is strongly concave (∂²E_A < I); Newton with an Armijo ascent test. The unknown is
// ba = b − a (see Saddle below), b = a + ba. Returns E_A at b°.
// E: PointToSet (double) or PosedP2S<T>.
template <class T, class E>
P2SValueT<T> maximise_inner(const E& A, const Vec3T<T>& a, Vec3T<T>& ba) {
  using V = Vec3T<T>;
  P2SValueT<T> ea = A.strict(a + ba, 2);
  for (int it = 0; it < 60; ++it) {
    // Stop rules relative to ba: near contact ba and r are 1e-29 where a is 0.1.
    const V r = ba - ea.gradient;  // −∇φ
    if (r.norm() <= T(1e-15) * kPrecisionScale<T> * ba.norm()) break;
    const Mat3T<T> J = Mat3T<T>::Identity() - ea.hessian;  // −∂²φ, SPD
    const V delta = -J.llt().solve(r);
    const T slope = -r.dot(delta);  // ∇φ·δ > 0
    const T phi0 = ea.value - T(0.5) * ba.squaredNorm();
    T alpha = 1;
    bool moved = false;
    for (int ls = 0; ls < 40; ++ls, alpha *= T(0.5)) {
      const V bn = ba + alpha * delta;
      P2SValueT<T> en = A.strict(a + bn, 2);
      const T phin = en.value - T(0.5) * bn.squaredNorm();
      if (phin >= phi0 + T(kArmijo) * alpha * slope - kRound<T> * (std::abs(phi0) + T(1e-300))) {
        ba = bn;
        ea = en;
        moved = true;
        break;
      }
    }
    if (!moved || alpha * delta.norm() <= T(1e-16) * kPrecisionScale<T> * ba.norm()) break;
  }
  return ea;
}

template <class T, class E>
T lambda_of(const E& A, const E& B, const Vec3T<T>& a, const Vec3T<T>& b) {
  return A.strict(b, 0).value + B.strict(a, 0).value - T(0.5) * (a - b).squaredNorm();
}

}  // namespace

double lambda_at(const PointToSet& A, const PointToSet& B, const Vec3& a, const Vec3& b) {
  return lambda_of<double>(A, B, a, b);
}

WitnessSolution solve_fixed_point(const PointToSet& A, const PointToSet& B, const Vec3& a0,
                                  double tol, int max_iter) {
  WitnessSolution s;
  Vec3 a = a0;
  for (s.iterations = 0; s.iterations < max_iter;) {
    const Vec3 b = a - B.strict(a, 1).gradient;     // Π_B(a)
    const Vec3 next = b - A.strict(b, 1).gradient;  // Π_A(Π_B(a))
    ++s.iterations;
    const double step = (next - a).norm();
    a = next;
    if (step < tol) {
      s.converged = true;
      break;
    }
  }
  s.a = a;
  s.ab = B.strict(a, 1).gradient;
  s.b = a - s.ab;
  s.lambda = lambda_at(A, B, s.a, s.b);
  return s;
}

namespace {

// The current pair with E_A at b and E_B at a (values, gradients, Hessians). b − a is carried
// as its own vector `ba`: near contact it is far below the points' ulp (1e-29 against 1e-17 at
// a Euclidean distance of 1e-6), so the difference of the two doubles would leave the saddle
// residuals b − a + ∇E_B(a) and a − b + ∇E_A(b) pure rounding. b is a + ba rounded, which only
// moves where E_A is evaluated, by an ulp.
template <class T>
struct SaddleT {
  Vec3T<T> a, b, ba;
  P2SValueT<T> ea, eb;
  T shift = 0;  // makes lambda() Λ's quadratic model after a final, unevaluated step
  T lambda() const { return ea.value + eb.value - T(0.5) * ba.squaredNorm() + shift; }
};
using Saddle = SaddleT<double>;

// E_B at x.a and E_A at x.b, to second order (together where the shapes allow:
// PointToSet::strict_pair, the same values).
template <class T, class E>
void evaluate(const E& A, const E& B, SaddleT<T>& x) {
  if constexpr (std::is_same_v<E, PointToSet>) {
    B.strict_pair(x.a, A, x.b, 2, x.eb, x.ea);
  } else {
    x.eb = B.strict(x.a, 2);
    x.ea = A.strict(x.b, 2);
  }
}

// The Newton step (δa, δb) of the saddle equations below from their residuals rb, ra and the
// Hessians Eb = ∂²E_B(a), Ea = ∂²E_A(b). With Hb = Eb − I, Ha = Ea − I:
// (Hb δa + δb = −rb, δa + Ha δb = −ra), so (I − Hb Ha) δb = Hb ra − rb and δa = −ra − Ha δb.
// I − Hb Ha = I − Sb Sa with Sa, Sb = I − ∂²E in (0, I]: its eigenvalues lie in [0, 1), and
// Cramer's rule (the adjugate over the determinant, as Eigen's closed-form 3×3 inverse) is as
// accurate as pivoted LU here at a third of the cost; the adjugate is applied to the right-hand
// side before the division, without forming M⁻¹ (a quarter less time on the tracked path). An
// exactly singular matrix gives non-finite steps (callers check). `inverse_norm_squared`: the
// squared Frobenius norm of M⁻¹, if asked for (its square root only where a stop rule needs it).
// Also returns δb − δa = ra + Ea δb, which near contact is far below δa and δb themselves.
template <class T>
Vec3T<T> saddle_step(const Mat3T<T>& Eb, const Mat3T<T>& Ea, const Vec3T<T>& rb, const Vec3T<T>& ra, Vec3T<T>& da,
                     Vec3T<T>& db, T* inverse_norm_squared = nullptr) {
  const Mat3T<T> M = Eb + Ea - Eb * Ea;  // = I − Hb Ha
  Mat3T<T> adjugate;
  adjugate << M(1, 1) * M(2, 2) - M(1, 2) * M(2, 1), M(0, 2) * M(2, 1) - M(0, 1) * M(2, 2), M(0, 1) * M(1, 2) - M(0, 2) * M(1, 1),
      M(1, 2) * M(2, 0) - M(1, 0) * M(2, 2), M(0, 0) * M(2, 2) - M(0, 2) * M(2, 0), M(0, 2) * M(1, 0) - M(0, 0) * M(1, 2),
      M(1, 0) * M(2, 1) - M(1, 1) * M(2, 0), M(0, 1) * M(2, 0) - M(0, 0) * M(2, 1), M(0, 0) * M(1, 1) - M(0, 1) * M(1, 0);
  const T inverse_det = T(1) / (M(0, 0) * adjugate(0, 0) + M(0, 1) * adjugate(1, 0) + M(0, 2) * adjugate(2, 0));
  if (inverse_norm_squared) *inverse_norm_squared = adjugate.squaredNorm() * (inverse_det * inverse_det);
  db = (adjugate * (Eb * ra - ra - rb)) * inverse_det;
  Vec3T<T> dba = ra + Ea * db;  // not const: returned by move
  da = db - dba;
  return dba;
}

// Takes the Newton step (δa, δb), δ(ba) = δb − δa, without evaluating again: the witnesses' error
// drops from |δ| to O(|δ|²). Λ follows its quadratic model, Λ + g·δ + ½δᵀHδ = Λ + ½g·δ with
// g = (r_b, r_a) = ∇Λ(a, b) and Hδ = −g; ∇E_B its linear model (the gradient of Λ is read from
// it, solve_newton). ½‖b − a‖² changes by ba·δ(ba) + ½‖δ(ba)‖².
template <class T>
void final_step(SaddleT<T>& s, const Vec3T<T>& rb, const Vec3T<T>& ra, const Vec3T<T>& da, const Vec3T<T>& db,
                const Vec3T<T>& dba) {
  s.shift = T(0.5) * (rb.dot(da) + ra.dot(db)) + s.ba.dot(dba) + T(0.5) * dba.squaredNorm();
  s.eb.gradient += s.eb.hessian * da;  // ∂²E_B(a) δa
  s.a += da;
  s.ba += dba;
  s.b = s.a + s.ba;
}

// The error left after the Newton step (δa, δb) at s, estimated. The residual after the step is
// ½ ∂³E[δ, δ] in each equation; ∂³E's size is estimated by the secant of the Hessians between s
// and an earlier point (Hessians hb at a_then, ha at b_then). The next Newton step (the error
// left) is then at most (1 + 2‖M⁻¹‖) times that, M of saddle_step: |δb| ≤ ‖M⁻¹‖ (|ra| + |rb|)
// and |δa| ≤ |ra| + |δb|, as ‖∂²E − I‖ ≤ 1. `inverse_norm_squared`: ‖M⁻¹‖², saddle_step's.
inline double error_after_step(const Saddle& s, const Mat3& hb, const Vec3& a_then, const Mat3& ha, const Vec3& b_then,
                               double inverse_norm_squared, const Vec3& da, const Vec3& db) {
  const double lb = (s.eb.hessian - hb).norm() / (s.a - a_then).norm();
  const double la = (s.ea.hessian - ha).norm() / (s.b - b_then).norm();
  return (1 + 2 * std::sqrt(inverse_norm_squared)) * 0.5 * (lb * da.squaredNorm() + la * db.squaredNorm());
}

// The stop rule on that estimate: a quarter of it below tol, and the relative error of ∇E_B it
// implies below `relative` (kRelativeStep² for tracked calls, kColdErrorRelative for cold ones).
inline bool error_left_is_below(double left, const P2SValue& eb, double tol, double relative) {
  return 4 * left < tol && below_local_scale(4 * left, eb, relative);
}

// Joint Newton on the saddle-point equations of Lemma 3 in (a, b):
//   r_b = b − Π_B(a) = 0,  r_a = a − Π_A(b) = 0,
// Jacobian [[∂²E_B − I, I], [I, ∂²E_A − I]], eliminated to one 3×3 solve. Two P2S evaluations a
// step; backtracking on ‖r‖. Stops when the next Newton step is below tol (and kRelativeStep ℓ),
// taking that step without evaluating again (the error is then O(tol²)); in double also when the
// error left after it is (error_after_step, secant from the last point, kColdErrorRelative). The
// long-double reference takes every evaluation. Returns false if it cannot make progress, or
// after kDampedSteps damped steps in a row (then the nested method, which is globally
// convergent, takes over): ‖r‖ is no merit function along the long valleys of
// nearly parallel faces, where the witnesses slide by centimetres at residuals of 1e-14 and
// backtracking on ‖r‖ crawls (44 steps where the nested method, descending on the convex
// Λ_B, takes 15).
template <class T, class E>
bool joint_newton(const E& A, const E& B, SaddleT<T>& s, T tol, int max_iter, int& iterations) {
  using V = Vec3T<T>;
  auto residual = [](const SaddleT<T>& x, V& rb, V& ra) {
    rb = x.ba + x.eb.gradient;
    ra = x.ea.gradient - x.ba;
    return rb.squaredNorm() + ra.squaredNorm();
  };
  V rb, ra;
  T merit = residual(s, rb, ra);
  SaddleT<T> trial[2] = {s, s};
  SaddleT<T>* cur = &trial[0];
  SaddleT<T>* next = &trial[1];
  bool done = false, stepped = false;  // stepped: `next` holds the last point
  int damped = 0;
  while (!done && iterations < max_iter) {
    V da, db;
    T inverse_norm_squared = 0;
    const V dba = saddle_step<T>(cur->eb.hessian, cur->ea.hessian, rb, ra, da, db, &inverse_norm_squared);
    if (!da.allFinite() || !db.allFinite()) break;
    const T step2 = std::max(da.squaredNorm(), db.squaredNorm());
    bool stop = step2 < tol * tol && below_local_scale(std::sqrt(step2), cur->eb, kRelativeStep);
    if constexpr (std::is_same_v<T, double>) {
      if (!stop && stepped) {
        const double left = error_after_step(*cur, next->eb.hessian, next->a, next->ea.hessian, next->b, inverse_norm_squared, da, db);
        stop = error_left_is_below(left, cur->eb, tol, kColdErrorRelative);
      }
    }
    if (stop) {
      final_step(*cur, rb, ra, da, db, dba);
      done = true;
      break;
    }
    ++iterations;
    T alpha = 1;
    bool moved = false;
    for (int ls = 0; ls < kJointHalvings; ++ls, alpha *= T(0.5)) {
      next->a = cur->a + alpha * da;
      next->ba = cur->ba + alpha * dba;
      next->b = next->a + next->ba;
      evaluate<T>(A, B, *next);
      V rbn, ran;
      const T m = residual(*next, rbn, ran);
      if (m < (1 - T(1e-4) * alpha) * merit || m == 0) {
        std::swap(cur, next);
        stepped = true;
        rb = rbn, ra = ran, merit = m;
        moved = true;
        break;
      }
    }
    if (!moved) break;
    damped = alpha < 1 ? damped + 1 : 0;
    if (damped >= kDampedSteps) break;
  }
  s = *cur;
  return done;
}

// Newton on Λ_B(a) = max_b Λ(a, b) (nested), from s.a with s.ba warm.
template <class T, class E>
bool nested_newton(const E& A, const E& B, SaddleT<T>& s, T tol, int max_iter, int& iterations) {
  using V = Vec3T<T>;
  using M3 = Mat3T<T>;
  s.ea = maximise_inner<T>(A, s.a, s.ba);
  s.b = s.a + s.ba;
  s.eb = B.strict(s.a, 2);
  T lam = s.lambda();
  const M3 I = M3::Identity();
  while (iterations < max_iter) {
    const V g = s.eb.gradient + s.ba;  // ∇Λ_B(a) = b° − Π_B(a)
    const Eigen::LLT<M3> inner(I - s.ea.hessian);
    // Eq. (11), SPD: ∂²E_B − I + (I − ∂²E_A)⁻¹ = ∂²E_B + (I − ∂²E_A)⁻¹ ∂²E_A, the latter form
    // without the cancellation that loses ∂²E_A (1e-20 near contact) against I.
    const M3 M = s.eb.hessian + inner.solve(s.ea.hessian);
    Eigen::LLT<M3> outer(M);
    V d = outer.info() == Eigen::Success ? V(-outer.solve(g)) : V(-g);
    if (!d.allFinite() || g.dot(d) >= 0) d = -g;
    // No final step here: the step itself must be below kRelativeStep² ℓ.
    if (d.norm() < tol && below_local_scale(d.norm(), s.eb, kRelativeStep * kRelativeStep)) return true;
    ++iterations;
    // b° moves by (I − ∂²E_A)⁻¹ δa, so b° − a by (I − ∂²E_A)⁻¹ ∂²E_A δa.
    const V dba = inner.solve(s.ea.hessian * d);
    const T slope = g.dot(d);
    T alpha = 1;
    bool moved = false;
    for (int ls = 0; ls < 60; ++ls, alpha *= T(0.5)) {
      SaddleT<T> n{s.a + alpha * d, {}, s.ba + alpha * dba, {}, {}};
      n.ea = maximise_inner<T>(A, n.a, n.ba);
      n.b = n.a + n.ba;
      n.eb = B.strict(n.a, 2);
      const T lamn = n.lambda();
      // Near the solution Λ's decrease, ½ g·d, falls below Λ's own rounding (1e-29 against
      // 6e-16 on nearly parallel faces) and the Armijo test sees noise; a step that halves ‖g‖
      // is then taken as well, so Newton keeps converging quadratically.
      const bool halves = (n.eb.gradient + n.ba).norm() <= T(0.5) * g.norm();
      if (halves || lamn <= lam + T(kArmijo) * alpha * slope + kRound<T> * std::abs(lam)) {
        // A step taken without lowering Λ or halving ‖g‖ passed only by the rounding allowance:
        // the decrease Newton predicts is below Λ's rounding, and the steps are noise from here
        // on (they hover at 1e-15 near contact, 1e-14 on nearly parallel faces).
        const bool floor = !(lamn < lam) && !halves;
        s = n, lam = lamn;
        if (floor) return true;
        moved = true;
        break;
      }
    }
    if (!moved) return false;  // no decrease possible at working precision
  }
  return false;
}

template <class T, class E>
WitnessSolutionT<T> newton(const E& A, const E& B, const Vec3T<T>& a0, T tol, int max_iter, const Vec3T<T>* b0) {
  using V = Vec3T<T>;
  WitnessSolutionT<T> out;
  SaddleT<T> s{a0, a0, {}, {}, {}};
  s.eb = B.strict(s.a, 2);
  // Without a start for b, b0 = Π_B(a0): the first saddle equation then holds exactly.
  s.ba = b0 ? V(*b0 - a0) : V(-s.eb.gradient);
  s.b = a0 + s.ba;
  s.ea = A.strict(s.b, 2);
  out.converged = joint_newton<T>(A, B, s, tol, max_iter, out.iterations);
  if (!out.converged) {
    // The nested method's inner solve starts from the last b, or from b = a (exact when a is in A).
    if (!s.a.allFinite() || !s.ba.allFinite()) s.a = a0, s.ba = V::Zero();
    out.converged = nested_newton<T>(A, B, s, tol, max_iter, out.iterations);
  }
  out.a = s.a;
  if (out.converged) {
    // b = Π_B(a) and a = Π_A(b) hold to O(tol²) after the final step; Λ is stationary there.
    out.b = s.b;
    out.ab = s.eb.gradient;
    out.lambda = s.lambda();
  } else {
    out.ab = B.strict(s.a, 1).gradient;
    out.b = s.a - out.ab;
    out.lambda = lambda_of<T>(A, B, out.a, out.b);
    const V fa = out.b - A.strict(out.b, 1).gradient;
    out.converged = (fa - s.a).norm() < tol;  // converged to working precision after all
  }
  if (out.a == s.a && out.b == s.b) out.ea = s.ea, out.eb = s.eb, out.evaluated = true;
  return out;
}

}  // namespace

WitnessSolution solve_newton(const PointToSet& A, const PointToSet& B, const Vec3& a0, double tol, int max_iter,
                             const Vec3* b0) {
  return newton<double>(A, B, a0, tol, max_iter, b0);
}

WitnessSolutionT<long double> solve_newton(const PosedP2S<long double>& A, const PosedP2S<long double>& B,
                                           const Vec3T<long double>& a0, long double tol, int max_iter,
                                           const Vec3T<long double>* b0) {
  return newton<long double>(A, B, a0, tol, max_iter, b0);
}

void lambda_gradients(const WitnessSolution& s, const Pose& pose_a, const Pose& pose_b, Vec6& grad_a,
                      Vec6& grad_b) {
  grad_a.head<3>() = s.ab;
  grad_a.tail<3>() = -(s.b - pose_a.position).cross(-s.ab);
  grad_b.head<3>() = -s.ab;
  grad_b.tail<3>() = -(s.a - pose_b.position).cross(s.ab);
}

namespace {

// ∇E and ∂²E of a shape moved rigidly from `from` to `to`, at x, from its derivatives `e` at x
// before the move: E_to(x) = E_from(y), y = from(to⁻¹(x)), so ∇E_to(x) = R (∇E + ∂²E (y − x))
// and ∂²E_to(x) = R ∂²E Rᵀ (R = R_to R_fromᵀ) to first order in the move; ∂²E_to is exact at
// `anchor`, x carried with the shape.
void moved_derivatives(const P2SValue& e, const Pose& from, const Pose& to, const Vec3& x,
                       Vec3& gradient, Mat3& hessian, Vec3& anchor) {
  if (from.position == to.position && from.rotation.coeffs() == to.rotation.coeffs()) {
    gradient = e.gradient, hessian = e.hessian, anchor = x;  // not moved (e.g. a static obstacle)
    return;
  }
  const Mat3 R = (to.rotation * from.rotation.conjugate()).toRotationMatrix();
  const Vec3 y = R.transpose() * (x - to.position) + from.position;  // from(to⁻¹(x)), by R
  gradient = R * (e.gradient + e.hessian * (y - x));
  hessian = R * e.hessian * R.transpose();
  anchor = R * (x - from.position) + to.position;
}

}  // namespace

bool predict_witnesses(const WitnessSolution& last, const Pose& last_pose_a, const Pose& last_pose_b,
                       const Pose& pose_a, const Pose& pose_b, Vec3& a, Vec3& b, Prediction* detail) {
  Prediction local;
  Prediction& p = detail ? *detail : local;  // filled in place
  Vec3 ga, gb;
  moved_derivatives(last.ea, last_pose_a, pose_a, last.b, ga, p.hessian_a, p.anchor_b);  // E_A at b
  moved_derivatives(last.eb, last_pose_b, pose_b, last.a, gb, p.hessian_b, p.anchor_a);  // E_B at a
  const Vec3 ba = -last.ab;                                                              // b − a without the cancellation of the points' difference (Saddle)
  const Vec3 rb = ba + gb, ra = ga - ba;
  Vec3 da, db;
  const Vec3 dba = saddle_step(p.hessian_b, p.hessian_a, rb, ra, da, db);
  if (!da.allFinite() || !db.allFinite()) return false;
  a = p.a = last.a + da;
  b = p.b = last.b + db;
  p.ba = ba + dba;
  return true;
}

void solve_predicted(const PointToSet& A, const PointToSet& B, const Prediction& p, double tol, int max_iter,
                     WitnessSolution& out) {
  Saddle s{p.a, p.a + p.ba, p.ba, {}, {}};
  evaluate<double>(A, B, s);  // E_A at b, E_B at a
  // The Hessians at the last other point and where (first the carried ones, exact at the anchors).
  Mat3 hb = p.hessian_b, ha = p.hessian_a;
  Vec3 at_a = p.anchor_a, at_b = p.anchor_b;
  int iterations = 0;
  for (; iterations < std::min(2, max_iter - 1); ++iterations) {
    const Vec3 rb = s.ba + s.eb.gradient, ra = s.ea.gradient - s.ba;
    Vec3 da, db;
    double inverse_norm_squared = 0;
    const Vec3 dba = saddle_step(s.eb.hessian, s.ea.hessian, rb, ra, da, db, &inverse_norm_squared);
    if (!da.allFinite() || !db.allFinite()) break;
    // Stop when a quarter of tol bounds the error left after the step (error_after_step, the
    // secant from the carried Hessians or the last point), or, as solve_newton, when the step
    // itself is below tol, taking the step unevaluated. Near contact both also answer to the local
    // length ℓ (kRelativeStep): the step as in joint_newton, the error left, which is what ∇E_B's
    // relative error follows, below kRelativeStep² ℓ.
    const double step = std::sqrt(std::max(da.squaredNorm(), db.squaredNorm()));
    if ((step < tol && below_local_scale(step, s.eb, kRelativeStep)) ||
        error_left_is_below(error_after_step(s, hb, at_a, ha, at_b, inverse_norm_squared, da, db), s.eb, tol,
                            kRelativeStep * kRelativeStep)) {
      final_step(s, rb, ra, da, db, dba);
      out.a = s.a, out.b = s.b, out.ab = s.eb.gradient;
      out.lambda = s.lambda();
      out.ea = s.ea, out.eb = s.eb, out.evaluated = true;
      out.converged = true;
      out.iterations = iterations;
      return;
    }
    hb = s.eb.hessian, ha = s.ea.hessian, at_a = s.a, at_b = s.b;
    s.a += da, s.ba += dba, s.b = s.a + s.ba;
    evaluate<double>(A, B, s);
  }
  // Not certified (or not finite): solve_newton, globally convergent, from the last point.
  if (!s.a.allFinite() || !s.ba.allFinite()) s.a = p.a, s.b = p.b;
  out = solve_newton(A, B, s.a, tol, max_iter - iterations, &s.b);
  out.iterations += iterations;
}

}  // namespace distlab
