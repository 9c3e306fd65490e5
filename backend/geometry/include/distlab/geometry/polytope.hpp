#pragma once
// Convex polytopes {x : A x <= b} with unit-norm rows, and how to build them.
#include <vector>

#include "distlab/geometry/types.hpp"

namespace distlab {

struct Polytope {
  MatX3 A;                             // n x 3, rows of unit length
  VecX b;                              // n offsets: the set is {x : A x <= b}
  std::vector<Vec3> vertices;          // extreme points, no duplicates
  std::vector<Eigen::Vector3i> faces;  // triangles over `vertices`, outward (counter-clockwise)
  bool is_hull = false;                // made by polytope_from_points: a mesh's or a cloud's hull

  int rows() const { return static_cast<int>(A.rows()); }
};

// Normalises the rows, then checks that the set is bounded and has an interior (a "regular"
// set in the GAP paper's sense). Throws InvalidInput naming `field` (e.g. "a") on an empty,
// flat or unbounded set, on zero rows, and on non-finite numbers. Rows are kept as given
// (redundant rows stay; they do not change the set).
Polytope make_polytope(const MatX3& A, const VecX& b, const std::string& field);

// Convex hull of points (CGAL) as a polytope; coplanar hull triangles are merged into one row.
// Throws InvalidInput if fewer than 4 affinely independent points or non-finite values.
Polytope polytope_from_points(const std::vector<Vec3>& points, const std::string& field);

// The largest number of half-spaces of a bounded, regular polytope that a single point can
// violate (the paper's m in W_i = 1/(m + eps), Section III-B). Exact: for such a set it equals
// the largest number of rows with a_i . d > 0 over directions d (an open-hemisphere count),
// which is found on the arrangement's vertices +-(a_i x a_j).
int max_violated_halfspaces(const MatX3& A_unit_rows);

// An upper bound of λ_max(Σ_{i in V} w_i a_i a_iᵀ) over the sets V of rows one point can violate
// (w >= 0), in O(n² log n): largest over the arrangement's vertices v of the sum over the rows
// with a_i . v > 0 and the rows tied at v (a_i . v = 0 within 1e-9) of one tangent half circle,
// which holds every cell's set at v. ∂²e_S of eq. 5 is at most
// this times the largest Φ''. Exact where the rows are in general position (each arrangement
// vertex on exactly two great circles). The P2S functions use it for hulls (is_hull) and above
// kAreaWeightedRows rows.
double max_violated_eigenvalue_bound(const MatX3& A_unit_rows, const VecX& w);

// The area of each row's facet: the polytope's triangles, each given to the row whose normal is
// nearest its own. 0 for a row that touches the set only in an edge or a vertex, or is redundant.
VecX facet_areas(const Polytope& P);

// A hull (is_hull) and a polytope of more rows than this get P2S weights by facet area (PointToSet),
// not 1/(m + margin): a 45-facet hull of finger_edu (Gepetto/example-robot-data), m = 42, broke
// Property 2 with it. Written rows keep the paper's rule up to here (its polytopes have 10); above,
// the exact m would cost O(n³).
inline constexpr int kAreaWeightedRows = 64;

}  // namespace distlab
