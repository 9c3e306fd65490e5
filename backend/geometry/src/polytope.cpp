// Building convex polytopes from half-spaces or from points (CGAL hulls, exact predicates).
#include "distlab/geometry/polytope.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/convex_hull_3.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "distlab/geometry/error.hpp"

namespace distlab {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_3;
using Triangle = std::array<std::size_t, 3>;

// Relative tolerances: vertex feasibility/dedup, coplanar merging, flatness.
constexpr double kFeasTol = 1e-9;
constexpr double kFlatTol = 1e-9;

std::string indexed(const std::string& base, std::size_t i) {
  return base + "[" + std::to_string(i) + "]";
}

Point to_point(const Vec3& v) { return Point(v.x(), v.y(), v.z()); }
Vec3 to_vec(const Point& p) { return Vec3(p.x(), p.y(), p.z()); }

// True iff the points span 3-D space (exact predicates: no tolerance involved).
bool full_dimensional(const std::vector<Point>& p) {
  std::size_t i = 1;
  while (i < p.size() && p[i] == p[0]) ++i;
  if (i == p.size()) return false;
  std::size_t j = i + 1;
  while (j < p.size() && CGAL::collinear(p[0], p[i], p[j])) ++j;
  if (j >= p.size()) return false;
  for (std::size_t k = j + 1; k < p.size(); ++k)
    if (!CGAL::coplanar(p[0], p[i], p[j], p[k])) return true;
  return false;
}

struct Hull {
  std::vector<Point> points;
  std::vector<Triangle> faces;  // outward, counter-clockwise seen from outside
};

// Precondition: full_dimensional(points). Goes through Surface_mesh because CGAL 5.5.1's
// indexed-triangle overload of convex_hull_3 gave, on our test data, triangles that were not
// facets of the hull, and its 4-point path gave inward faces.
Hull hull_of(const std::vector<Point>& points) {
  CGAL::Surface_mesh<Point> mesh;
  CGAL::convex_hull_3(points.begin(), points.end(), mesh);
  Hull h;
  std::map<CGAL::Surface_mesh<Point>::Vertex_index, std::size_t> index;
  for (auto v : mesh.vertices()) {
    index[v] = h.points.size();
    h.points.push_back(mesh.point(v));
  }
  for (auto f : mesh.faces()) {
    Triangle t{};
    int k = 0;
    for (auto v : CGAL::vertices_around_face(mesh.halfedge(f), mesh))
      if (k < 3) t[k++] = index[v];  // hull faces are triangles
    h.faces.push_back(t);
  }
  // Orient every face outward explicitly: any hull vertex off its plane is on the inner side.
  for (Triangle& f : h.faces) {
    for (const Point& w : h.points) {
      const auto o = CGAL::orientation(h.points[f[0]], h.points[f[1]], h.points[f[2]], w);
      if (o == CGAL::COPLANAR) continue;
      if (o == CGAL::POSITIVE) std::swap(f[1], f[2]);
      break;
    }
  }
  // CGAL's output order follows memory addresses; a canonical order makes results bit-for-bit
  // reproducible: points sorted lexicographically, each face rotated to start at its smallest
  // index (orientation kept), faces sorted.
  std::vector<std::size_t> order(h.points.size()), rank(h.points.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) {
    return CGAL::compare_xyz(h.points[x], h.points[y]) == CGAL::SMALLER;
  });
  std::vector<Point> sorted;
  for (std::size_t i = 0; i < order.size(); ++i) {
    rank[order[i]] = i;
    sorted.push_back(h.points[order[i]]);
  }
  h.points = std::move(sorted);
  for (Triangle& f : h.faces) {
    for (auto& v : f) v = rank[v];
    std::rotate(f.begin(), std::min_element(f.begin(), f.end()), f.end());
  }
  std::sort(h.faces.begin(), h.faces.end());
  return h;
}

void fill_mesh(const Hull& h, Polytope& P) {
  P.vertices.clear();
  for (const Point& p : h.points) P.vertices.push_back(to_vec(p));
  P.faces.clear();
  for (const Triangle& f : h.faces)
    P.faces.emplace_back(static_cast<int>(f[0]), static_cast<int>(f[1]), static_cast<int>(f[2]));
}

