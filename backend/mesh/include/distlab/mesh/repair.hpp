#pragma once
// Turning what users bring into the closed surface the Kelvin field needs (issue 20):
//   fix:  CGAL Polygon_mesh_processing's repair steps, each counted; refused with the remaining
//         defect when they are not enough;
//   wrap: CGAL's 3D Alpha Wrapping, a watertight manifold around any soup, at α and offset;
// and the one rule that carries per-vertex values between the user's mesh and the result.
#include <array>
#include <string>
#include <utility>
#include <vector>

#include "distlab/geometry/progress.hpp"
#include "distlab/mesh/surface.hpp"

namespace distlab::mesh {

struct FixOptions {
  int max_hole_edges = 0;  // holes bounded by at most this many edges are filled (0: none)
};
// triangulate_hole's fallback (its cubic search over all the hole's edges) is allowed only on
// holes up to this many edges: larger ones are filled by the Delaunay-restricted search alone
// (fast: a 950-edge wavy hole in 0.14 s) or stay open and are named in the refusal.
inline constexpr int kCubicHoleEdges = 300;

struct WrapOptions {
  double alpha = 0;   // metres; 0: diagonal / 20 (CGAL's relative α 20)
  double offset = 0;  // metres; 0: α / 30
};

// What a wrap costs, predicted before it runs from the input's face count and area, α and the
// offset (defaults resolved as wrap does). Calibrated on CGAL 5.5's alpha_wrap_3 (issue 36's note:
// spheres, tori, open sheets, the 2CylinderEngine CAD part; α from diagonal/20 to /200):
//   faces   = area / α² · (1 + 0.25 √(α / offset))  — within ×2 of the wrap on closed shapes at
//             10k+ faces; CAD parts (inner surfaces) come out below it; open sheets above it (to
//             ×3 at offset α/30: both sides of a thin part refine to the offset), which the run's
//             own Steiner-point cap catches;
//   memory  = 100 MB + 1.0 kB per input face (AABB tree, soup) + 1.3 kB per wrap face (Delaunay);
//   seconds = wrap faces · (50 + √input faces) µs + 10 µs per input face (the queries near dense
//             input cost more) + 3 µs per face of either surface for the two distance passes
//             (hausdorff_distance; a rough rate, not yet fitted against distlab-bench-wrap).
struct WrapEstimate {
  double alpha = 0, offset = 0;
  double faces = 0, megabytes = 0, seconds = 0;
};
// A wrap's bounds (the server's limits table); a wrap predicted over any of them is refused.
struct WrapBudget {
  std::size_t max_faces = 0;
  double max_megabytes = 0, max_seconds = 0;
};
WrapEstimate estimate_wrap(const SurfaceMesh& user, const WrapOptions& options);
// The smallest α (at the offset given, or α / 30 when none is) whose estimate fits the budget;
// +infinity when none does (the input alone is over the memory or time budget).
double smallest_alpha_within(const SurfaceMesh& user, const WrapOptions& options, const WrapBudget& budget);
// Throws InvalidInput(field + ".alpha") naming the prediction and the α that fits, before any work.
void require_wrap_within(const SurfaceMesh& user, const WrapOptions& options, const WrapBudget& budget,
                         const std::string& field = "repair_options");

struct RepairResult {
  SurfaceMesh surface;                                   // closed, manifold, outward oriented
  std::vector<std::pair<std::string, long long>> steps;  // fix: what each step changed, in order
  double alpha = 0, offset = 0;                          // wrap: the values used
  // One-sided Hausdorff distances (hausdorff_distance, within kReportedRelativeError of
  // themselves): input → result and result → input (metres), for fix and wrap.
  double input_to_result = 0, result_to_input = 0;
};

// Both report stage "repair" to `progress` and throw Cancelled once its token is set: fix between
// its steps and filled holes, wrap between the gates of CGAL's flood fill (its visitor) and
// within the distance passes. The wrap's fraction is its Steiner points against the count
// expected from the face estimate, so it is an estimate, monotone, and below 1 until the end.

// Throws InvalidInput(field) naming the defect that remains after the steps.
RepairResult fix(const SurfaceMesh& user, const FixOptions& options, const std::string& field = "repair",
                 const Progress& progress = {});

// Throws InvalidInput(field) when α or offset is not positive, or (field.alpha) when the estimate
// is over the budget (require_wrap_within) or the running wrap inserts more Steiner points than
// budget.max_faces (a closed surface has about F / 2 vertices: twice the expected count) or
// makes more faces than that.
RepairResult wrap(const SurfaceMesh& user, const WrapOptions& options, const WrapBudget& budget,
                  const std::string& field = "repair_options", const Progress& progress = {});

// The transfer rule, both directions: a point takes the value at the closest point of the
// closest triangle of `from`, interpolated barycentrically from that triangle's three vertices
// (CGAL AABB tree). Row i of the result: the three vertices of `from` and their weights.
struct Transfer {
  std::vector<std::array<int, 3>> vertices;
  std::vector<std::array<double, 3>> weights;
  std::vector<double> distances;  // from each point to its closest point
  std::vector<double> apply(const std::vector<double>& values_at_from) const;
};
// `progress` is checked (never reported to) every few thousand points.
Transfer nearest_face_transfer(const SurfaceMesh& from, const MatX3& points, const Progress& progress = {});

}  // namespace distlab::mesh
