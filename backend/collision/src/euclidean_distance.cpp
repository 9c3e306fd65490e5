// Separation distance, nearest points and pose gradients via FCL, checked by a duality gap.
#include <fcl/narrowphase/distance.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "distlab/collision/euclidean.hpp"
#include "gjk.hpp"
#include "placed.hpp"

namespace distlab {
namespace {

using detail::Placed;

// Solver: GST_LIBCCD. In FCL 0.7 both solvers return nearest points in the world frame (checked
// for every shape pair with both shapes off the origin), but GST_INDEP's GJK can stop early on
// polytopes (a box-box pair came out 1% too far in a random sweep), while libccd's GJK is exact
// on polytopes and as fast (box-box) or faster (fcl::Convex). Its tolerance is an absolute
// distance improvement: at 1e-14 about 15% of curved GJK pairs (cylinder, capsule, sphere vs
// polytope) still need the polish below, against ~80% at 1e-12.
constexpr double kFclTolerance = 1e-14;

fcl::Transform3d to_fcl(const Placed& p) {
  fcl::Transform3d tf;
  tf.linear() = p.R;
  tf.translation() = p.t;
  tf.makeAffine();
  return tf;
}

struct Separation {
  double d;      // <= 0: touching or overlapping
  double lower;  // certified lower bound on the distance
  Vec3 pa, pb;
};

// FCL's nearest points, accepted when the separating direction they define certifies the
// distance to within gap_tol (a direction error of about sqrt(gap / size), so 1e-14 relative
// keeps gradients accurate to ~1e-7); otherwise polished by our own GJK.
Separation separation(const EuclideanShape& ea, const Placed& a, const EuclideanShape& eb,
                      const Placed& b) {
  const fcl::DistanceRequestd request(true, false, 0, 0, kFclTolerance, fcl::GST_LIBCCD);
  fcl::DistanceResultd result;
  const double d_fcl = fcl::distance(ea.fcl_geometry().get(), to_fcl(a), eb.fcl_geometry().get(),
                                     to_fcl(b), request, result);
  const double size = ea.fcl_geometry()->aabb_radius + eb.fcl_geometry()->aabb_radius;
  const double rounding = 1e-15 * (a.t.norm() + b.t.norm() + size);
  Vec3 n0 = b.t - a.t;
  Separation fcl{-1, -1, Vec3::Zero(), Vec3::Zero()};
  double fcl_gap = std::numeric_limits<double>::infinity();
  if (d_fcl > 0) {
    fcl.pa = result.nearest_points[0];
    fcl.pb = result.nearest_points[1];
    fcl.d = (fcl.pb - fcl.pa).norm();
    if (fcl.d > 0) {
      n0 = (fcl.pb - fcl.pa) / fcl.d;
      fcl.lower = detail::separation_along(a, b, n0);
      fcl_gap = fcl.d - fcl.lower;
      if (fcl_gap <= 1e-14 * (fcl.d + size) + rounding) return fcl;
    }
  }
  const detail::GjkResult g =
      detail::gjk_closest(a, b, n0, 1e-14 * (size + std::max(fcl.d, 0.0)) + rounding, 1e-12);
  if (g.overlap) return {0, g.lower, g.pa, g.pb};
  if (fcl_gap <= g.upper - g.lower) return fcl;
  return {g.upper, g.lower, g.pa, g.pb};
}

}  // namespace

EuclideanResult fcl_distance(const EuclideanShape& a, const Pose& pose_a, const EuclideanShape& b,
                             const Pose& pose_b) {
  const Placed pa(a.shape(), pose_a), pb(b.shape(), pose_b);
  const fcl::DistanceRequestd request(true, false, 0, 0, kFclTolerance, fcl::GST_LIBCCD);
  fcl::DistanceResultd result;
  EuclideanResult r;
  r.distance = fcl::distance(a.fcl_geometry().get(), to_fcl(pa), b.fcl_geometry().get(),
                             to_fcl(pb), request, result);
  r.witness_a = result.nearest_points[0];
  r.witness_b = result.nearest_points[1];
  return r;
}

GjkAnswer gjk_distance_or_common_point(const Shape& a, const Pose& pose_a, const Shape& b,
                                       const Pose& pose_b, double scale, double rel_gap) {
  const Placed pa(a, pose_a), pb(b, pose_b);
  return gjk_distance_or_common_point(a, pa.R, pa.t, b, pb.R, pb.t, scale, rel_gap);
}

GjkAnswer gjk_distance_or_common_point(const Shape& a, const Mat3& rotation_a, const Vec3& position_a,
                                       const Shape& b, const Mat3& rotation_b, const Vec3& position_b,
                                       double scale, double rel_gap) {
  const Placed pa(a, rotation_a, position_a), pb(b, rotation_b, position_b);
  const detail::GjkResult g = detail::gjk_closest_double(pa, pb, pb.t - pa.t, 1e-12 * scale,
                                                         detail::kTouch, 64, rel_gap);
  GjkAnswer r;
  r.nearest.witness_a = g.pa;
  r.nearest.witness_b = g.pb;
  r.nearest.distance = g.overlap ? 0.0 : g.upper;
  if (g.overlap) {
    const Vec3 mid = 0.5 * (g.pa + g.pb);
    if (detail::in_both(pa, pb, mid)) r.common = mid;
  }
  return r;
}

EuclideanResult gjk_distance(const Shape& a, const Pose& pose_a, const Shape& b,
                             const Pose& pose_b, double scale, double rel_gap) {
  return gjk_distance_or_common_point(a, pose_a, b, pose_b, scale, rel_gap).nearest;
}

EuclideanResult euclidean_distance(const EuclideanShape& a, const Pose& pose_a,
                                   const EuclideanShape& b, const Pose& pose_b) {
  const Placed pa(a.shape(), pose_a), pb(b.shape(), pose_b);
  const Separation s = separation(a, pa, b, pb);
  EuclideanResult r;
  // Not certified apart by more than kTouch: the distance is 0 when common_point finds a
  // common point, so the two functions agree (up to GJK stalls inside a ~1e-8 contact band).
  if (s.lower <= detail::kTouch) {
    if (const auto p = detail::common_point(pa, pb)) {
      r.witness_a = r.witness_b = *p;
      return r;
    }
    if (!(s.d > 0)) {
      r.witness_a = r.witness_b = 0.5 * (s.pa + s.pb);
      return r;
    }
  }
  r.distance = s.d;
  r.witness_a = s.pa;
  r.witness_b = s.pb;
  const Vec3 n = (s.pb - s.pa) / s.d;
  r.gradient_a << -n, -(s.pa - pa.t).cross(n);
  r.gradient_b << n, (s.pb - pb.t).cross(n);
  return r;
}

}  // namespace distlab
