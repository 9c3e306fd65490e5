#pragma once
// Welding a mesh as the user gave it (the file's vertices in the file's order, a position repeated
// wherever the file repeats it, e.g. an STL's three corners per facet) into the closed surface
// the Kelvin field is prepared on, keeping the map between the two so that per-vertex arrays
// crossing the API stay in the user's order.
#include <vector>

#include "distlab/mesh/surface.hpp"

namespace distlab::mesh {

struct Welded {
  // One vertex per distinct position among the vertices that faces use, numbered in the order of
  // their first user vertex (no duplicates and no unused vertices: the same numbering as the
  // user's); faces as the user's (same order and corners, polygon_corners kept), re-indexed.
  SurfaceMesh surface;
  // to_welded[i]: the welded vertex of user vertex i, or −1 when no face uses vertex i.
  std::vector<int> to_welded;
};

// Exact-position weld: vertices are the same when their three coordinates are equal as doubles
// (−0 and +0 equal). No tolerance: positions a file repeats are bit-identical copies, and a
// tolerance would merge distinct vertices of fine meshes, or chain across a surface.
Welded weld(const SurfaceMesh& user);

}  // namespace distlab::mesh
