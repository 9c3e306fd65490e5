#pragma once
// The one-sided Hausdorff distance between two triangle surfaces, to a relative error, at the size
// of scans (issue 36): a 2M-face input against its 100k-face simplification.
#include <string>

#include "distlab/geometry/progress.hpp"
#include "distlab/mesh/surface.hpp"

namespace distlab::mesh {

struct HausdorffDistance {
  double value = 0;        // metres: within error of max_{p in from} d(p, to), and at least every vertex's distance
  double error = 0;        // metres: |value - exact| <= error
  long faces_refined = 0;  // faces of `from` that the vertex bound could not settle (CGAL's part)
};

// The relative error of the distances that simplify, fix and wrap report.
inline constexpr double kReportedRelativeError = 0.05;

// max over the points p of `from` of the distance from p to `to`, within relative_error of itself
// (of 1e-4 of `from`'s size where the distance is below that: every vertex of `from` may lie on `to`).
// The vertices' distances give a lower bound L; a face none of whose points can be farther than
// L + error (its corners' largest distance to one triangle of `to` is at most that: the distance
// to a triangle is convex, so that bounds every point of the face) is settled; so is a face whose
// parts, split by planes through the edges of the triangles of `to` near it (a face straddling a
// flat or folded edge of `to`), each have such a triangle. CGAL's bounded-error Hausdorff
// distance runs on the others only. `from` may be any triangle soup.
// Reports stage `stage` to `progress` and throws Cancelled once its token is set.
HausdorffDistance hausdorff_distance(const SurfaceMesh& from, const SurfaceMesh& to, double relative_error,
                                     const std::string& stage, const Progress& progress = {});

}  // namespace distlab::mesh
