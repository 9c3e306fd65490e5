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
// vertex on exactly two great circles). The P2S functions use it above kAreaWeightedRows rows.
double max_violated_eigenvalue_bound(const MatX3& A_unit_rows, const VecX& w);

// The area of each row's facet: the polytope's triangles, each given to the row whose normal is
// nearest its own. 0 for a row that touches the set only in an edge or a vertex, or is redundant.
VecX facet_areas(const Polytope& P);

// Above this many rows a polytope is taken for a mesh's hull and its P2S weights go by facet area
// (PointToSet); hand-written polytopes and the paper's (10 rows) have fewer. A 200-facet pelvis hull
// (Gepetto/example-robot-data's alex) already broke Property 2 with W = 1/(m + margin).
inline constexpr int kAreaWeightedRows = 64;

}  // namespace distlab
