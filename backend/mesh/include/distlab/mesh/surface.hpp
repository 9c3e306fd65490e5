#pragma once
// Indexed triangle meshes: the input and output form of every surface in distlab. Metres.
#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "distlab/geometry/types.hpp"

namespace distlab::mesh {

using FacesX3 = Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>;

struct SurfaceMesh {
  MatX3 vertices;  // one row per vertex
  FacesX3 faces;   // counter-clockwise seen from outside (outward normals)
  // The file's faces when some had over three corners: polygon_corners[f] = k_f, the corner count
  // of the file's face f (load_mesh's triangulation below: faces holds Σ (k_f − 2) rows). Empty:
  // face f is the file's face f. Whatever changes the faces' count or order must clear it.
  std::vector<int> polygon_corners = {};
};

// Triangle t as the user numbers it: "face F" (the file's face), or "face F (triangle j of its
// k-corner polygon)" for a polygon; "face t" when polygon_corners is empty or does not match faces.
std::string file_face_name(const SurfaceMesh& mesh, Eigen::Index triangle);

// Reads OFF, OBJ, PLY (CGAL's polygon-soup readers), STL (a reader of its own) and glTF/GLB and Collada DAE (assimp), chosen by the
// file's extension. The vertices are the file's own, in the file's order: a position listed twice
// keeps both entries (nothing is welded here), and faces index them. A polygon (over three
// corners) becomes k − 2 triangles of its own corners, no vertex added or renumbered, turning as
// it does, in the file's face order: the file's face f is triangles T(f) … T(f) + k_f − 3, where
// T(f) = Σ_{g<f} (k_g − 2); so per-face data in the file's order is spread to triangles (or
// triangle data gathered per file face) by that prefix sum. The triangles are CGAL's constrained
// Delaunay triangulation of the polygon seen along its normal (one coordinate dropped), which
// takes non-convex and slightly non-planar polygons, and a hole written as one loop that runs in
// and out along a bridge edge; a polygon with two corners one behind the other along its normal
// is triangulated in space (CGAL's hole filling). First, a corner equal to (or at the position
// of) its predecessor, cyclically, is dropped (a zero-length edge: the same polygon), and a face
// listing one cycle of corners r times over is that cycle; k counts what is left. A polygon
// without area (collinear corners) stays the fan around its first corner, zero-area triangles
// that the surface checks name. A polygon that is no disk is refused naming the file's face and
// why: its edges cross, a corner lies on an edge, a vertex at corners apart pinches it into loops,
// or its outline overlaps itself. Per format,
// "the file's vertices" are:
//   OFF, OBJ, PLY: the vertex list (OBJ "v" lines, the PLY "vertex" element) in order;
//   STL: which has none, the distinct corner positions in order of first appearance (facet by
//        facet, three corners each): corners at the same position are one vertex;
//   glTF/GLB: each primitive's POSITION accessor in order, primitives in the order the node tree
//        (depth first) places them, node transforms applied;
//   DAE: as glTF, with its <unit meter> applied and its up_axis ignored (URDF's convention).
// STL is binary when its size is 84 + 50·n for the count n its header gives, else ASCII when its
// first word is "solid" (followed by anything: a tab, a name with spaces) and then facets or
// "endsolid" follow, or the file is text; a refusal says which and why (a binary file's size
// against its count, or the ASCII line that breaks the format).
// Declared counts (OFF header, PLY elements, binary STL) are checked against the file's size
// before anything is read, every face index is bounds-checked and every coordinate must be
// finite. Throws InvalidInput(field) for anything else; messages never quote the path.
// Untrusted files: load_mesh_isolated (isolated_import.hpp) runs this in a child process.
// format ("stl", "obj", ...): read as that format whatever the path's extension ("": by extension).
SurfaceMesh load_mesh(const std::string& path, const std::string& field = "mesh.path", const std::string& format = "");

// The bytes of an .stl file: a binary STL (80-byte header, uint32 n, n records of 50 bytes) is
// exactly 84 + 50·n bytes; returns n. An ASCII STL (as load_mesh decides, above): nullopt.
// Anything else throws InvalidInput(field) saying the file is not a valid STL and why.
std::optional<std::uint32_t> binary_stl_triangles(std::string_view bytes, const std::string& field);

// Writes through assimp; format is "stl", "obj", "ply" or "glb". Throws InvalidInput(field).
void save_mesh(const SurfaceMesh& mesh, const std::string& path, const std::string& format,
               const std::string& field = "format");

// Signed enclosed volume (positive for outward-oriented closed meshes).
double signed_volume(const SurfaceMesh& mesh);

}  // namespace distlab::mesh
