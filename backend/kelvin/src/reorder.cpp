// Spatial renumbering of the tet mesh: vertices and cells in Morton (Z-curve) order, so a cell's
// vertices, its neighbours and their values lie close together in memory (fewer cache and TLB
// misses in point location and interpolation; measured in bench_kelvin's q_hint/q_seed).
#include <algorithm>
#include <cstdint>
#include <numeric>

#include "reorder.hpp"

namespace distlab::kelvin {
namespace {

std::uint64_t spread(std::uint64_t v) {  // 21 bits → every third bit of 63
  v &= 0x1fffff;
  v = (v | v << 32) & 0x1f00000000ffffull;
  v = (v | v << 16) & 0x1f0000ff0000ffull;
  v = (v | v << 8) & 0x100f00f00f00f00full;
  v = (v | v << 4) & 0x10c30c30c30c30c3ull;
  v = (v | v << 2) & 0x1249249249249249ull;
  return v;
}

struct Morton {
  Vec3 lo, scale;
  explicit Morton(const MatX3& p) {
    lo = p.colwise().minCoeff().transpose();
    const Vec3 extent = (p.colwise().maxCoeff().transpose() - lo).cwiseMax(1e-300);
    scale = Vec3::Constant(2097151.0).cwiseQuotient(extent);
  }
  std::uint64_t operator()(const Vec3& y) const {
    std::uint64_t code = 0;
    for (int k = 0; k < 3; ++k) {
      const double q = std::clamp((y[k] - lo[k]) * scale[k], 0.0, 2097151.0);
      code |= spread(static_cast<std::uint64_t>(q)) << k;
    }
    return code;
  }
};

// Order of 0..n-1 by key (ties by index: deterministic).
std::vector<int> order_by(const std::vector<std::uint64_t>& key) {
  std::vector<int> order(key.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return key[a] != key[b] ? key[a] < key[b] : a < b; });
  return order;
}

}  // namespace

void reorder_spatially(TetMesh& m) {
  const auto np = static_cast<int>(m.points.rows()), nt = static_cast<int>(m.tets.rows());
  if (np == 0) return;
  const Morton morton(m.points);
  std::vector<std::uint64_t> key(static_cast<size_t>(np));
  for (int v = 0; v < np; ++v) key[v] = morton(m.points.row(v));
  const std::vector<int> vorder = order_by(key);
  std::vector<int> vnew(static_cast<size_t>(np));
  MatX3 points(np, 3);
  for (int i = 0; i < np; ++i) {
    vnew[vorder[i]] = i;
    points.row(i) = m.points.row(vorder[i]);
  }
  key.assign(static_cast<size_t>(nt), 0);
  for (int c = 0; c < nt; ++c) {
    Vec3 centroid = Vec3::Zero();
    for (int k = 0; k < 4; ++k) centroid += Vec3(m.points.row(m.tets(c, k)));
    key[c] = morton(0.25 * centroid);
  }
  const std::vector<int> corder = order_by(key);
  std::vector<int> cnew(static_cast<size_t>(nt));
  for (int i = 0; i < nt; ++i) cnew[corder[i]] = i;
  TetsX4 tets(nt, 4), neighbours(nt, 4);
  std::vector<std::uint8_t> in_domain(static_cast<size_t>(nt));
  for (int i = 0; i < nt; ++i) {
    const int c = corder[i];
    for (int k = 0; k < 4; ++k) {
      tets(i, k) = vnew[m.tets(c, k)];
      const int n = m.neighbours(c, k);
      neighbours(i, k) = n < 0 ? -1 : cnew[n];
    }
    in_domain[i] = m.in_domain[c];
  }
  m.points = std::move(points);
  m.tets = std::move(tets);
  m.neighbours = std::move(neighbours);
  m.in_domain = std::move(in_domain);
}

}  // namespace distlab::kelvin
