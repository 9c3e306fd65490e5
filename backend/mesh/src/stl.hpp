#pragma once
// STL import (load_mesh, surface.hpp): binary or ASCII, decided by the binary size formula and
// the ASCII keywords, and read into the file's vertices (distinct corner positions).
#include <cstddef>
#include <string>
#include <vector>

#include "polygons.hpp"

namespace distlab::mesh::detail {

// Reads an .stl file's bytes into points and triangles (indices into points). Throws
// InvalidInput(field) with what is wrong: a binary file's size against its count, or the line
// of an ASCII file that breaks the format.
void read_stl(const std::string& bytes, std::vector<Point>& points, std::vector<std::vector<std::size_t>>& soup,
              const std::string& field);

}  // namespace distlab::mesh::detail
