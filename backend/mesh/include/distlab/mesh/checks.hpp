#pragma once
// Validation of solid boundaries: a closed, manifold, consistently oriented, non-self-intersecting
// triangle mesh. Each failure throws InvalidInput whose message names the defect.
#include <array>
#include <cstddef>
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

// For a mesh with a topology_defect: which repair (mesh/repair.hpp) can close it, as a sentence
// for the refusal. An edge of more than two faces needs "wrap"; open edges need fix's
// max_hole_edges or "wrap"; the others either.
std::string repair_advice(const SurfaceMesh& mesh);

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

// Where a mesh as the user gave it is not a closed 2-manifold, to draw and count before a repair.
// Found on its exact weld (weld.hpp), as preparation sees it, and numbered as the user numbers
// them: a vertex is the file's first vertex at its position (topology_defect's names), a face is
// the user's triangle (the file's face, or the triangles of a polygon face in order: load_mesh).
// Each list holds at most max_items entries (truncated says that one stopped); counts are whole.
struct MeshDefects {
  struct Piece {
    long faces = 0;
    double volume = 0;                      // enclosed (divergence theorem; its sign: orientation)
    std::vector<std::array<long, 2>> runs;  // its faces as [first, count] runs in face order
  };
  long boundary_edges = 0, non_manifold_edges = 0, non_manifold_vertices = 0, degenerate_faces = 0;
  // Pairs of intersecting triangles (CGAL's self_intersections) among the faces a halfedge mesh
  // takes: faces at a non-manifold edge or vertex that it refuses, and degenerate ones, are not
  // tested (unchecked_faces). The search stops at max_items pairs (self_intersections_complete).
  long self_intersections = 0, unchecked_faces = 0;
  bool self_intersections_complete = true;
  // Open and non-manifold edges as vertex pairs (lower first), intersecting face pairs; the
  // non-manifold vertices; the faces repeating a vertex or without area.
  std::vector<std::array<int, 2>> boundary, non_manifold, intersecting;
  std::vector<int> pinched, degenerate;
  // The pieces, face-connected across shared edges, by first face; the one largest_piece keeps
  // (the largest enclosed volume, -1 without faces).
  std::vector<Piece> pieces;
  int largest = -1;
  bool truncated = false;
};
MeshDefects find_defects(const SurfaceMesh& user, std::size_t max_items);

}  // namespace distlab::mesh
