// Marching tetrahedra on U = |y| V (so the vertex at y = 0, i.e. infinity, needs no special
// case): the boundary of {h ≥ level} = {U ≤ e^(−level)}, mapped back by eq. 5.
//
// Closed 2-manifolds at every level: the domain's boundary is one (make_boundary_manifold), and
// no vertex value equals the level, which is what the two rules below ensure.
// - At σ's smallest boundary value, {h ≥ level} is the whole exterior (h ≥ min σ by the maximum
//   principle), so the surface is the object's own (the domain's boundary facets). The discrete
//   h dips below min σ by up to ~1% in a few interior vertices near slivers (P1 elements keep no
//   maximum principle); at that level those dips would be pockets touching the surface.
// - Every other level is taken as level − kLevelShift, consistently: boundary vertices where σ
//   equals the level (a painted region, σ = 0 elsewhere) then lie strictly inside the region, and
//   crossings near them stay away from them by more than float32 rounding (an STL's precision).
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <vector>

#include "distlab/geometry/error.hpp"
#include "distlab/mesh/marching_tetrahedra.hpp"
#include "field_impl.hpp"

namespace distlab::kelvin {
namespace {

constexpr double kLevelShift = 1e-5;

class Builder {
 public:
  // One byte per vertex: the cell loop reads 4 per cell at random, and bytes stay in cache where
  // the doubles of u do not.
  Builder(const Field::Impl& m, const VecX& u, double level_u) : m_(m), u_(u), level_(level_u), in_(static_cast<size_t>(u.size())) {
    for (Eigen::Index v = 0; v < u.size(); ++v) in_[static_cast<size_t>(v)] = u[v] <= level_u;
    rehash(1 << 12);
  }

  // Output vertex for mesh vertex a (a == b) or for the level crossing on edge (a, b); shared by
  // every triangle that touches it, which makes the surface watertight.
  int vertex(int a, int b) {
    if (a != b) {  // a crossing that rounds onto an end is that end (then faces that collapse are left out)
      const double t = (level_ - u_[a]) / (u_[b] - u_[a]);
      if (!(t > 0)) b = a;
      else if (!(t < 1)) a = b;
    }
    if (a > b) std::swap(a, b);
    const auto key = (static_cast<std::uint64_t>(a) << 32) | static_cast<std::uint32_t>(b);
    std::size_t i = slot(key);
    if (keys_[i] == key) return values_[i];
    if (2 * (points_.size() + 1) > keys_.size()) {
      rehash(2 * keys_.size());
      i = slot(key);
    }
    keys_[i] = key;
    values_[i] = static_cast<int>(points_.size());
    Vec3 y = m_.tm.points.row(a);
    if (a != b) {
      y += (level_ - u_[a]) / (u_[b] - u_[a]) * (Vec3(m_.tm.points.row(b)) - y);
    }
    ys_.push_back(y);
    points_.emplace_back(m_.centre + y / y.squaredNorm());
    return values_[i];
  }

  // Adds triangle (i, j, k) facing n_y in y-space, where the test is well conditioned: the
  // triangle is planar there. The inversion reverses orientation, so the x-space triangle then
  // faces the pushed-forward n_y when its vertex order is reversed.
  void triangle(int i, int j, int k, const Vec3& n_y) {
    if (i == j || j == k || i == k) return;
    const Vec3 &a = ys_[static_cast<size_t>(i)], &b = ys_[static_cast<size_t>(j)], &c = ys_[static_cast<size_t>(k)];
    if ((b - a).cross(c - a).dot(n_y) > 0) tris_.emplace_back(i, k, j);
    else tris_.emplace_back(i, j, k);
  }

  bool in(int v) const { return in_[static_cast<size_t>(v)] != 0; }

  mesh::SurfaceMesh take() {
    mesh::SurfaceMesh out;
    out.vertices.resize(static_cast<Eigen::Index>(points_.size()), 3);
    for (size_t i = 0; i < points_.size(); ++i) out.vertices.row(static_cast<Eigen::Index>(i)) = points_[i];
    out.faces.resize(static_cast<Eigen::Index>(tris_.size()), 3);
    for (size_t i = 0; i < tris_.size(); ++i) out.faces.row(static_cast<Eigen::Index>(i)) = tris_[i];
    return out;
  }

 private:
  // Open addressing (linear probing, load ≤ 1/2): the vertex lookup is the hot path, and a
  // node-based map spent most of its time in malloc.
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};
  std::size_t slot(std::uint64_t key) const {
    std::size_t i = static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ull) >> shift_);
    while (keys_[i] != kEmpty && keys_[i] != key) i = (i + 1) & (keys_.size() - 1);
    return i;
  }
  void rehash(std::size_t capacity) {  // a power of two
    std::vector<std::uint64_t> keys(capacity, kEmpty);
    std::vector<int> values(capacity);
    keys_.swap(keys);
    values_.swap(values);
    shift_ = 64 - static_cast<int>(std::countr_zero(capacity));
    for (std::size_t j = 0; j < keys.size(); ++j)
      if (keys[j] != kEmpty) {
        const std::size_t i = slot(keys[j]);
        keys_[i] = keys[j];
        values_[i] = values[j];
      }
  }

  const Field::Impl& m_;
  const VecX& u_;
  double level_;
  std::vector<std::uint8_t> in_;
  std::vector<std::uint64_t> keys_;
  std::vector<int> values_;
  int shift_ = 0;
  std::vector<Vec3> points_, ys_;
  std::vector<Eigen::Vector3i> tris_;
};

}  // namespace

