#pragma once
// Polygon faces of imported files as triangles (load_mesh, surface.hpp).
#include <CGAL/Simple_cartesian.h>

#include <array>
#include <cstddef>
#include <string>
#include <vector>

namespace distlab::mesh::detail {

using Point = CGAL::Simple_cartesian<double>::Point_3;
using Triangle = std::array<std::size_t, 3>;

// The file's face f, its corners the file's vertex ids (finite points), as k − 2 triangles of
// those ids, where k is the number of corners left in `corners` after the reductions surface.hpp
// describes (the triangles' count is what polygon_corners records). Throws InvalidInput(field)
// naming face f when the polygon is no disk (its edges cross, a corner lies on an edge, it
// pinches at a repeated vertex, its outline overlaps itself) or is folded beyond triangulating.
std::vector<Triangle> triangulate_polygon(const std::vector<Point>& points, std::vector<std::size_t>& corners, std::size_t f,
                                          const std::string& field);

}  // namespace distlab::mesh::detail