// Rough thinnest width, 2 * volume / area (a slab of thickness t gives t); used to reject
// sets that are flat up to rounding.
bool is_thin(const Polytope& P) {
  double volume = 0, area = 0;
  Vec3 lo = P.vertices[0], hi = P.vertices[0];
  for (const Vec3& v : P.vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  const Vec3 c = 0.5 * (lo + hi);
  for (const auto& f : P.faces) {
    const Vec3 p = P.vertices[f[0]] - c, q = P.vertices[f[1]] - c, r = P.vertices[f[2]] - c;
    volume += p.dot(q.cross(r)) / 6.0;
    area += 0.5 * (q - p).cross(r - p).norm();
  }
  return !(area > 0) || 2.0 * volume / area <= kFlatTol * (hi - lo).norm();
}

// Bounded iff the origin is strictly inside the hull of the unit normals: otherwise some
// direction d has a_i . d <= 0 for all rows and the set contains a ray.
bool normals_surround_origin(const MatX3& A) {
  std::vector<Point> normals;
  for (Eigen::Index i = 0; i < A.rows(); ++i) normals.push_back(to_point(A.row(i).transpose()));
  if (!full_dimensional(normals)) return false;
  const Hull h = hull_of(normals);
  const Point origin = CGAL::ORIGIN;
  for (const Triangle& f : h.faces)
    if (CGAL::orientation(h.points[f[0]], h.points[f[1]], h.points[f[2]], origin) !=
        CGAL::NEGATIVE)
      return false;
  return true;
}

// All intersections of three rows that satisfy every row (within a relative tolerance),
// deduplicated. O(n^3) triples, each checked against all rows with early exit.
std::vector<Vec3> enumerate_vertices(const MatX3& A, const VecX& b) {
  const Eigen::Index n = A.rows();
  const double bscale = b.cwiseAbs().maxCoeff();
  std::vector<Vec3> out;
  for (Eigen::Index i = 0; i < n; ++i) {
    const Vec3 ai = A.row(i);
    for (Eigen::Index j = i + 1; j < n; ++j) {
      const Vec3 aj = A.row(j);
      const Vec3 ij = ai.cross(aj);
      for (Eigen::Index k = j + 1; k < n; ++k) {
        const Vec3 ak = A.row(k);
        const Vec3 jk = aj.cross(ak);
        const double det = ai.dot(jk);
        if (std::abs(det) < 1e-12) continue;  // (nearly) parallel planes: no single point
        const Vec3 x = (b[i] * jk + b[j] * ak.cross(ai) + b[k] * ij) / det;
        const double tol = kFeasTol * (bscale + x.norm());
        bool feasible = x.allFinite();
        for (Eigen::Index r = 0; feasible && r < n; ++r)
          feasible = A.row(r).dot(x) - b[r] <= tol;
        if (!feasible) continue;
        const bool dup = std::any_of(out.begin(), out.end(),
                                     [&](const Vec3& v) { return (v - x).norm() <= 10 * tol; });
        if (!dup) out.push_back(x);
      }
    }
  }
  return out;
}

}  // namespace

Polytope make_polytope(const MatX3& A, const VecX& b, const std::string& field) {
  const Eigen::Index n = A.rows();
  if (b.size() != n)
    throw InvalidInput(field + ".b", "b has " + std::to_string(b.size()) + " entries but A has " +
                                         std::to_string(n) + " rows; they must match");
  if (n == 0)
    throw InvalidInput(field + ".A", "polytope has no rows: give half-spaces a . x <= b");
  Polytope P;
  P.A.resize(n, 3);
  P.b.resize(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto row = A.row(i);
    const std::string ai = indexed(field + ".A", static_cast<std::size_t>(i));
    const std::string bi = indexed(field + ".b", static_cast<std::size_t>(i));
    if (!row.allFinite()) throw InvalidInput(ai, "row contains a non-finite number (NaN or inf)");
    const double norm = row.stableNorm();
    if (!(norm > 0)) throw InvalidInput(ai, "row is all zeros: a half-space needs a non-zero normal");
    if (!std::isfinite(b[i])) throw InvalidInput(bi, "offset is not a finite number");
    P.A.row(i) = row / norm;
    P.b[i] = b[i] / norm;
    if (!std::isfinite(P.b[i]))
      throw InvalidInput(bi, "offset is too large compared with the length of its row");
  }
  if (!normals_surround_origin(P.A))
    throw InvalidInput(field,
                       "unbounded polytope: the rows' normals do not surround the origin, so the "
                       "set extends to infinity in some direction");
  const std::vector<Vec3> corners = enumerate_vertices(P.A, P.b);
  if (corners.empty())
    throw InvalidInput(field, "empty polytope: no point satisfies all rows A x <= b at once");
  std::vector<Point> pts;
  pts.reserve(corners.size());
  for (const Vec3& v : corners) pts.push_back(to_point(v));
  const std::string flat =
      "flat polytope (no interior): the rows only admit points on a plane, line or single point";
  if (!full_dimensional(pts)) throw InvalidInput(field, flat);
  fill_mesh(hull_of(pts), P);
  if (is_thin(P)) throw InvalidInput(field, flat);
  return P;
}

