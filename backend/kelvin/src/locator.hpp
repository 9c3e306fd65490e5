#pragma once
// Point location in the y-space triangulation: a stochastic visibility walk from a hint cell,
// or from a seed cell taken from a two-level grid over the mesh (no walk from a fixed cell).
// The y-mesh is strongly graded (l_y = |y|² l_x, eq. 23, bounded below), so a uniform grid with
// one box per cell on average has boxes several cells wide where most cells (and queries) are;
// here each block of a coarse grid is split into r³ boxes, r chosen from the number of cells in
// the block, so a box is about a cell everywhere. Each box holds the cell that contains its
// centre (exact barycentric test when the grid is built): a hint-less walk starts within half a
// box diagonal of the point, usually in its cell. The box also keeps a copy of that cell's four
// vertex ids, so the walk's first barycentric test reads the vertices without waiting for the
// cell's record: one dependent cache miss less per hint-less query (16 bytes more per box).
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "distlab/kelvin/tet_mesh.hpp"
#include "packed_mesh.hpp"

namespace distlab::kelvin {

struct Location {
  int cell = -1;
  double lambda[4] = {0, 0, 0, 0};  // barycentric coordinates of the point in cell
  bool outside_hull = false;        // the walk left the triangulation (cell: last hull cell)
  int steps = 0;                    // face crossings of the walk (for tests and profiling)
};

// Seeding grid and walks over a PackedMesh (the caller keeps it alive and unchanged in shape).
class Locator {
 public:
  void build(const PackedMesh& mesh);
  int seed(const Vec3& y) const;
  Location locate(const PackedMesh& mesh, const Vec3& y, int start) const;
  // The cell of the scan fallback (for tests): the one y is most inside of.
  static Location scan(const PackedMesh& mesh, const Vec3& y);
  std::size_t boxes() const { return cells_.size(); }
  std::size_t blocks() const { return blocks_.size(); }
  std::size_t bytes() const {
    return cells_.size() * (sizeof(int) + sizeof(Vertices)) + blocks_.size() * sizeof(Block);
  }
  // Centre of that box (for tests: the seed of a box centre contains it unless it is off the hull).
  Vec3 box_centre(std::size_t box) const;

 private:
  struct Block {
    std::uint32_t first = 0;  // index of its first box in cells_
    std::uint32_t r = 1;      // r × r × r boxes
  };
  using Vertices = std::array<int, 4>;
  std::size_t box(const Vec3& y) const;  // index of the box holding y (clamped into the grid)
  Vec3 centre(const int idx[3], const int sub[3], int r) const;
  Vec3 lo_ = Vec3::Zero(), inv_step_ = Vec3::Ones();
  int n_[3] = {1, 1, 1};                // blocks per axis
  HugeVector<Block> blocks_;            // huge pages: huge_pages.hpp
  HugeVector<int> cells_;               // per box, block by block, x fastest within a block
  HugeVector<Vertices> seed_vertices_;  // per box, the vertices of its cell
};

// Barycentric coordinates of y in cell c (the formula of packed_mesh.hpp).
void barycentric(const TetMesh& mesh, int c, const Vec3& y, double lambda[4]);

}  // namespace distlab::kelvin
