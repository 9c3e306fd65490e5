// Repair and wrapping of user meshes, and the nearest-face transfer rule (repair.hpp).
#include "distlab/mesh/repair.hpp"

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/border.h>
#include <CGAL/Polygon_mesh_processing/distance.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/repair_degeneracies.h>
#include <CGAL/Polygon_mesh_processing/repair_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/stitch_borders.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/alpha_wrap_3.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>

#include "distlab/geometry/error.hpp"
#include "distlab/mesh/checks.hpp"
#include "distlab/mesh/hausdorff.hpp"

namespace distlab::mesh {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_3;
using Mesh = CGAL::Surface_mesh<Point>;
namespace PMP = CGAL::Polygon_mesh_processing;

std::vector<Point> points_of(const SurfaceMesh& m) {
  std::vector<Point> out;
  out.reserve(static_cast<std::size_t>(m.vertices.rows()));
  for (Eigen::Index v = 0; v < m.vertices.rows(); ++v) out.emplace_back(m.vertices(v, 0), m.vertices(v, 1), m.vertices(v, 2));
  return out;
}

std::vector<std::vector<std::size_t>> triangles_of(const SurfaceMesh& m) {
  std::vector<std::vector<std::size_t>> out;
  out.reserve(static_cast<std::size_t>(m.faces.rows()));
  for (Eigen::Index f = 0; f < m.faces.rows(); ++f)
    out.push_back({static_cast<std::size_t>(m.faces(f, 0)), static_cast<std::size_t>(m.faces(f, 1)), static_cast<std::size_t>(m.faces(f, 2))});
  return out;
}

SurfaceMesh from_cgal(const Mesh& sm) {
  SurfaceMesh out;
  std::vector<int> index(sm.number_of_vertices() + sm.number_of_removed_vertices(), -1);
  out.vertices.resize(static_cast<Eigen::Index>(sm.number_of_vertices()), 3);
  int n = 0;
  for (auto v : sm.vertices()) {
    const Point& p = sm.point(v);
    out.vertices.row(n) << p.x(), p.y(), p.z();
    index[v.idx()] = n++;
  }
  out.faces.resize(static_cast<Eigen::Index>(sm.number_of_faces()), 3);
  Eigen::Index f = 0;
  for (auto face : sm.faces()) {
    int k = 0;
    for (auto v : CGAL::vertices_around_face(sm.halfedge(face), sm)) out.faces(f, std::min(k++, 2)) = index[v.idx()];
    ++f;
  }
  return out;
}

double diagonal(const SurfaceMesh& m) { return (m.vertices.colwise().maxCoeff() - m.vertices.colwise().minCoeff()).norm(); }

double area_of(const SurfaceMesh& m) {
  double area = 0;
  for (Eigen::Index f = 0; f < m.faces.rows(); ++f) {
    const Vec3 p = m.vertices.row(m.faces(f, 0)), q = m.vertices.row(m.faces(f, 1)), r = m.vertices.row(m.faces(f, 2));
    area += 0.5 * (q - p).cross(r - p).norm();
  }
  return area;
}

// CGAL's flood fill calls this before each gate (a facet between outside and inside): the place
// where the job's token is polled, and where inserted Steiner points give the progress.
struct WrapVisitor : CGAL::Alpha_wraps_3::internal::Wrapping_default_visitor {
  const Progress* progress = nullptr;
  const std::string* field = nullptr;
  double alpha = 0;
  double expected_vertices = 1;
  std::size_t max_steiner_points = 0;
  std::size_t steiner_points = 0;

