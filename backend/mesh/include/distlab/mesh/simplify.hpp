#pragma once
// Simplifying big inputs (scans) before preparation (issue 36): CGAL Surface_mesh_simplification's
// edge collapse with its default Lindstrom–Turk cost and placement, down to a face count, with the one-sided
// Hausdorff distance from the input to the result reported (hausdorff.hpp).
#include <cstddef>
#include <string>

#include "distlab/geometry/progress.hpp"
#include "distlab/mesh/surface.hpp"

namespace distlab::mesh {

struct SimplifyResult {
  SurfaceMesh surface;  // at most the requested faces; closed if the input was
  // metres: the one-sided Hausdorff distance from the input to the result, within 5 % of itself
  // (hausdorff.hpp)
  double input_to_result = 0;
};

// `input` must be a manifold, orientable surface (a welded mesh; CGAL's polygon mesh), else
// InvalidInput(field). Reports stage "simplify" to `progress` and throws Cancelled once its
// token is set (checked between collapses). An input with at most `faces` faces is returned as is.
SimplifyResult simplify(const SurfaceMesh& input, std::size_t faces, const std::string& field = "simplify",
                        const Progress& progress = {});

}  // namespace distlab::mesh
