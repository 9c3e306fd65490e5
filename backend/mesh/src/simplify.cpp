// Edge-collapse simplification of big inputs (simplify.hpp).
#include "distlab/mesh/simplify.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/distance.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_simplification/Edge_collapse_visitor_base.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Count_stop_predicate.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>

#include <algorithm>

#include "distlab/geometry/error.hpp"
#include "distlab/mesh/repair.hpp"

namespace distlab::mesh {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_3;
using Mesh = CGAL::Surface_mesh<Point>;
namespace PMP = CGAL::Polygon_mesh_processing;
namespace SMS = CGAL::Surface_mesh_simplification;

// Polls the job's token every 1024 selected edges and reports the share of the collapses done.
// Input faces per call of CGAL's bounded-error Hausdorff distance (about 200 MB each).
constexpr Eigen::Index kHausdorffPieceFaces = 100000;

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
  SMS::edge_collapse(sm, stop, CGAL::parameters::visitor(visitor));  // Lindstrom–Turk cost and placement
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
  // The sampled maximum is a lower bound (14 % low on a bumpy sphere: the farthest point is inside
  // a face); CGAL's bounded-error Hausdorff distance, to 5 % of it, gives the distance itself.
  const double lower = sampled_distance(input, out.surface, progress);
  progress("simplify", 0.92);
  // CGAL's bounded-error distance keeps about 2 KB per input face at once (3.9 GB, 98 s on a 2M-face
  // scan even at an error of 100 %; 7.8 GB at 5 %): it runs on pieces of the input's faces in turn.
  // The one-sided distance of the input is the largest of its pieces', each known to the same error.
  if (lower > 0) {
    const Eigen::Index n = input.faces.rows();
    for (Eigen::Index first = 0; first < n; first += kHausdorffPieceFaces) {
      progress("simplify", 0.92 + 0.08 * static_cast<double>(first) / static_cast<double>(n));
      const Eigen::Index count = std::min<Eigen::Index>(kHausdorffPieceFaces, n - first);
      std::vector<int> index(static_cast<std::size_t>(input.vertices.rows()), -1);
      std::vector<Point> piece_points;
      std::vector<std::array<std::size_t, 3>> piece_triangles;
      piece_triangles.reserve(static_cast<std::size_t>(count));
      for (Eigen::Index f = first; f < first + count; ++f) {
        std::array<std::size_t, 3> t{};
        for (int k = 0; k < 3; ++k) {
          int& i = index[static_cast<std::size_t>(input.faces(f, k))];
          if (i < 0) {
            i = static_cast<int>(piece_points.size());
            const auto v = input.faces(f, k);
            piece_points.emplace_back(input.vertices(v, 0), input.vertices(v, 1), input.vertices(v, 2));
          }
          t[static_cast<std::size_t>(k)] = static_cast<std::size_t>(i);
        }
        piece_triangles.push_back(t);
      }
      Mesh piece;  // faces of a manifold, oriented mesh: one too
      PMP::polygon_soup_to_polygon_mesh(piece_points, piece_triangles, piece);
      out.input_to_result = std::max(out.input_to_result, PMP::bounded_error_Hausdorff_distance<CGAL::Sequential_tag>(piece, sm, 0.05 * lower));
    }
  }
  progress("simplify", 1.0);
  return out;
}

}  // namespace distlab::mesh
