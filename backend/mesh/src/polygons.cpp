// Polygon faces as triangles: CGAL's 2D constrained Delaunay triangulation of the polygon seen
// along its normal, keeping the triangles its outline winds around once (polygons.hpp).
#include "polygons.hpp"

#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <CGAL/Triangulation_face_base_with_info_2.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <map>
#include <numeric>
#include <utility>

#include "distlab/geometry/error.hpp"

namespace distlab::mesh::detail {

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
struct Position {
  std::size_t vertex = 0;  // the file's vertex first seen at this position
  int id = -1;             // the polygon's distinct positions, numbered from 0
};
using Vb = CGAL::Triangulation_vertex_base_with_info_2<Position, K>;
using Fb = CGAL::Constrained_triangulation_face_base_2<K, CGAL::Triangulation_face_base_with_info_2<int, K>>;  // winding number
// Constraints that cross (an intersection needing a new point) throw: such a polygon is no surface.
using Cdt = CGAL::Constrained_Delaunay_triangulation_2<K, CGAL::Triangulation_data_structure_2<Vb, Fb>>;
constexpr int kUnvisited = INT_MIN;

// The corners of a cyclic sequence that remain once a corner equal to its predecessor is dropped
// (a zero-length edge: the same polygon) and a sequence that is one cycle listed r times is
// taken once (the same outline traced r times).
template <class T>
std::vector<std::size_t> reduced(const std::vector<T>& keys) {
  const std::size_t n = keys.size();
  std::vector<std::size_t> kept;
  for (std::size_t k = 0; k < n; ++k)
    if (keys[k] != keys[(k + n - 1) % n]) kept.push_back(k);
  const std::size_t m = kept.size();
  for (std::size_t p = 3; p <= m / 2; ++p) {
    if (m % p != 0) continue;
    bool cycle = true;
    for (std::size_t i = p; i < m && cycle; ++i) cycle = keys[kept[i]] == keys[kept[i % p]];
    if (cycle) {
      kept.resize(p);
      break;
    }
  }
  return kept;
}

// A polygon without area keeps the fan around its first corner: its zero-area triangles are
// named by the surface checks (or removed by "repair": "fix") like any other degenerate face.
std::vector<Triangle> fan(const std::vector<std::size_t>& c) {
  std::vector<Triangle> out;
  for (std::size_t k = 1; k + 1 < c.size(); ++k) out.push_back({c[0], c[k], c[k + 1]});
  return out;
}

// The first corner where the outline comes back to a position it left (not its neighbour), with
// the corner it left: where a polygon that is no disk pinches.
std::string pinch(const std::vector<int>& id, const std::vector<std::size_t>& corners, const std::vector<std::size_t>& number) {
  std::map<int, std::size_t> first;
  for (std::size_t j = 0; j < id.size(); ++j) {
    const auto [it, inserted] = first.emplace(id[j], j);
    if (inserted) continue;
    const std::size_t i = it->second;
    const std::string at = " at corners " + std::to_string(number[i]) + " and " + std::to_string(number[j]);
    return corners[i] == corners[j] ? " lists vertex " + std::to_string(corners[i]) + at
                                    : " lists vertices " + std::to_string(corners[i]) + " and " + std::to_string(corners[j]) + " (one position)" + at;
  }
  return {};
}

// A polygon too far from planar to be seen along one direction (two corners one behind the
// other): CGAL's hole filling, which triangulates the polyline in space (minimizing the worst
// dihedral angle, then the area). Its search takes up to O(k³) time: larger polygons are refused.
constexpr std::size_t kMaxCornersInSpace = 200;
std::vector<Triangle> in_space(const std::vector<Point>& points, const std::vector<std::size_t>& corners, const std::string& why,
                               const std::string& field) {
  if (corners.size() > kMaxCornersInSpace)
    throw InvalidInput(field, why + " with its " + std::to_string(corners.size()) + " corners (over " + std::to_string(kMaxCornersInSpace) +
                                  ") it is not triangulated in space; split it into flatter faces");
  std::vector<K::Point_3> polyline;
  polyline.reserve(corners.size());
  for (const std::size_t v : corners) polyline.emplace_back(points[v].x(), points[v].y(), points[v].z());
  std::vector<CGAL::Triple<int, int, int>> patch;
  CGAL::Polygon_mesh_processing::triangulate_hole_polyline(polyline, std::back_inserter(patch));
  if (patch.size() + 2 != corners.size())
    throw InvalidInput(field, why + " no triangulation in space fits it; split it into flatter faces");
  std::vector<Triangle> out;
  out.reserve(patch.size());
  for (const auto& t : patch)
    out.push_back({corners[static_cast<std::size_t>(t.first)], corners[static_cast<std::size_t>(t.second)], corners[static_cast<std::size_t>(t.third)]});
  return out;
}

}  // namespace

