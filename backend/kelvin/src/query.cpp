// Algorithm 1: h(x) = −ln(G(y) V(y)) with y = Φ⁻¹(x), and ∇h by the chain rule (eq. 18).
#include <algorithm>
#include <cmath>
#include <limits>

#include "field_impl.hpp"

namespace distlab::kelvin {
namespace {

Sample undefined(Status status) {
  constexpr double nan = std::numeric_limits<double>::quiet_NaN();
  return {nan, Vec3::Constant(nan), status};
}

// ∇_y of V interpolated linearly in cell c: Σ V_k ∇λ_k, with ∇λ_1..3 the rows of the inverse of the
// edge matrix (the normals of barycentric(), divided by the volume term) and ∇λ_0 = −Σ the others.
Vec3 cell_gradient(const PackedMesh& m, int c) {
  const int* t = m.cells[static_cast<size_t>(c)].v;
  const auto vertex = [&](int k) -> const VertexRecord& { return m.vertices[static_cast<size_t>(t[k])]; };
  using Point = Eigen::Map<const Vec3>;
  const Vec3 a = Point(vertex(0).y);
  const Vec3 e1 = Vec3(Point(vertex(1).y)) - a, e2 = Vec3(Point(vertex(2).y)) - a, e3 = Vec3(Point(vertex(3).y)) - a;
  const Vec3 n1 = e2.cross(e3), n2 = e3.cross(e1), n3 = e1.cross(e2);
  const double inv = 1.0 / e1.dot(n1), v0 = vertex(0).value;
  return ((vertex(1).value - v0) * n1 + (vertex(2).value - v0) * n2 + (vertex(3).value - v0) * n3) * inv;
}

// Interpolates V and its vertex gradients (or V's own gradient in the cell) in cell c at
// barycentric lambda, then maps to x.
Sample evaluate(const Field::Impl& m, int c, const double lambda[4], const Vec3& p, const Vec3& y, Gradient kind) {
  double v = 0;
  Vec3 gv = Vec3::Zero();
  // set_sigma(…, gradients = false) skips the vertex gradients; the cell's own needs only V.
  const bool with_gradient = kind == Gradient::cell || m.has_gradients;
  const bool smoothed = kind == Gradient::smoothed && with_gradient;
  for (int k = 0; k < 4; ++k) {
    const VertexRecord& r = m.packed.vertices[static_cast<size_t>(m.packed.cells[static_cast<size_t>(c)].v[k])];
    v += lambda[k] * r.value;
    if (smoothed) gv += lambda[k] * Vec3(Eigen::Map<const Vec3>(r.gradient));
  }
  if (kind == Gradient::cell) gv = cell_gradient(m.packed, c);
  if (!(v > 0)) return undefined(Status::nonpositive);
  const double y2 = y.squaredNorm();
  Sample s;
  s.h = -std::log(std::sqrt(y2) * v);      // U = G V with G = |y| (eq. 16)
  const Vec3 grad_y = -(y / y2 + gv / v);  // ∇_y h
  const double p2 = p.squaredNorm();
  const Vec3 n = p / std::sqrt(p2);
  s.gradient = with_gradient ? Vec3((grad_y - 2 * n * n.dot(grad_y)) / p2)  // ∇_x h = (∂y/∂x)ᵀ ∇_y h
                             : Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
  return s;
}

}  // namespace

Sample Field::query(const Vec3& x, int* hint, Gradient kind) const {
  const Impl& m = *impl_;
  const Vec3 p = x - m.centre;
  const double p2 = p.squaredNorm();
  if (!(p2 > 0)) return undefined(Status::inside);
  const Vec3 y = p / p2;  // eq. 5
  const int start = hint ? *hint : -1;
  Location loc = m.locator.locate(m.packed, y, start);
  if (hint) *hint = loc.cell;
  const auto in_domain = [&m](const Location& l) { return !l.outside_hull && m.packed.in_domain[static_cast<size_t>(l.cell)]; };
  if (in_domain(loc)) return evaluate(m, loc.cell, loc.lambda, p, y, kind);
  // What follows depends on the located cell, and off the hull on where the walk left it, so it
  // starts from the seeding grid's walk: a hint (where the previous point was) changes the speed,
  // never the answer.
  if (start >= 0) {
    loc = m.locator.locate(m.packed, y, -1);
    if (in_domain(loc)) return evaluate(m, loc.cell, loc.lambda, p, y, kind);
  }
  // Not in a domain cell: either on the domain's boundary (a point on a shared face, edge or
  // vertex, located in the outside cell by rounding), inside the object, or in a sliver between
  // the input surface and the mesher's piecewise-flat boundary. A domain cell that shares the
  // point with the located cell shares a vertex with it: look at the domain cells around its
  // four vertices, then at the cells within three face steps, and take the one that needs the
  // least extrapolation.
  int best = -1;
  double best_lambda[4] = {0, 0, 0, 0}, best_min = -1e300;
  auto consider = [&](int n) {
    double lambda[4];
    barycentric(m.packed, n, y, lambda);
    const double lo = std::min(std::min(lambda[0], lambda[1]), std::min(lambda[2], lambda[3]));
    if (lo > best_min) best = n, best_min = lo, std::copy_n(lambda, 4, best_lambda);
  };
  for (int k = 0; k < 4; ++k) {
    const auto v = static_cast<size_t>(m.tm.tets(loc.cell, k));
    for (int e = m.star_start[v]; e < m.star_start[v + 1]; ++e) consider(m.domain_tets[static_cast<size_t>(m.star[static_cast<size_t>(e)] >> 2)]);
  }
  std::vector<int> frontier{loc.cell}, seen{loc.cell};
  for (int depth = 0; depth < 3 && !frontier.empty() && best_min < 0; ++depth) {
    std::vector<int> next;
    for (int c : frontier)
      for (int k = 0; k < 4; ++k) {
        const int n = m.tm.neighbours(c, k);
        if (n < 0 || std::find(seen.begin(), seen.end(), n) != seen.end()) continue;
        seen.push_back(n);
        next.push_back(n);
        if (m.tm.in_domain[static_cast<size_t>(n)]) consider(n);
      }
    frontier.swap(next);
  }
  constexpr double on_face = 1e-9;  // relative to the cell: rounding, not extrapolation
  if (best >= 0 && best_min >= -on_face) return evaluate(m, best, best_lambda, p, y, kind);
  // Inside the object, unless within rounding of its surface (a face's centroid, a vertex), where
  // h is σ's boundary value (eq. 9) as on the meshed boundary next to it.
  if (best < 0 || (m.oracle->inside(x) && !(m.oracle->distance(x) <= 1e-12 * std::max(1.0, x.norm()))))
    return undefined(Status::inside);
  double sum = 0;  // extend from the nearest domain cell, clamped to it
  for (double& l : best_lambda) sum += (l = std::max(l, 0.0));
  for (double& l : best_lambda) l /= sum;
  return evaluate(m, best, best_lambda, p, y, kind);
}

std::vector<Sample> Field::query(const std::vector<Vec3>& points) const {
  std::vector<Sample> out;
  out.reserve(points.size());
  for (const Vec3& x : points) out.push_back(query(x, nullptr));
  return out;
}

}  // namespace distlab::kelvin
