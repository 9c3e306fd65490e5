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

struct WrapOptions {
  double alpha = 0;   // metres; 0: diagonal / 20 (CGAL's relative α 20)
  double offset = 0;  // metres; 0: α / 30
};

struct RepairResult {
  SurfaceMesh surface;                                   // closed, manifold, outward oriented
  std::vector<std::pair<std::string, long long>> steps;  // fix: what each step changed, in order
  double alpha = 0, offset = 0;                          // wrap: the values used
  // wrap: one-sided Hausdorff distances from one surface, sampled on a grid (about 50 points a
  // face, CGAL's sample_triangle_soup), to the other: input → wrap and wrap → input (metres).
  double input_to_result = 0, result_to_input = 0;
};

// Both report stage "repair" to `progress` and throw Cancelled once its token is set: fix between
// its steps and filled holes, wrap between the gates of CGAL's flood fill (its visitor) and
// between the distance samples. The wrap's fraction is its Steiner points against the count
// expected from the face estimate, so it is an estimate, monotone, and below 1 until the end.

// Throws InvalidInput(field) naming the defect that remains after the steps.
RepairResult fix(const SurfaceMesh& user, const FixOptions& options, const std::string& field = "repair",
                 const Progress& progress = {});

// Throws InvalidInput(field) when α or offset is not positive or the wrap would exceed max_faces
// (estimated from 4 · area / α² before wrapping, counted after).
RepairResult wrap(const SurfaceMesh& user, const WrapOptions& options, std::size_t max_faces,
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