  template <typename Wrapper, typename Gate>
  void before_facet_treatment(const Wrapper&, const Gate&) const { progress->check(); }
  template <typename Wrapper, typename VertexHandle>
  void after_Steiner_point_insertion(const Wrapper&, VertexHandle) {
    if (++steiner_points > max_steiner_points)  // the estimate was low for this input: stop here
      throw InvalidInput(*field + ".alpha", "α " + std::to_string(alpha) + " m: the wrap passed " + std::to_string(max_steiner_points) +
                                                " points, over this server's budget (its surface would have more faces than " +
                                                std::to_string(max_steiner_points) + "); use a larger alpha");
    if (steiner_points % 256 == 0)
      (*progress)("repair", 0.8 * std::min(0.99, static_cast<double>(steiner_points) / expected_vertices));
  }
};

// A one-sided Hausdorff distance of a repair (hausdorff_distance, to kReportedRelativeError),
// reported as the fractions [from, to] of stage "repair".
double repair_distance(const SurfaceMesh& a, const SurfaceMesh& b, const Progress& progress, double from, double to) {
  const Progress part{[&](const std::string&, double f) { progress("repair", from + (to - from) * f); }, progress.cancel};
  return hausdorff_distance(a, b, kReportedRelativeError, "repair", part).value;
}

}  // namespace

RepairResult fix(const SurfaceMesh& user, const FixOptions& options, const std::string& field, const Progress& progress) {
  RepairResult out;
  progress("repair", 0.0);
  std::vector<Point> points = points_of(user);
  auto polygons = triangles_of(user);
  const auto count = [&](const char* step, std::size_t n) { out.steps.emplace_back(step, static_cast<long long>(n)); };
  count("merged_duplicate_vertices", PMP::merge_duplicate_points_in_polygon_soup(points, polygons));
  progress("repair", 0.1);
  std::size_t before = polygons.size();
  PMP::internal::simplify_polygons_in_polygon_soup<K>(points, polygons);
  PMP::internal::remove_invalid_polygons_in_polygon_soup(points, polygons);
  count("removed_degenerate_faces", before - polygons.size());
  count("removed_duplicate_faces", PMP::merge_duplicate_polygons_in_polygon_soup(points, polygons));
  PMP::remove_isolated_points_in_polygon_soup(points, polygons);
  const std::size_t points_before_orient = points.size();
  if (polygons.empty()) throw InvalidInput(field, "repair left no faces: every face was degenerate");
  progress("repair", 0.2);
  PMP::orient_polygon_soup(points, polygons);
  count("split_non_manifold_vertices", points.size() - points_before_orient);
  progress("repair", 0.4);
  Mesh sm;
  PMP::polygon_soup_to_polygon_mesh(points, polygons, sm);
  count("stitched_edges", PMP::stitch_borders(sm));
  progress("repair", 0.5);
  before = sm.number_of_faces();
  PMP::remove_degenerate_faces(sm);
  sm.collect_garbage();
  count("removed_zero_area_faces", before - sm.number_of_faces());
  std::size_t filled = 0;
  if (options.max_hole_edges > 0) {
    std::vector<Mesh::Halfedge_index> borders;
    PMP::extract_boundary_cycles(sm, std::back_inserter(borders));
    for (std::size_t i = 0; i < borders.size(); ++i) {
      progress("repair", 0.6 + 0.3 * static_cast<double>(i) / static_cast<double>(borders.size()));
      const auto h = borders[i];
      std::size_t edges = 0;
      for ([[maybe_unused]] auto e : CGAL::halfedges_around_face(h, sm)) ++edges;
      if (edges > static_cast<std::size_t>(options.max_hole_edges)) continue;
      std::vector<Mesh::Face_index> patch;
      PMP::triangulate_hole(sm, h, std::back_inserter(patch),
                            PMP::parameters::use_delaunay_triangulation(true).do_not_use_cubic_algorithm(edges > static_cast<std::size_t>(kCubicHoleEdges)));
      filled += !patch.empty();
    }
  }
  count("filled_holes", filled);
  if (CGAL::is_closed(sm) && !PMP::is_outward_oriented(sm)) {
    PMP::reverse_face_orientations(sm);
    count("reversed_orientation", 1);
  } else {
    count("reversed_orientation", 0);
  }
  progress("repair", 0.9);
  out.surface = from_cgal(sm);
  // The surface checks name what is left (boundary edges, non-manifold parts, self-intersections).
  try {
    require_closed_manifold(out.surface, field);
  } catch (const InvalidInput& e) {
    throw InvalidInput(field, std::string("repair is not enough (try \"wrap\"): after it, ") + e.what());
  }
  // How far the fix moved the surface: input → fixed is ~0 unless faces were removed; fixed →
  // input is how far a filled hole's patch lies from the input.
  out.input_to_result = repair_distance(user, out.surface, progress, 0.9, 0.95);
  out.result_to_input = repair_distance(out.surface, user, progress, 0.95, 1.0);
  progress("repair", 1.0);
  return out;
}

