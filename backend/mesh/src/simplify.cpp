// Edge-collapse simplification of big inputs (simplify.hpp).
#include "distlab/mesh/simplify.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_simplification/Edge_collapse_visitor_base.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Bounded_normal_change_filter.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Count_stop_predicate.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>

#include <algorithm>

#include "distlab/geometry/error.hpp"
#include "distlab/mesh/hausdorff.hpp"

namespace distlab::mesh {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_3;
using Mesh = CGAL::Surface_mesh<Point>;
namespace PMP = CGAL::Polygon_mesh_processing;
namespace SMS = CGAL::Surface_mesh_simplification;

// Polls the job's token every 1024 selected edges and reports the share of the collapses done.
struct Visitor : SMS::Edge_collapse_visitor_base<Mesh> {
  const Progress* progress = nullptr;
  double target_edges = 0;
  std::size_t calls = 0;
  void OnSelected(const Profile&, const boost::optional<double>&, std::size_t initial, std::size_t current) {
    if (++calls % 1024 != 0) return;
    const double total = static_cast<double>(initial) - target_edges;
    (*progress)("simplify", total > 0 ? 0.9 * std::clamp((static_cast<double>(initial) - static_cast<double>(current)) / total, 0.0, 1.0) : 0.0);
  }
};

}  // namespace

SimplifyResult simplify(const SurfaceMesh& input, std::size_t faces, const std::string& field, const Progress& progress) {
  progress("simplify", 0.0);
  SimplifyResult out;
  if (static_cast<std::size_t>(input.faces.rows()) <= faces) {
    out.surface = input;
    progress("simplify", 1.0);
    return out;
  }
  std::vector<Point> points;
  points.reserve(static_cast<std::size_t>(input.vertices.rows()));
  for (Eigen::Index v = 0; v < input.vertices.rows(); ++v) points.emplace_back(input.vertices(v, 0), input.vertices(v, 1), input.vertices(v, 2));
  std::vector<std::array<std::size_t, 3>> triangles;
  triangles.reserve(static_cast<std::size_t>(input.faces.rows()));
  for (Eigen::Index f = 0; f < input.faces.rows(); ++f)
    triangles.push_back({static_cast<std::size_t>(input.faces(f, 0)), static_cast<std::size_t>(input.faces(f, 1)), static_cast<std::size_t>(input.faces(f, 2))});
  if (!PMP::is_polygon_soup_a_polygon_mesh(triangles))
    throw InvalidInput(field, "simplify needs a manifold, consistently oriented surface; repair it first (\"repair\": \"fix\")");
  Mesh sm;
  PMP::polygon_soup_to_polygon_mesh(points, triangles, sm);
  points = {};
  triangles = {};
  // Count_stop_predicate stops below a count of edges; a triangle mesh has E ≥ 3F / 2 (equal when
  // closed), so stopping below 3N / 2 + 1 edges leaves at most N faces.
  const std::size_t target_edges = 3 * faces / 2 + 1;
  SMS::Count_stop_predicate<Mesh> stop(target_edges);
  Visitor visitor;
  visitor.progress = &progress;
  visitor.target_edges = static_cast<double>(target_edges);
  // Lindstrom–Turk cost and placement; no collapse may turn a face over (a turned face is how a
  // collapse makes the surface cross itself, which a preparation refuses).
  SMS::edge_collapse(sm, stop, CGAL::parameters::visitor(visitor).filter(SMS::Bounded_normal_change_filter<>()));
  sm.collect_garbage();
  progress("simplify", 0.9);
  out.surface.vertices.resize(static_cast<Eigen::Index>(sm.number_of_vertices()), 3);
  for (auto v : sm.vertices()) {
    const Point& p = sm.point(v);
    out.surface.vertices.row(static_cast<Eigen::Index>(v.idx())) << p.x(), p.y(), p.z();
  }
  out.surface.faces.resize(static_cast<Eigen::Index>(sm.number_of_faces()), 3);
  for (auto f : sm.faces()) {
    int k = 0;
    for (auto v : CGAL::vertices_around_face(sm.halfedge(f), sm)) out.surface.faces(static_cast<Eigen::Index>(f.idx()), std::min(k++, 2)) = static_cast<int>(v.idx());
  }
  const Progress distance{[&](const std::string&, double f) { progress("simplify", 0.9 + 0.1 * f); }, progress.cancel};
  out.input_to_result = hausdorff_distance(input, out.surface, kReportedRelativeError, "simplify", distance).value;
  progress("simplify", 1.0);
  return out;
}

}  // namespace distlab::mesh
