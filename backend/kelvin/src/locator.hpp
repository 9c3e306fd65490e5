#pragma once
// Point location in the y-space triangulation: a stochastic visibility walk from a hint cell,
// or from a seed cell taken from a uniform grid over the mesh (no walk from a fixed cell). Each
// grid box holds the cell that contains the box's centre, located exactly when the grid is
// built, so a hint-less walk starts within half a box diagonal of the point (about one cell).
#include <vector>

#include "distlab/kelvin/tet_mesh.hpp"

namespace distlab::kelvin {

struct Location {
  int cell = -1;
  double lambda[4] = {0, 0, 0, 0};  // barycentric coordinates of the point in cell
  bool outside_hull = false;        // the walk left the triangulation (cell: last hull cell)
};

class Locator {
 public:
  void build(const TetMesh& mesh);
  int seed(const Vec3& y) const;
  Location locate(const TetMesh& mesh, const Vec3& y, int start) const;
  // The cell of the scan fallback (for tests): the one y is most inside of.
  static Location scan(const TetMesh& mesh, const Vec3& y);
  std::size_t boxes() const { return grid_.size(); }

 private:
  Vec3 lo_ = Vec3::Zero(), inv_step_ = Vec3::Ones();
  int n_[3] = {1, 1, 1};
  std::vector<int> grid_;
};

// Barycentric coordinates of y in cell c.
void barycentric(const TetMesh& mesh, int c, const Vec3& y, double lambda[4]);

}  // namespace distlab::kelvin
