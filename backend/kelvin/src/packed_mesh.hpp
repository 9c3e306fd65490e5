#pragma once
// The tet mesh repacked for queries. A hint-less query is a chain of dependent cache misses
// (seeding grid → cell → its vertices → a neighbour → … → V and ∇V), and on this machine (a VM:
// two-level page walks) each miss to a new page costs about twice a cache miss. TetMesh keeps
// each attribute in its own array, so one walk step touched the cell's row in `tets`, its row in
// `neighbours`, and four rows in `points`, and the interpolation four more in V and four in ∇V.
// Here a cell is one 32-byte record (vertices and face neighbours: one cache line) and a vertex
// one 64-byte record (position, V and ∇V: one cache line), so a step touches a line for the
// cell and a line per vertex, and the interpolation reads lines the walk already brought in.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "distlab/kelvin/tet_mesh.hpp"
#include "huge_pages.hpp"

namespace distlab::kelvin {

struct alignas(32) CellRecord {
  int v[4];  // vertices (as TetMesh::tets)
  int n[4];  // n[i]: the cell opposite v[i], or -1 on the hull (as TetMesh::neighbours)
};

struct alignas(64) VertexRecord {
  double y[3];         // position (as TetMesh::points)
  double value;        // V (NaN until set, and outside Ω_inv)
  double gradient[3];  // ∇_y V (NaN until set)
};

struct PackedMesh {
  HugeVector<CellRecord> cells;  // huge pages: huge_pages.hpp
  HugeVector<VertexRecord> vertices;
  HugeVector<std::uint8_t> in_domain;  // as TetMesh::in_domain

  PackedMesh() = default;
  explicit PackedMesh(const TetMesh& m);
  std::size_t bytes() const {
    return cells.size() * sizeof(CellRecord) + vertices.size() * sizeof(VertexRecord) + in_domain.size();
  }
};

// Barycentric coordinates of y in the tet (a, b, c, d). Every caller uses this one formula, so a
// point gets the same coordinates, bit for bit, from TetMesh and from PackedMesh.
inline void barycentric(const double* pa, const double* pb, const double* pc, const double* pd, const Vec3& y,
                        double lambda[4]) {
  using Point = Eigen::Map<const Vec3>;
  const Vec3 a = Point(pa);
  const Vec3 e1 = Vec3(Point(pb)) - a, e2 = Vec3(Point(pc)) - a, e3 = Vec3(Point(pd)) - a, q = y - a;
  const Vec3 n1 = e2.cross(e3), n2 = e3.cross(e1), n3 = e1.cross(e2);
  const double inv = 1.0 / e1.dot(n1);
  lambda[1] = q.dot(n1) * inv;
  lambda[2] = q.dot(n2) * inv;
  lambda[3] = q.dot(n3) * inv;
  lambda[0] = 1.0 - lambda[1] - lambda[2] - lambda[3];
}

// In the tet of vertices t (a cell's, or the seeding grid's copy of them).
inline void barycentric(const PackedMesh& m, const int t[4], const Vec3& y, double lambda[4]) {
  const auto p = [&](int k) { return m.vertices[static_cast<std::size_t>(t[k])].y; };
  barycentric(p(0), p(1), p(2), p(3), y, lambda);
}

inline void barycentric(const PackedMesh& m, int c, const Vec3& y, double lambda[4]) {
  barycentric(m, m.cells[static_cast<std::size_t>(c)].v, y, lambda);
}

}  // namespace distlab::kelvin
