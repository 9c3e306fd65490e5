#pragma once
// Validation of solid boundaries: a closed, manifold, consistently oriented, non-self-intersecting
// triangle mesh. Each failure throws InvalidInput whose message names the defect.
#include <string>
#include <vector>

#include "distlab/mesh/surface.hpp"

namespace distlab::mesh {

struct CheckOptions {
  bool self_intersection = true;  // the O(n log n) CGAL test; topology checks always run
};

// Checks topology and geometry; flips all faces if the mesh is consistently but inwardly
// oriented (negative volume), so the result has outward normals.
void require_closed_manifold(SurfaceMesh& mesh, const std::string& field = "mesh",
                             const CheckOptions& options = {});

// Topology only (boundary edges, non-manifold edges/vertices, orientation): for meshes we produce.
// Returns an empty string when fine, else the defect. names[v]: how vertex v is numbered in the
// message (e.g. the user's first file vertex of a welded vertex); empty: v itself.
std::string topology_defect(const SurfaceMesh& mesh, const std::vector<int>& names = {});

}  // namespace distlab::mesh