WrapEstimate estimate_wrap(const SurfaceMesh& user, const WrapOptions& options) {
  WrapEstimate e;
  e.alpha = options.alpha > 0 ? options.alpha : diagonal(user) / 20;
  e.offset = options.offset > 0 ? options.offset : e.alpha / 30;
  if (!(e.alpha > 0) || !(e.offset > 0)) return e;
  const auto input = static_cast<double>(user.faces.rows());
  e.faces = area_of(user) / (e.alpha * e.alpha) * (1 + 0.25 * std::sqrt(e.alpha / e.offset));
  e.megabytes = 100 + 1.0e-3 * input + 1.3e-3 * e.faces;
  // The two distance passes (repair_distance): 3 µs per face of either surface.
  e.seconds = 1e-6 * (e.faces * (50 + std::sqrt(input)) + 10 * input + 3 * (input + e.faces));
  return e;
}

namespace {
bool within(const WrapEstimate& e, const WrapBudget& b) {
  return e.faces <= static_cast<double>(b.max_faces) && e.megabytes <= b.max_megabytes && e.seconds <= b.max_seconds;
}
}  // namespace

double smallest_alpha_within(const SurfaceMesh& user, const WrapOptions& options, const WrapBudget& budget) {
  // Every term falls as α grows: bisect on log α between a fitting and a failing value.
  const double d = diagonal(user);
  WrapOptions o = options;
  const auto fits = [&](double alpha) {
    o.alpha = alpha;
    return within(estimate_wrap(user, o), budget);
  };
  double hi = std::max(d, options.offset) * 4, lo = hi;
  if (!(d > 0) || !fits(hi)) return std::numeric_limits<double>::infinity();
  while (fits(lo) && lo > 1e-12 * hi) lo /= 2;
  for (int i = 0; i < 60; ++i) {
    const double mid = std::sqrt(lo * hi);
    (fits(mid) ? hi : lo) = mid;
  }
  return hi;
}

void require_wrap_within(const SurfaceMesh& user, const WrapOptions& options, const WrapBudget& budget, const std::string& field) {
  const WrapEstimate e = estimate_wrap(user, options);
  if (within(e, budget)) return;
  const double fit = smallest_alpha_within(user, options, budget);
  const auto num = [](double x) {
    char b[32];
    std::snprintf(b, sizeof b, "%.4g", x);
    return std::string(b);
  };
  const std::string advice = std::isfinite(fit) ? "; use alpha ≥ " + num(fit) + " m to fit" : "; no alpha fits: the input has too many faces";
  throw InvalidInput(field + ".alpha", "α " + num(e.alpha) + " m (offset " + num(e.offset) + " m) would make about " + num(std::round(e.faces)) +
                                           " faces, " + num(std::round(e.megabytes)) + " MB and " + num(std::round(e.seconds)) +
                                           " s, over this server's budget of " + std::to_string(budget.max_faces) + " faces, " +
                                           num(budget.max_megabytes) + " MB and " + num(budget.max_seconds) + " s" + advice);
}

