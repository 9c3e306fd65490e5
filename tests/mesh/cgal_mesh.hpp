#pragma once
// A SurfaceMesh as CGAL's Surface_mesh, for tests that check against CGAL's own algorithms.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>

#include <vector>

#include "distlab/mesh/surface.hpp"

namespace distlab::test {

using CgalKernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using CgalMesh = CGAL::Surface_mesh<CgalKernel::Point_3>;

inline CgalMesh to_cgal(const mesh::SurfaceMesh& m) {
  CgalMesh sm;
  std::vector<CgalMesh::Vertex_index> v;
  for (Eigen::Index i = 0; i < m.vertices.rows(); ++i) v.push_back(sm.add_vertex(CgalKernel::Point_3(m.vertices(i, 0), m.vertices(i, 1), m.vertices(i, 2))));
  for (Eigen::Index f = 0; f < m.faces.rows(); ++f) sm.add_face(v[m.faces(f, 0)], v[m.faces(f, 1)], v[m.faces(f, 2)]);
  return sm;
}

}  // namespace distlab::test
