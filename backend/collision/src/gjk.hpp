#pragma once
// Internal: a small, careful GJK on world-frame support points. Used to polish FCL's answer
// when its duality gap is too large, and to build a common point of overlapping shapes.
#include <limits>

#include "placed.hpp"

namespace distlab::detail {

struct GjkResult {
  Vec3 pa = Vec3::Zero();  // point of A (convex combination of A's support points)
  Vec3 pb = Vec3::Zero();  // point of B, likewise
  double upper = 0;        // |pb - pa|, an upper bound on the distance
  double lower = 0;        // a certified lower bound (best separating direction seen)
  bool overlap = false;    // |pb - pa| <= zero_tol: the shapes touch or overlap
};

// Minimises |b - a| over a in A, b in B, starting from direction n0 (roughly from A to B).
// Stops when upper - lower <= gap_tol, when |b - a| <= zero_tol, when lower > stop_above, or
// when it stalls.
GjkResult gjk_closest(const Placed& a, const Placed& b, const Vec3& n0, double gap_tol,
                      double zero_tol, int max_iter = 64,
                      double stop_above = std::numeric_limits<double>::infinity());

// The same in double: about 2x faster, stalls near gaps of ~1e-11 relative. For starting points,
// which may also stop once the gap is below rel_gap × upper (then lower >= (1 − rel_gap) upper).
GjkResult gjk_closest_double(const Placed& a, const Placed& b, const Vec3& n0, double gap_tol,
                             double zero_tol, int max_iter = 64, double rel_gap = 0);

// Lower bound on the distance certified by the direction n (unit, from A to B).
inline double separation_along(const Placed& a, const Placed& b, const Vec3& n) {
  return n.dot(b.support(-n)) - n.dot(a.support(n));
}

}  // namespace distlab::detail