Polytope polytope_from_points(const std::vector<Vec3>& points, const std::string& field) {
  std::vector<Point> pts;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!points[i].allFinite())
      throw InvalidInput(indexed(field + ".points", i), "point has a non-finite coordinate");
    pts.push_back(to_point(points[i]));
  }
  const std::string flat =
      "points span no volume: need at least 4 points that do not lie on one plane";
  if (!full_dimensional(pts)) throw InvalidInput(field + ".points", flat);
  const Hull h = hull_of(pts);
  Polytope P;
  P.is_hull = true;
  fill_mesh(h, P);
  if (is_thin(P)) throw InvalidInput(field + ".points", flat);

  // Merge hull triangles into planar facets by region growing from the largest triangles
  // (their normals are the best conditioned); a neighbour joins when its corners lie on the
  // seed's plane within tolerance.
  const auto& V = P.vertices;
  const std::size_t nf = h.faces.size();
  std::vector<Vec3> normal(nf);
  std::vector<double> area(nf);
  for (std::size_t f = 0; f < nf; ++f) {
    const auto& t = h.faces[f];
    const Vec3 c = (V[t[1]] - V[t[0]]).cross(V[t[2]] - V[t[0]]);
    area[f] = c.norm();
    normal[f] = c / area[f];
  }
  std::map<std::pair<std::size_t, std::size_t>, std::vector<std::size_t>> edge_faces;
  for (std::size_t f = 0; f < nf; ++f)
    for (int e = 0; e < 3; ++e) {
      auto u = h.faces[f][e], w = h.faces[f][(e + 1) % 3];
      edge_faces[{std::min(u, w), std::max(u, w)}].push_back(f);
    }
  std::vector<std::size_t> order(nf);
  for (std::size_t f = 0; f < nf; ++f) order[f] = f;
  std::sort(order.begin(), order.end(), [&](auto x, auto y) { return area[x] > area[y]; });

  Vec3 lo = V[0], hi = V[0];
  for (const Vec3& v : V) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  const double tol = kFeasTol * std::max((hi - lo).norm(), std::max(lo.norm(), hi.norm()));
  std::vector<bool> used(nf, false);
  std::vector<Vec3> rows;
  for (std::size_t seed : order) {
    if (used[seed] || !(area[seed] > 0)) continue;  // a zero-area sliver carries no facet
    const Vec3 n = normal[seed];
    const double off = n.dot(V[h.faces[seed][0]]);
    const auto on_plane = [&](std::size_t f) {
      return std::all_of(h.faces[f].begin(), h.faces[f].end(),
                         [&](std::size_t v) { return std::abs(n.dot(V[v]) - off) <= tol; });
    };
    std::vector<std::size_t> stack{seed};
    used[seed] = true;
    while (!stack.empty()) {
      const std::size_t f = stack.back();
      stack.pop_back();
      for (int e = 0; e < 3; ++e) {
        auto u = h.faces[f][e], w = h.faces[f][(e + 1) % 3];
        for (std::size_t g : edge_faces[{std::min(u, w), std::max(u, w)}])
          if (!used[g] && on_plane(g)) {
            used[g] = true;
            stack.push_back(g);
          }
      }
    }
    rows.push_back(n);
  }
  P.A.resize(static_cast<Eigen::Index>(rows.size()), 3);
  P.b.resize(static_cast<Eigen::Index>(rows.size()));
  for (std::size_t r = 0; r < rows.size(); ++r) {
    const auto ri = static_cast<Eigen::Index>(r);
    P.A.row(ri) = rows[r].transpose();
    // Offset from every vertex, not just the facet's: the row is then valid for all points.
    double best = -std::numeric_limits<double>::infinity();
    for (const Vec3& v : V) best = std::max(best, rows[r].dot(v));
    P.b[ri] = best;
  }
  return P;
}

VecX facet_areas(const Polytope& P) {
  VecX area = VecX::Zero(P.A.rows());
  if (P.A.rows() == 0) return area;
  for (const auto& f : P.faces) {
    const Vec3 c = (P.vertices[f[1]] - P.vertices[f[0]]).cross(P.vertices[f[2]] - P.vertices[f[0]]);
    const double twice = c.norm();
    if (!(twice > 0)) continue;
    Eigen::Index row = 0;
    (P.A * (c / twice)).maxCoeff(&row);
    area[row] += 0.5 * twice;
  }
  return area;
}

}  // namespace distlab
