#pragma once
// The Euclidean baseline: FCL for separation distance and nearest points, libccd (GJK/MPR) for
// the intersection test. Geometry is converted once per shape (EuclideanShape) and reused.
#include <memory>
#include <optional>

#include "distlab/geometry/shape.hpp"

namespace fcl {
template <typename S>
class CollisionGeometry;
}

namespace distlab {

class EuclideanShape {
 public:
  explicit EuclideanShape(const Shape& shape);
  const Shape& shape() const { return *shape_; }
  const std::shared_ptr<fcl::CollisionGeometry<double>>& fcl_geometry() const { return fcl_; }

 private:
  std::shared_ptr<const Shape> shape_;
  std::shared_ptr<fcl::CollisionGeometry<double>> fcl_;
};

struct EuclideanResult {
  double distance = 0;  // >= 0; 0 when the shapes touch or overlap
  Vec3 witness_a = Vec3::Zero();
  Vec3 witness_b = Vec3::Zero();
  // d distance / d (linear velocity, angular velocity about the shape's origin), world frame.
  // Zero when overlapping.
  Vec6 gradient_a = Vec6::Zero();
  Vec6 gradient_b = Vec6::Zero();
};

// Separation distance and nearest points with FCL (DistanceRequest with nearest points). On
// overlap (distance 0) witness_a == witness_b is common_point's answer; only inside the touching
// band (1e-9) where libccd finds none, the midpoint of the nearest points.
EuclideanResult euclidean_distance(const EuclideanShape& a, const Pose& pose_a,
                                   const EuclideanShape& b, const Pose& pose_b);

// FCL's distance and nearest points as FCL returns them: no certification, no gradients, and
// distance <= 0 (FCL's "in collision") without a common point. The baseline a user would call,
// and a cheap start for the GAP solver.
EuclideanResult fcl_distance(const EuclideanShape& a, const Pose& pose_a, const EuclideanShape& b,
                             const Pose& pose_b);

// Nearest points by distlab's own GJK in double precision, started along the line between the
// shapes' origins: no FCL call, no certification, no gradients; distance 0 when GJK finds the
// shapes touching or overlapping. `scale` is a length of the pair's size (e.g. the sum of the
// bounding radii): GJK stops when its duality gap is below 1e-12 scale, or below `rel_gap` times
// the distance found (the shapes are then proved apart by (1 − rel_gap) distance). The GAP
// solver's start, where a nearby point is all that is needed.
EuclideanResult gjk_distance(const Shape& a, const Pose& pose_a, const Shape& b,
                             const Pose& pose_b, double scale, double rel_gap = 0);

// gjk_distance's GJK as an overlap test too: where the shapes overlap, GJK ends at points of A
// and of B that coincide within 1e-9, and their midpoint, accepted by both shapes' inside tests
// (as common_point's are), is a point common to both. `common` holds it; empty when the shapes
// are apart or the test refuses the point (then common_point decides).
struct GjkAnswer {
  EuclideanResult nearest;  // gjk_distance's answer
  std::optional<Vec3> common;
};
GjkAnswer gjk_distance_or_common_point(const Shape& a, const Pose& pose_a, const Shape& b,
                                       const Pose& pose_b, double scale, double rel_gap = 0);
// The same with each pose given as its rotation matrix and position, for callers that hold the
// matrices already (GAP's bodies): no quaternion is normalized and turned into a matrix per call.
GjkAnswer gjk_distance_or_common_point(const Shape& a, const Mat3& rotation_a, const Vec3& position_a,
                                       const Shape& b, const Mat3& rotation_b, const Vec3& position_b,
                                       double scale, double rel_gap = 0);

// Overlapping shapes: the smallest translation of B (depth along direction, a unit vector from A
// towards B) that separates them, with witness points (A's deepest point inside B, B's inside A;
// direction . (witness_a - witness_b) = depth). libccd's EPA, its direction refined for round
// shapes; depth is the overlap measured along the direction reported, so moving B by it makes the
// shapes touch. nullopt when the shapes do not overlap (or only touch).
struct Penetration {
  double depth = 0;
  Vec3 direction = Vec3::Zero();
  Vec3 witness_a = Vec3::Zero();
  Vec3 witness_b = Vec3::Zero();
};
std::optional<Penetration> penetration(const EuclideanShape& a, const Pose& pose_a,
                                       const EuclideanShape& b, const Pose& pose_b);

// libccd intersection test (GJK). If the shapes intersect, returns a point common to both
// (from MPR's penetration position, moved into the intersection); otherwise nullopt.
std::optional<Vec3> common_point(const Shape& a, const Pose& pose_a, const Shape& b,
                                 const Pose& pose_b);

}  // namespace distlab