RepairResult wrap(const SurfaceMesh& user, const WrapOptions& options, const WrapBudget& budget, const std::string& field,
                  const Progress& progress) {
  progress("repair", 0.0);
  RepairResult out;
  const WrapEstimate e = estimate_wrap(user, options);
  out.alpha = e.alpha;
  out.offset = e.offset;
  if (!(out.alpha > 0) || !(out.offset > 0)) throw InvalidInput(field, "the mesh has no extent to wrap");
  require_wrap_within(user, options, budget, field);
  const std::vector<Point> points = points_of(user);
  const auto triangles = triangles_of(user);
  Mesh wrapped;
  WrapVisitor visitor;
  visitor.progress = &progress;
  visitor.field = &field;
  visitor.alpha = out.alpha;
  visitor.expected_vertices = std::max(1.0, e.faces / 2);  // a closed surface has about F / 2 vertices
  visitor.max_steiner_points = budget.max_faces;
  CGAL::alpha_wrap_3(points, triangles, out.alpha, out.offset, wrapped, CGAL::parameters::default_values(),
                     CGAL::parameters::visitor(std::ref(visitor)));
  progress("repair", 0.8);
  out.surface = from_cgal(wrapped);
  if (static_cast<std::size_t>(out.surface.faces.rows()) > budget.max_faces)
    throw InvalidInput(field + ".alpha", "the wrap has " + std::to_string(out.surface.faces.rows()) + " faces, over this server's " +
                                             std::to_string(budget.max_faces) + "; use a larger alpha");
  if (out.surface.faces.rows() == 0) throw InvalidInput(field, "wrapping produced no surface");
  if (signed_volume(out.surface) < 0) out.surface.faces.col(1).swap(out.surface.faces.col(2));
  out.input_to_result = repair_distance(user, out.surface, progress, 0.8, 0.9);
  out.result_to_input = repair_distance(out.surface, user, progress, 0.9, 1.0);
  progress("repair", 1.0);
  return out;
}

std::vector<double> Transfer::apply(const std::vector<double>& values) const {
  std::vector<double> out(vertices.size());
  for (std::size_t i = 0; i < vertices.size(); ++i)
    for (int k = 0; k < 3; ++k) out[i] += weights[i][k] * values[static_cast<std::size_t>(vertices[i][k])];
  return out;
}

Transfer nearest_face_transfer(const SurfaceMesh& from, const MatX3& points, const Progress& progress) {
  using Triangle = K::Triangle_3;
  using Iterator = std::vector<Triangle>::const_iterator;
  using Tree = CGAL::AABB_tree<CGAL::AABB_traits<K, CGAL::AABB_triangle_primitive<K, Iterator>>>;
  std::vector<Triangle> triangles;
  triangles.reserve(static_cast<std::size_t>(from.faces.rows()));
  const auto corner = [&](Eigen::Index f, int k) {
    return Point(from.vertices(from.faces(f, k), 0), from.vertices(from.faces(f, k), 1), from.vertices(from.faces(f, k), 2));
  };
  for (Eigen::Index f = 0; f < from.faces.rows(); ++f) triangles.emplace_back(corner(f, 0), corner(f, 1), corner(f, 2));
  Tree tree(triangles.cbegin(), triangles.cend());
  tree.accelerate_distance_queries();
  Transfer t;
  const auto n = static_cast<std::size_t>(points.rows());
  t.vertices.resize(n);
  t.weights.resize(n);
  t.distances.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (i % 4096 == 0) progress.check();
    const Point q(points(static_cast<Eigen::Index>(i), 0), points(static_cast<Eigen::Index>(i), 1), points(static_cast<Eigen::Index>(i), 2));
    const auto [p, primitive] = tree.closest_point_and_primitive(q);
    const auto f = static_cast<Eigen::Index>(primitive - triangles.cbegin());
    const Vec3 x(p.x(), p.y(), p.z());
    const Vec3 a = from.vertices.row(from.faces(f, 0)), b = from.vertices.row(from.faces(f, 1)), c = from.vertices.row(from.faces(f, 2));
    // Barycentric coordinates of x in (a, b, c) from the sub-triangle areas; a degenerate
    // triangle gives its nearest corner the whole weight.
    const Vec3 normal = (b - a).cross(c - a);
    const double area2 = normal.squaredNorm();
    std::array<double, 3> w{};
    if (area2 > 0) {
      w[0] = (c - b).cross(x - b).dot(normal) / area2;
      w[1] = (a - c).cross(x - c).dot(normal) / area2;
      w[2] = 1 - w[0] - w[1];
    } else {
      const double da = (x - a).norm(), db = (x - b).norm(), dc = (x - c).norm();
      w[da <= db && da <= dc ? 0 : db <= dc ? 1
                                            : 2] = 1;
    }
    t.vertices[i] = {from.faces(f, 0), from.faces(f, 1), from.faces(f, 2)};
    t.weights[i] = w;
    t.distances[i] = std::sqrt(CGAL::squared_distance(p, q));
  }
  return t;
}

}  // namespace distlab::mesh
