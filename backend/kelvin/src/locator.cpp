// Stochastic visibility walk (terminates on Delaunay/regular triangulations) and seeding grid.
#include "locator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace distlab::kelvin {

Location walk(const TetMesh& m, const Vec3& y, int c);

void barycentric(const TetMesh& m, int c, const Vec3& y, double lambda[4]) {
  const auto* t = m.tets.row(c).data();
  const Vec3 a = m.points.row(t[0]);
  const Vec3 e1 = Vec3(m.points.row(t[1])) - a, e2 = Vec3(m.points.row(t[2])) - a,
             e3 = Vec3(m.points.row(t[3])) - a, q = y - a;
  const Vec3 n1 = e2.cross(e3), n2 = e3.cross(e1), n3 = e1.cross(e2);
  const double inv = 1.0 / e1.dot(n1);
  lambda[1] = q.dot(n1) * inv;
  lambda[2] = q.dot(n2) * inv;
  lambda[3] = q.dot(n3) * inv;
  lambda[0] = 1.0 - lambda[1] - lambda[2] - lambda[3];
}

void Locator::build(const TetMesh& m) {
  grid_.clear();
  if (m.tets.rows() == 0) return;
  lo_ = m.points.colwise().minCoeff().transpose();
  const Vec3 hi = m.points.colwise().maxCoeff().transpose();
  const Vec3 extent = (hi - lo_).cwiseMax(1e-12);
  // About one box per cell (a box then spans about one cell where cells are average-sized; the
  // hull's outer cells are larger, the far-field cells near y = 0 smaller: a few walk steps).
  const double box = std::cbrt(extent.prod() / static_cast<double>(m.tets.rows()));
  for (int k = 0; k < 3; ++k) {
    n_[k] = std::clamp(static_cast<int>(std::ceil(extent[k] / box)), 1, 1024);
    inv_step_[k] = n_[k] / extent[k];
  }
  grid_.assign(static_cast<size_t>(n_[0]) * n_[1] * n_[2], -1);
  // Box centres in row order, each walk starting from the previous box's cell (coherent: a few
  // steps each). A centre outside the hull keeps the hull cell where the walk stopped.
  int c = 0;
  Vec3 y;
  for (int z = 0; z < n_[2]; ++z) {
    y.z() = lo_.z() + (z + 0.5) / inv_step_.z();
    int row_start = c;
    for (int yy = 0; yy < n_[1]; ++yy) {
      y.y() = lo_.y() + (yy + 0.5) / inv_step_.y();
      c = row_start;
      for (int x = 0; x < n_[0]; ++x) {
        y.x() = lo_.x() + (x + 0.5) / inv_step_.x();
        const int found = walk(m, y, c).cell;
        if (found >= 0) c = found;  // a cycling walk (rare) keeps its nearby start as the seed
        if (x == 0) row_start = c;
        grid_[(static_cast<size_t>(z) * n_[1] + yy) * n_[0] + x] = c;
      }
    }
    c = grid_[static_cast<size_t>(z) * n_[1] * n_[0]];
  }
}

int Locator::seed(const Vec3& y) const {
  int idx[3];
  for (int k = 0; k < 3; ++k)
    idx[k] = std::clamp(static_cast<int>((y[k] - lo_[k]) * inv_step_[k]), 0, n_[k] - 1);
  return grid_[(static_cast<size_t>(idx[2]) * n_[1] + idx[1]) * n_[0] + idx[0]];
}

Location Locator::locate(const TetMesh& m, const Vec3& y, int start) const {
  Location loc = walk(m, y, start >= 0 && start < m.tets.rows() ? start : seed(y));
  // The walk cycled (seen at l_x = 0.03 on the cube: rounding in the barycentric coordinates of
  // nearly flat cells). Fall back to a scan of every cell: slow, rare, and it always ends.
  return loc.cell >= 0 ? loc : scan(m, y);
}

// Stochastic visibility walk; cell -1 when it did not end within its step budget.
Location walk(const TetMesh& m, const Vec3& y, int c) {
  Location loc;
  // Tolerance so a point on a shared face is accepted by either cell instead of ping-ponging.
  constexpr double eps = 1e-12;
  std::uint32_t rng = 2463534242u;
  const long max_steps = 4 * m.tets.rows() + 16;
  for (long step = 0; step < max_steps; ++step) {
    barycentric(m, c, y, loc.lambda);
    rng ^= rng << 13, rng ^= rng >> 17, rng ^= rng << 5;
    const int first = static_cast<int>(rng & 3u);
    int exit = -1;
    for (int k = 0; k < 4 && exit < 0; ++k) {
      const int i = (first + k) & 3;
      if (loc.lambda[i] < -eps) exit = i;
    }
    loc.cell = c;
    if (exit < 0) return loc;
    const int next = m.neighbours(c, exit);
    if (next < 0) {
      loc.outside_hull = true;
      return loc;
    }
    c = next;
  }
  loc.cell = -1;
  return loc;
}

// Every cell, keeping the one the point is most inside of (largest smallest barycentric).
Location Locator::scan(const TetMesh& m, const Vec3& y) {
  Location loc;
  double best = -std::numeric_limits<double>::infinity();
  double lambda[4];
  for (int k = 0; k < static_cast<int>(m.tets.rows()); ++k) {
    barycentric(m, k, y, lambda);
    const double worst = std::min(std::min(lambda[0], lambda[1]), std::min(lambda[2], lambda[3]));
    if (std::isfinite(worst) && worst > best) {
      best = worst;
      loc.cell = k;
      std::copy(lambda, lambda + 4, loc.lambda);
    }
  }
  if (!(best >= -1e-9)) {
    // Not inside any finite cell: outside the hull; report the nearest cell as the walk does.
    loc.outside_hull = true;
  }
  return loc;
}

}  // namespace distlab::kelvin
