#pragma once
// Indexed triangle meshes: the input and output form of every surface in distlab. Metres.
#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

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

// The bytes of an .stl file: a binary STL (80-byte header, uint32 n, n records of 50 bytes) is
// exactly 84 + 50·n bytes; returns n. An ASCII STL (starts with "solid", no binary bytes):
// nullopt. Anything else throws InvalidInput(field) saying the file is not a valid STL.
std::optional<std::uint32_t> binary_stl_triangles(std::string_view bytes, const std::string& field);

// Writes through assimp; format is "stl", "obj", "ply" or "glb". Throws InvalidInput(field).
void save_mesh(const SurfaceMesh& mesh, const std::string& path, const std::string& format,
               const std::string& field = "format");

// Signed enclosed volume (positive for outward-oriented closed meshes).
double signed_volume(const SurfaceMesh& mesh);

}  // namespace distlab::mesh
