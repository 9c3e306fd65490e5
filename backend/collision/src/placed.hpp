#pragma once
// Internal: a shape at a pose, with world-frame support points and an inside test.
#include <optional>

#include "distlab/collision/euclidean.hpp"
#include "distlab/geometry/shape.hpp"

namespace distlab::detail {

// Tolerances shared by the distance and intersection code (absolute, in length units).
// Shapes closer than kTouch count as touching: the distance is reported as 0 when libccd also
// finds them intersecting, and a common point is accepted when it is within kInside of both.
inline constexpr double kTouch = 1e-9;
inline constexpr double kInside = 1e-9;

struct Placed {
  const Shape* shape;
  Mat3 R;
  Vec3 t;
  Placed(const Shape& s, const Pose& p)
      : shape(&s), R(p.rotation.normalized().toRotationMatrix()), t(p.position) {}
  Placed(const Shape& s, const Mat3& rotation, const Vec3& position) : shape(&s), R(rotation), t(position) {}
  // argmax over the placed shape of d . x, world frame.
  Vec3 support(const Vec3& d) const {
    return R * distlab::support(*shape, R.transpose() * d) + t;
  }
  Vec3 to_local(const Vec3& x) const { return R.transpose() * (x - t); }
};

// <= 0 inside; otherwise a lower bound (box, cylinder, polytope) or the exact Euclidean
// distance (sphere, capsule) from the local point p to the shape.
double inside_violation(const Shape& s, const Vec3& p);

inline double inside_violation(const Placed& a, const Vec3& x) {
  return inside_violation(*a.shape, a.to_local(x));
}

// x is accepted as a common point: within kInside of both shapes.
inline bool in_both(const Placed& a, const Placed& b, const Vec3& x) {
  return inside_violation(a, x) <= kInside && inside_violation(b, x) <= kInside;
}

// A point within kInside of both shapes if libccd finds them intersecting (common_point.cpp).
std::optional<Vec3> common_point(const Placed& a, const Placed& b);

// Penetration of overlapping shapes (common_point.cpp); `scale` a length of the pair's size.
std::optional<Penetration> penetration(const Placed& a, const Placed& b, double scale);

}  // namespace distlab::detail
