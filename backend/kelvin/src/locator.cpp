// Stochastic visibility walk (terminates on Delaunay/regular triangulations) and seeding grid.
#include "locator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace distlab::kelvin {

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
  lo_ = m.points.colwise().minCoeff().transpose();
  const Vec3 hi = m.points.colwise().maxCoeff().transpose();
  const Vec3 extent = (hi - lo_).cwiseMax(1e-12);
  // About two cells per grid box: short walks, small grid.
  const double box = std::cbrt(extent.prod() * 2.0 / std::max<Eigen::Index>(m.tets.rows(), 1));
  for (int k = 0; k < 3; ++k) {
    n_[k] = std::clamp(static_cast<int>(std::ceil(extent[k] / box)), 1, 512);
    inv_step_[k] = n_[k] / extent[k];
  }
  grid_.assign(static_cast<size_t>(n_[0]) * n_[1] * n_[2], -1);
  std::vector<double> best(grid_.size(), 1e300);
  for (Eigen::Index c = 0; c < m.tets.rows(); ++c) {
    Vec3 centroid = Vec3::Zero();
    for (int k = 0; k < 4; ++k) centroid += Vec3(m.points.row(m.tets(c, k)));
    centroid *= 0.25;
    int idx[3];
    for (int k = 0; k < 3; ++k)
      idx[k] = std::clamp(static_cast<int>((centroid[k] - lo_[k]) * inv_step_[k]), 0, n_[k] - 1);
    const size_t g = (static_cast<size_t>(idx[2]) * n_[1] + idx[1]) * n_[0] + idx[0];
    Vec3 mid;
    for (int k = 0; k < 3; ++k) mid[k] = lo_[k] + (idx[k] + 0.5) / inv_step_[k];
    const double d = (centroid - mid).squaredNorm();
    if (d < best[g]) best[g] = d, grid_[g] = static_cast<int>(c);
  }
  // Empty boxes take a neighbour's cell (repeated dilation), so every box has a nearby seed.
  for (bool changed = true; changed;) {
    changed = false;
    std::vector<int> next = grid_;
    for (int z = 0; z < n_[2]; ++z)
      for (int y = 0; y < n_[1]; ++y)
        for (int x = 0; x < n_[0]; ++x) {
          const size_t g = (static_cast<size_t>(z) * n_[1] + y) * n_[0] + x;
          if (grid_[g] >= 0) continue;
          const int dx[6][3] = {{-1, 0, 0}, {1, 0, 0}, {0, -1, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1}};
          for (const auto& d : dx) {
            const int a = x + d[0], b = y + d[1], c = z + d[2];
            if (a < 0 || b < 0 || c < 0 || a >= n_[0] || b >= n_[1] || c >= n_[2]) continue;
            const int s = grid_[(static_cast<size_t>(c) * n_[1] + b) * n_[0] + a];
            if (s >= 0) { next[g] = s; changed = true; break; }
          }
        }
    grid_.swap(next);
  }
}

int Locator::seed(const Vec3& y) const {
  int idx[3];
  for (int k = 0; k < 3; ++k)
    idx[k] = std::clamp(static_cast<int>((y[k] - lo_[k]) * inv_step_[k]), 0, n_[k] - 1);
  return grid_[(static_cast<size_t>(idx[2]) * n_[1] + idx[1]) * n_[0] + idx[0]];
}

Location Locator::locate(const TetMesh& m, const Vec3& y, int start) const {
  Location loc;
  int c = start >= 0 && start < m.tets.rows() ? start : seed(y);
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
  // The walk cycled (seen at l_x = 0.03 on the cube: rounding in the barycentric coordinates of
  // nearly flat cells). Fall back to a scan of every cell, keeping the one the point is most
  // inside of (largest smallest barycentric coordinate): slow, rare, and it always ends.
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