std::vector<Triangle> triangulate_polygon(const std::vector<Point>& points, std::vector<std::size_t>& corners, std::size_t f,
                                          const std::string& field) {
  const std::string face = "face " + std::to_string(f);
  std::vector<std::size_t> number(corners.size());  // the file's corner numbers, for messages
  std::iota(number.begin(), number.end(), 0);
  std::vector<Cdt::Vertex_handle> at;
  const auto keep = [&](const std::vector<std::size_t>& kept) {
    for (std::size_t i = 0; i < kept.size(); ++i) {
      corners[i] = corners[kept[i]], number[i] = number[kept[i]];
      if (!at.empty()) at[i] = at[kept[i]];
    }
    corners.resize(kept.size()), number.resize(kept.size());
    if (!at.empty()) at.resize(kept.size());
  };
  if (const auto kept = reduced(corners); kept.size() >= 3) keep(kept);
  else return fan(corners);
  if (corners.size() == 3) return {{corners[0], corners[1], corners[2]}};

  // Seen along the axis of its normal's largest component, with one coordinate dropped: the
  // projection is exact, so every predicate of the triangulation is. A polygon whose lobes
  // cancel (a bow tie) has no normal and is seen along the axis it spreads most over.
  const std::size_t k = corners.size();
  const Point& o = points[corners[0]];
  std::array<double, 3> normal{}, spread{};
  for (std::size_t i = 0; i < k; ++i) {
    const auto c = CGAL::cross_product(points[corners[i]] - o, points[corners[(i + 1) % k]] - o);
    for (int a = 0; a < 3; ++a) normal[a] += c[a], spread[a] += std::abs(c[a]);
  }
  const auto& along = normal == std::array<double, 3>{} ? spread : normal;
  const auto axis = static_cast<int>(std::max_element(along.begin(), along.end(), [](double a, double b) { return std::abs(a) < std::abs(b); }) - along.begin());
  if (along[axis] == 0) return fan(corners);    // collinear corners: no area
  const int inside = along[axis] > 0 ? 1 : -1;  // the winding number of the polygon's inside, seen from +axis

  Cdt cdt;
  int positions = 0;
  for (const std::size_t v : corners) {
    const Point& p = points[v];
    at.push_back(cdt.insert(K::Point_2(p[(axis + 1) % 3], p[(axis + 2) % 3])));
    Position& seen = at.back()->info();
    if (seen.id < 0) seen = {v, positions++};
    else if (points[seen.vertex] != p)
      return in_space(points, corners, face + " folds over itself: its vertices " + std::to_string(seen.vertex) + " and " + std::to_string(v) + " coincide seen along its normal, and", field);
  }
  // Distinct vertices at one position are one corner (a zero-length edge between them dropped).
  const auto ids = [&]() {
    std::vector<int> out(at.size());
    std::transform(at.begin(), at.end(), out.begin(), [](const Cdt::Vertex_handle& h) { return h->info().id; });
    return out;
  };
  if (const auto kept = reduced(ids()); kept.size() >= 3 && cdt.dimension() == 2) keep(kept);
  else return fan(corners);
  const std::vector<int> id = ids();

  // Each edge once, as the balance of its two directions: an edge the outline runs along and back
  // (the bridge of a polygon with a hole, written as one loop) bounds nothing and is no constraint.
  const std::size_t m = corners.size();
  std::map<std::pair<int, int>, int> forward;  // (lo, hi): traversals lo → hi minus hi → lo
  std::vector<Cdt::Vertex_handle> handle(static_cast<std::size_t>(positions));
  for (std::size_t i = 0; i < m; ++i) {
    const int a = id[i], b = id[(i + 1) % m];
    forward[std::minmax(a, b)] += a < b ? 1 : -1;
    handle[static_cast<std::size_t>(a)] = at[i];
  }
  try {
    for (const auto& [edge, count] : forward)
      if (count != 0) cdt.insert_constraint(handle[static_cast<std::size_t>(edge.first)], handle[static_cast<std::size_t>(edge.second)]);
  } catch (const Cdt::Intersection_of_constraints_exception&) {
    throw InvalidInput(field, face + "'s edges cross each other (seen along its normal): a self-intersecting polygon is no surface; split it where its edges cross");
  }
  // A constraint through a corner was split there: the outline touches itself.
  for (const auto& [edge, count] : forward) {
    const Cdt::Vertex_handle a = handle[static_cast<std::size_t>(edge.first)], b = handle[static_cast<std::size_t>(edge.second)];
    Cdt::Vertex_handle on;
    Cdt::Face_handle unused;
    int index = 0;
    if (count != 0 && !cdt.is_edge(a, b) && cdt.includes_edge(a, b, on, unused, index))
      throw InvalidInput(field, face + " touches itself: its vertex " + std::to_string(on->info().vertex) + " lies on its edge between vertices " +
                                    std::to_string(a->info().vertex) + " and " + std::to_string(b->info().vertex) + "; split it into faces there");
  }

  // Winding numbers, from 0 outside: crossing a → b from its left (the face) to its right.
  for (const auto& fh : cdt.all_face_handles()) fh->info() = kUnvisited;
  std::vector<Cdt::Face_handle> todo{cdt.infinite_face()};
  todo.back()->info() = 0;
  while (!todo.empty()) {
    const Cdt::Face_handle fh = todo.back();
    todo.pop_back();
    for (int i = 0; i < 3; ++i) {
      const Cdt::Face_handle g = fh->neighbor(i);
      if (g->info() != kUnvisited) continue;
      g->info() = fh->info();
      if (fh->is_constrained(i)) {
        const int a = fh->vertex(Cdt::ccw(i))->info().id, b = fh->vertex(Cdt::cw(i))->info().id;
        const int count = forward.at(std::minmax(a, b));
        g->info() -= a < b ? count : -count;
      }
      todo.push_back(g);
    }
  }
  std::vector<Triangle> out;
  bool once = true;
  for (const auto& fh : cdt.finite_face_handles()) {
    if (fh->info() == 0) continue;
    once = once && fh->info() == inside;
    Triangle t{fh->vertex(0)->info().vertex, fh->vertex(1)->info().vertex, fh->vertex(2)->info().vertex};
    if (inside < 0) std::swap(t[1], t[2]);  // the file's orientation
    out.push_back(t);
  }
  // A disk with m corners on its boundary and none inside is m − 2 triangles.
  if (!once || out.size() + 2 != m) {
    if (const std::string where = pinch(id, corners, number); !where.empty())
      throw InvalidInput(field, face + where + ", which are not neighbours (numbers from 0): the polygon pinches into loops that meet there, which no polygon is; split it into faces");
    throw InvalidInput(field, face + "'s outline overlaps itself (part of it is enclosed more than once); split it into faces that do not overlap");
  }
  return out;
}

}  // namespace distlab::mesh::detail
