// Intersection test with libccd (GJK), a common point from MPR, verified and repaired.
#include <ccd/ccd.h>
#include <ccd/config.h>

#include <type_traits>

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

bool in_both(const Placed& a, const Placed& b, const Vec3& p) {
  return inside_violation(a, p) <= kInside && inside_violation(b, p) <= kInside;
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

}  // namespace detail

std::optional<Vec3> common_point(const Shape& a, const Pose& pose_a, const Shape& b,
                                 const Pose& pose_b) {
  return detail::common_point(detail::Placed(a, pose_a), detail::Placed(b, pose_b));
}

}  // namespace distlab
