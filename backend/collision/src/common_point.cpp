// Intersection test with libccd (GJK), a common point from MPR, verified and repaired; the
// penetration depth, direction and witness points from libccd's EPA, refined.
#include <ccd/ccd.h>
#include <ccd/config.h>

#include <cmath>
#include <limits>
#include <type_traits>
#include <variant>

#include "distlab/collision/euclidean.hpp"
#include "gjk.hpp"
#include "placed.hpp"

#ifndef CCD_DOUBLE
#error "distlab needs libccd built with double precision (CCD_DOUBLE)"
#endif
static_assert(std::is_same_v<ccd_real_t, double>, "libccd must use double (CCD_DOUBLE)");

namespace distlab {
namespace detail {
namespace {

void ccd_support(const void* obj, const ccd_vec3_t* dir, ccd_vec3_t* out) {
  const Vec3 s = static_cast<const Placed*>(obj)->support(Vec3(dir->v[0], dir->v[1], dir->v[2]));
  for (int i = 0; i < 3; ++i) out->v[i] = s[i];
}

void ccd_center(const void* obj, ccd_vec3_t* out) {
  const auto* p = static_cast<const Placed*>(obj);
  const Vec3 c = p->R * bounding_ball(*p->shape).center + p->t;
  for (int i = 0; i < 3; ++i) out->v[i] = c[i];
}

}  // namespace

std::optional<Vec3> common_point(const Placed& a, const Placed& b) {
  ccd_t ccd;
  CCD_INIT(&ccd);
  ccd.support1 = ccd.support2 = ccd_support;
  ccd.center1 = ccd.center2 = ccd_center;
  ccd.max_iterations = 200;
  ccd.mpr_tolerance = 1e-6;  // MPR's point is only a candidate (verified below)
  Vec3 n = b.t - a.t;
  if (ccdGJKIntersect(&a, &b, &ccd)) {
    // MPR's position is a good guess but not guaranteed to lie in both shapes.
    ccd_real_t depth = 0;
    ccd_vec3_t dir, pos;
    if (ccdMPRPenetration(&a, &b, &ccd, &depth, &dir, &pos) == 0) {
      const Vec3 p(pos.v[0], pos.v[1], pos.v[2]);
      if (in_both(a, b, p)) return p;
      n = Vec3(dir.v[0], dir.v[1], dir.v[2]);  // from a to b
      const Vec3 mid = 0.5 * (a.support(n) + b.support(-n));
      if (in_both(a, b, mid)) return mid;
    }
  }
  // Settle the rest with our GJK, which stops once a separating direction proves a distance
  // above kTouch. libccd's GJK misses shallow overlaps of round shapes (about one pair in four
  // at depth 1e-6, where FCL's distance sees them), so its "no" is checked too. A zero point of
  // B - A gives convex combinations in A and in B that (almost) coincide. Near contact GJK can
  // stall undecided (lower <= kTouch < upper); a restart with a fresh simplex settles it.
  GjkResult g = gjk_closest(a, b, n, 1e-3 * kTouch, 1e-12, 128, kTouch);
  for (int restart = 0; restart < 3 && g.lower <= kTouch && g.upper > kTouch; ++restart)
    g = gjk_closest(a, b, g.pb - g.pa, 1e-3 * kTouch, 1e-12, 128, kTouch);
  if (g.lower > kTouch || g.upper > kTouch) return std::nullopt;
  const Vec3 p = 0.5 * (g.pa + g.pb);
  if (in_both(a, b, p)) return p;
  return std::nullopt;
}

namespace {

bool polyhedral(const Shape& s) { return std::holds_alternative<Box>(s) || std::holds_alternative<Polytope>(s); }

// The overlap of A and B along the unit direction n (A towards B): moving B by it along n makes
// them touch. The penetration depth is its minimum over n.
double overlap_along(const Placed& a, const Placed& b, const Vec3& n) {
  return -separation_along(a, b, n);
}

// A local minimum of overlap_along near n. The depth is the distance from the origin to the
// boundary of A - B, reached along that boundary's normal: a point beyond the supporting plane
// along n, projected onto A - B (our GJK between A and B moved there), gives the normal of a
// boundary point nearer the minimum (one step on flat faces, a contraction on round ones). Then
// a pattern search polishes. Never worse than the start.
Vec3 refine_direction(const Placed& a, const Placed& b, Vec3 n, double scale) {
  double f = overlap_along(a, b, n), last_change = 0;
  Vec3 m = n;
  for (int it = 0; it < 300; ++it) {
    Placed moved = b;
    moved.t += (overlap_along(a, b, m) + 1e-3 * scale) * m;
    const GjkResult g = gjk_closest_double(a, moved, m, 1e-13 * scale, 1e-12 * scale, 128);
    Vec3 next = (g.pb - g.pa).normalized();
    if (g.overlap || !next.allFinite()) break;
    const double change = (next - m).norm();
    // A linear contraction by rho per step (round shapes, slow when nearly concentric): jump
    // to its limit (Aitken); a bad jump only costs a step, the best direction is kept.
    const double rho = last_change > 0 ? change / last_change : 0;
    if (rho > 0.5 && rho < 0.99) {
      const Vec3 jump = (next + rho / (1 - rho) * (next - m)).normalized();
      if (overlap_along(a, b, jump) < overlap_along(a, b, next)) next = jump;
    }
    last_change = change;
    m = next;
    if (const double fm = overlap_along(a, b, m); fm < f) f = fm, n = m;
    if (change < 1e-12) break;
  }
  // Pattern search: sixteen tangent directions, turned by the golden angle each round (a fixed
  // set stalls in the narrow valleys that edges make), the step halved when none improves.
  constexpr double kPi = 3.14159265358979323846, kGolden = 2.399963229728653;
  double turn = 0;
  for (double step = 1e-4; step > 1e-13;) {
    const Vec3 t1 = n.unitOrthogonal(), t2 = n.cross(t1);
    bool moved = false;
    for (int k = 0; k < 16 && !moved; ++k) {
      const double ang = turn + k * (kPi / 8);
      const Vec3 d = (n + step * (std::cos(ang) * t1 + std::sin(ang) * t2)).normalized();
      if (const double fd = overlap_along(a, b, d); fd < f) f = fd, n = d, moved = true;
    }
    turn += kGolden;
    if (!moved) step *= 0.5;
  }
  return n;
}

// The direction of least overlap among 64 spread over the sphere: a second start beside EPA's,
// against a local minimum in the wrong basin (deep overlaps of elongated shapes have several).
Vec3 best_sampled_direction(const Placed& a, const Placed& b) {
  constexpr int kSamples = 64;
  Vec3 best = Vec3::UnitX();
  double f = std::numeric_limits<double>::infinity();
  for (int i = 0; i < kSamples; ++i) {
    const double z = 1 - (2 * i + 1.0) / kSamples, r = std::sqrt(1 - z * z), phi = 2.399963229728653 * i;
    const Vec3 d(r * std::cos(phi), r * std::sin(phi), z);
    if (const double fd = overlap_along(a, b, d); fd < f) f = fd, best = d;
  }
  return best;
}

}  // namespace

std::optional<Penetration> penetration(const Placed& a, const Placed& b, double scale) {
  ccd_t ccd;
  CCD_INIT(&ccd);
  ccd.support1 = ccd.support2 = ccd_support;
  ccd.center1 = ccd.center2 = ccd_center;
  ccd.max_iterations = 200;
  // EPA ends only when a new support point improves by less than epa_tolerance: exact (finitely
  // many vertices) on polyhedra, coarse on round shapes, where refine_direction finishes. EPA's
  // work on a round shape grows like 1/tolerance where every direction is nearly as deep
  // (concentric spheres: 4 s at 1e-6, 0.2 s at 1e-5; at 1e-3 refinement started in a wrong basin on a
  // cylinder/sphere pair of the tests).
  const bool exact = polyhedral(*a.shape) && polyhedral(*b.shape);
  ccd.epa_tolerance = (exact ? 1e-12 : 1e-5) * scale;
  ccd_real_t depth = 0;
  ccd_vec3_t dir, pos;  // pos unused: the witness points come from the refined direction
  if (ccdGJKPenetration(&a, &b, &ccd, &depth, &dir, &pos) != 0 || !(depth > 0)) return std::nullopt;
  Vec3 n = Vec3(dir.v[0], dir.v[1], dir.v[2]).normalized();
  if (!n.allFinite()) return std::nullopt;
  if (!exact) {
    n = refine_direction(a, b, n, scale);
    // The second start only when it may lie in another basin (a seed within ~17° of n is taken
    // to be in n's basin: a heuristic, checked against dense sampling in the tests).
    if (const Vec3 seed = best_sampled_direction(a, b); seed.dot(n) < 0.955) {
      const Vec3 other = refine_direction(a, b, seed, scale);
      if (overlap_along(a, b, other) < overlap_along(a, b, n)) n = other;
    }
  }
  Penetration p;
  p.direction = n;
  p.depth = overlap_along(a, b, n);  // exact for the direction reported, an upper bound on depth
  if (!(p.depth > 0)) return std::nullopt;
  // Witness points: B moved by the depth along the direction (less kTouch / 2) touches A; a
  // point common to both then is A's witness (on a patch of flat faces, one point of it), and
  // that point moved back is B's. Without one (a direction EPA left short), the support points.
  Placed moved = b;
  moved.t += (p.depth - 0.5 * kTouch) * n;
  if (const auto w = common_point(a, moved)) {
    // Within kInside of both: onto A's supporting plane exactly (B's then follows).
    p.witness_a = *w + n.dot(a.support(n) - *w) * n;
    p.witness_b = p.witness_a - p.depth * n;
  } else {
    p.witness_a = a.support(n);
    p.witness_b = b.support(-n);
  }
  return p;
}

}  // namespace detail

std::optional<Vec3> common_point(const Shape& a, const Pose& pose_a, const Shape& b,
                                 const Pose& pose_b) {
  return detail::common_point(detail::Placed(a, pose_a), detail::Placed(b, pose_b));
}

std::optional<Penetration> penetration(const EuclideanShape& a, const Pose& pose_a,
                                       const EuclideanShape& b, const Pose& pose_b) {
  const double scale = bounding_ball(a.shape()).radius + bounding_ball(b.shape()).radius;
  return detail::penetration(detail::Placed(a.shape(), pose_a), detail::Placed(b.shape(), pose_b), scale);
}

}  // namespace distlab
