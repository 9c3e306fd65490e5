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

// What an exported surface is, counted on its vertices welded at float32 (an STL's precision),
// independently of how it was made: closed (every edge in exactly two faces), a 2-manifold (also
// one fan of faces around every vertex, no face collapsed by the weld), its face-connected pieces
// and enclosed volume (positive: outward faces).
struct SurfaceReport {
  long vertices = 0, faces = 0;
  long boundary_edges = 0, non_manifold_edges = 0, non_manifold_vertices = 0, degenerate_faces = 0;
  long components = 0;
  double volume = 0;
  bool closed() const { return faces > 0 && boundary_edges == 0 && non_manifold_edges == 0; }
  bool manifold() const { return closed() && non_manifold_vertices == 0 && degenerate_faces == 0; }
};
SurfaceReport inspect_surface(const SurfaceMesh& mesh);
// The face-connected piece (across shared edges) enclosing the largest volume, its vertices
// renumbered in their order in `mesh`; *pieces: how many there were. For a welded mesh.
SurfaceMesh largest_piece(const SurfaceMesh& mesh, long* pieces = nullptr);

// Empty for a closed 2-manifold; else its defects with their counts, for a refusal.
std::string surface_defects(const SurfaceReport& report);

}  // namespace distlab::mesh
