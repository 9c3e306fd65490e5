// TetMesh → PackedMesh (see packed_mesh.hpp).
#include "packed_mesh.hpp"

#include <limits>

namespace distlab::kelvin {

PackedMesh::PackedMesh(const TetMesh& m)
    : cells(static_cast<std::size_t>(m.tets.rows())), vertices(static_cast<std::size_t>(m.points.rows())), in_domain(m.in_domain.begin(), m.in_domain.end()) {
  for (std::size_t c = 0; c < cells.size(); ++c)
    for (int k = 0; k < 4; ++k) {
      cells[c].v[k] = m.tets(static_cast<Eigen::Index>(c), k);
      cells[c].n[k] = m.neighbours(static_cast<Eigen::Index>(c), k);
    }
  constexpr double nan = std::numeric_limits<double>::quiet_NaN();
  for (std::size_t v = 0; v < vertices.size(); ++v) {
    for (int k = 0; k < 3; ++k) vertices[v].y[k] = m.points(static_cast<Eigen::Index>(v), k);
    vertices[v].value = nan;
    vertices[v].gradient[0] = vertices[v].gradient[1] = vertices[v].gradient[2] = nan;
  }
}

}  // namespace distlab::kelvin
