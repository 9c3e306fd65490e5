#pragma once
// Indexed triangle meshes: the input and output form of every surface in distlab. Metres.
#include <Eigen/Core>
#include <string>

#include "distlab/geometry/types.hpp"

namespace distlab::mesh {

using FacesX3 = Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>;

struct SurfaceMesh {
  MatX3 vertices;  // one row per vertex
  FacesX3 faces;   // counter-clockwise seen from outside (outward normals)
};

// Reads STL, OBJ, PLY, glTF/GLB, OFF (by extension and content) with assimp, triangulates and
// welds identical positions. Throws InvalidInput(field) if the file cannot be read or is empty.
SurfaceMesh load_mesh(const std::string& path, const std::string& field = "mesh.path");

// Writes through assimp; format is "stl", "obj", "ply" or "glb". Throws InvalidInput(field).
void save_mesh(const SurfaceMesh& mesh, const std::string& path, const std::string& format,
               const std::string& field = "format");

// Signed enclosed volume (positive for outward-oriented closed meshes).
double signed_volume(const SurfaceMesh& mesh);

}  // namespace distlab::mesh