mesh::SurfaceMesh Field::isosurface(double level) const {
  const Impl& m = *impl_;
  if (m.V.size() == 0) throw std::logic_error("isosurface before set_sigma");
  if (!std::isfinite(level)) throw InvalidInput("isosurfaces.levels", "levels must be finite numbers");
  VecX u(m.tm.points.rows());
  for (Eigen::Index v = 0; v < u.size(); ++v) u[v] = m.tm.points.row(v).norm() * m.V[v];
  double u_boundary = 0;  // e^(−min σ): U = |y| · e^(−σ)/|y| on the boundary
  for (const int v : m.boundary) u_boundary = std::max(u_boundary, u[v]);
  const double lowest_sigma = -std::log(u_boundary);
  const bool at_boundary = std::abs(level - lowest_sigma) <= 1e-9 * std::max(1.0, std::abs(lowest_sigma));
  Builder out(m, u, at_boundary ? u_boundary : std::exp(-(level - kLevelShift)));

  bool crosses = false;  // some cell has the level inside: the field takes it
  if (!at_boundary)
    for (int c : m.domain_tets) {
      int v[4], n_in = 0;
      for (int k = 0; k < 4; ++k) n_in += out.in(v[k] = m.tm.tets(c, k));
      if (n_in == 0 || n_in == 4) continue;
      crosses = true;
      // −∇U in this cell points into {h ≥ level}.
      // ∇U solves D ∇U = ΔU (rows of D: edges from v[0]); D⁻¹ has columns (d_j × d_k) / det D.
      Mat3 d;
      for (int k = 0; k < 3; ++k) d.row(k) = m.tm.points.row(v[k + 1]) - m.tm.points.row(v[0]);
      const Vec3 du(u[v[1]] - u[v[0]], u[v[2]] - u[v[0]], u[v[3]] - u[v[0]]);
      const Vec3 c0 = d.row(1).cross(d.row(2)), c1 = d.row(2).cross(d.row(0)), c2 = d.row(0).cross(d.row(1));
      const double det = d.row(0).dot(c0);
      const Vec3 into = det != 0 ? Vec3(-(du[0] * c0 + du[1] * c1 + du[2] * c2) / det)
                                 : Vec3(-d.colPivHouseholderQr().solve(du));  // degenerate cell
      const bool in[4] = {out.in(v[0]), out.in(v[1]), out.in(v[2]), out.in(v[3])};
      mesh::march_tetrahedron(
          v, in, [&](int a, int b) { return out.vertex(a, b); },
          [&](int a, int b, int e) { out.triangle(a, b, e, into); });
    }
  // No crossing and below every value: the field never takes the level (empty).
  if (!crosses && !at_boundary) {
    const double lowest = minimum();
    if (level < lowest - 1e-9 * std::max(1.0, std::abs(lowest))) return {};
  }
  // Where the region reaches the object's surface, the surface itself closes it (a facet with
  // no corner in the region adds nothing).
  for (const int facet : m.boundary_facets) {
    const int c = facet >> 2, k = facet & 3;
    int f[3], j = 0;
    for (int i = 0; i < 4; ++i)
      if (i != k) f[j++] = m.tm.tets(c, i);
    if (!out.in(f[0]) && !out.in(f[1]) && !out.in(f[2])) continue;
    const Vec3 a = m.tm.points.row(f[0]), b = m.tm.points.row(f[1]), cc = m.tm.points.row(f[2]);
    Vec3 into = (b - a).cross(cc - a);
    if (into.dot(Vec3(m.tm.points.row(m.tm.tets(c, k))) - a) < 0) into = -into;
    int poly[4], n = 0;  // the facet clipped to U ≤ level (Sutherland–Hodgman): ≤ 4 corners
    for (int i = 0; i < 3; ++i) {
      const int p = f[i], q = f[(i + 1) % 3];
      if (out.in(p)) poly[n++] = out.vertex(p, p);
      if (out.in(p) != out.in(q)) poly[n++] = out.vertex(p, q);
    }
    for (int i = 2; i < n; ++i) out.triangle(poly[0], poly[i - 1], poly[i], into);
  }
  return out.take();
}

double Field::minimum() const {
  const Impl& m = *impl_;
  if (m.V.size() == 0) throw std::logic_error("minimum before set_sigma");
  double u_max = 0;  // h = −ln U is smallest where U = |y| V is largest
  for (int c : m.domain_tets)
    for (int k = 0; k < 4; ++k) {
      const int v = m.tm.tets(c, k);
      u_max = std::max(u_max, m.tm.points.row(v).norm() * m.V[v]);
    }
  return -std::log(u_max);
}

}  // namespace distlab::kelvin
