#pragma once
// Differentiable witness points (Definition 2) for two disjoint sets, by two methods:
// - the paper's generalized alternating projection a ← Π_A(Π_B(a)) (eq. 2), and
// - Newton's method on Lemma 3's min–max: Λ_B(a) = max_b Λ(a, b) is convex in a, with gradient
//   ∇E_B(a) − (a − b°) and Hessian ∂²E_B(a) − I − (∂²E_A(b°) − I)⁻¹ (eq. 11); Armijo line
//   search on Λ_B itself, the inner maximisation by Newton as well. Converges quadratically where
//   the plain iteration crawls (contraction factors of 0.999+ near contact).
#include "distlab/gap/point_to_set.hpp"

namespace distlab {

template <class T>
struct WitnessSolutionT {
  Vec3T<T> a = Vec3T<T>::Zero();  // a* = Π_A(b*)
  Vec3T<T> b = Vec3T<T>::Zero();  // b* = Π_B(a*)
  // a* − b* = ∇E_B(a*) (Π_B(p) = p − ∇E_B(p), Definition 1; b* = Π_B(a*)), read from the P2S
  // gradient: near contact it is far below |a*| (1e-13 against 0.3 at D ~ 1e-8, 0 in double
  // at d ~ 1e-5), so the difference of the two points keeps few digits or none.
  Vec3T<T> ab = Vec3T<T>::Zero();
  T lambda = 0;        // eq. (3)
  int iterations = 0;  // outer iterations
  bool converged = false;

  // E_A(b) and E_B(a) with derivatives at the returned points, when the solver's last
  // evaluation was there (`evaluated`): the start of the next solve along a motion.
  P2SValueT<T> ea, eb;
  bool evaluated = false;
};
using WitnessSolution = WitnessSolutionT<double>;

// Plain iteration from a0; stops when ‖a[k+1] − a[k]‖ < tol (the paper's rule) or at max_iter.
WitnessSolution solve_fixed_point(const PointToSet& A, const PointToSet& B, const Vec3& a0,
                                  double tol, int max_iter);

// Newton on the min–max from a0; stops when the Newton step is below tol (the error is then
// of the order of tol², quadratic convergence) or at max_iter.
// b0: start for b (default a0: a* and b* are close when ∇E is small).
WitnessSolution solve_newton(const PointToSet& A, const PointToSet& B, const Vec3& a0, double tol,
                             int max_iter, const Vec3* b0 = nullptr);

// A shape at a pose in scalar T, evaluated by PointToSet::strict_at.
template <class T>
struct PosedP2S {
  const PointToSet& set;
  PoseT<T> pose;
  P2SValueT<T> strict(const Vec3T<T>& p, int order) const { return set.strict_at(p, pose, order); }
};

// The same Newton in long double (64-bit significand, 2048× less rounding than double): a
// reference for Λ and its gradient near contact, where double's rounding of the evaluations is
// ~1e-9 of D (gap_gradient_extended). Stop rules at double's precision are scaled to long double's.
WitnessSolutionT<long double> solve_newton(const PosedP2S<long double>& A, const PosedP2S<long double>& B,
                                           const Vec3T<long double>& a0, long double tol, int max_iter,
                                           const Vec3T<long double>* b0 = nullptr);

// Λ(a, b) = E_A(b) + E_B(a) − ½‖a − b‖² (eq. 3 at the witness points).
double lambda_at(const PointToSet& A, const PointToSet& B, const Vec3& a, const Vec3& b);

// Gradients of Λ from the witness points (envelope theorem on Lemma 3's saddle point):
// dΛ/dv_A = a* − b*, dΛ/dω_A = −(b* − t_A) × (b* − a*); B with the roles swapped; a* − b* from
// the solution's ab.
void lambda_gradients(const WitnessSolution& s, const Pose& pose_a, const Pose& pose_b, Vec6& grad_a,
                      Vec6& grad_b);

// Tracking (Euler–Newton continuation): the witnesses move smoothly with the poses, so one
// Newton step of the saddle equations, linearised at the last solution (its E derivatives
// carried rigidly to the new poses), predicts them to second order in the pose change. Newton
// from there needs about one evaluation and step fewer than from the old witnesses.
// The predicted witnesses and the carried Hessians with the points where they are exact (the
// last witnesses carried with each shape): solve_predicted's estimate of E's third derivative.
struct Prediction {
  Vec3 a = Vec3::Zero(), b = Vec3::Zero(), ba = Vec3::Zero();  // ba: b − a, carried (as in the solver)
  Mat3 hessian_b = Mat3::Zero(), hessian_a = Mat3::Zero();     // ∂²E_B at anchor_a, ∂²E_A at anchor_b
  Vec3 anchor_a = Vec3::Zero(), anchor_b = Vec3::Zero();
};

// `last` must be `evaluated`; returns false (a, b untouched) if the prediction is not finite.
bool predict_witnesses(const WitnessSolution& last, const Pose& last_pose_a, const Pose& last_pose_b,
                       const Pose& pose_a, const Pose& pose_b, Vec3& a, Vec3& b, Prediction* detail = nullptr);

// Newton from a prediction: stops after the one evaluation at the predicted witnesses, taking
// its Newton step unevaluated (as solve_newton's last step), when that step is below tol or the
// estimated next one is (the error left after it); else goes on as solve_newton from there.
// The solution is written to `out` (a tracked pair's own, without a copy).
void solve_predicted(const PointToSet& A, const PointToSet& B, const Prediction& p, double tol, int max_iter,
                     WitnessSolution& out);

}  // namespace distlab
