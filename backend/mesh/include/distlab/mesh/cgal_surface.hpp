#pragma once
// A SurfaceMesh as a CGAL::Surface_mesh, in the same order: vertex i is Vertex_index(i), and the
// faces are added row by row. Header-only, so only its includers need CGAL.
#include <CGAL/Surface_mesh.h>

#include <vector>

#include "distlab/mesh/surface.hpp"

namespace distlab::mesh {

// Face rows CGAL refuses (not manifold there) are skipped; with rejected_face given, the
// conversion stops at the first such row and stores it there (-1 when every face was added).
template <class Point>
CGAL::Surface_mesh<Point> to_cgal_surface(const SurfaceMesh& s, Eigen::Index* rejected_face = nullptr) {
  using Mesh = CGAL::Surface_mesh<Point>;
  Mesh m;
  std::vector<typename Mesh::Vertex_index> vi;
  vi.reserve(static_cast<std::size_t>(s.vertices.rows()));
  for (Eigen::Index v = 0; v < s.vertices.rows(); ++v)
    vi.push_back(m.add_vertex(Point(s.vertices(v, 0), s.vertices(v, 1), s.vertices(v, 2))));
  if (rejected_face != nullptr) *rejected_face = -1;
  for (Eigen::Index f = 0; f < s.faces.rows(); ++f)
    if (m.add_face(vi[static_cast<std::size_t>(s.faces(f, 0))], vi[static_cast<std::size_t>(s.faces(f, 1))],
                   vi[static_cast<std::size_t>(s.faces(f, 2))]) == Mesh::null_face() &&
        rejected_face != nullptr) {
      *rejected_face = f;
      break;
    }
  return m;
}

}  // namespace distlab::mesh
