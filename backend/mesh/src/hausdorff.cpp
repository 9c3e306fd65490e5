// One-sided Hausdorff distance of big surfaces (hausdorff.hpp).
//
// CGAL's bounded-error Hausdorff distance alone costs ~95 µs and ~2 KB per face of `from` on a
// 2M-face scan against its 100k-face simplification (190 s, 7.8 GB at once): its culling bounds
// a node of `from` by its box diagonal, which settles little at the scale of a scan's faces. The
// vertex bound below settles almost every face first; CGAL refines the rest, to the same error.
#include "distlab/mesh/hausdorff.hpp"

#include <CGAL/AABB_face_graph_triangle_primitive.h>
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/distance.h>
#include <CGAL/Surface_mesh.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace distlab::mesh {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_3;
using Triangle = K::Triangle_3;
using Mesh = CGAL::Surface_mesh<Point>;
using Iterator = std::vector<Triangle>::const_iterator;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<K, CGAL::AABB_triangle_primitive<K, Iterator>>>;
namespace PMP = CGAL::Polygon_mesh_processing;

// Faces of `from` per call of CGAL's distance (about 200 MB each).
constexpr std::size_t kPieceFaces = 100000;
constexpr Eigen::Index kPoll = 4096;
// The error's floor, relative to the size of `from` (its bounding-box diagonal).
constexpr double kErrorFloor = 1e-4;

Point point(const SurfaceMesh& m, Eigen::Index v) { return {m.vertices(v, 0), m.vertices(v, 1), m.vertices(v, 2)}; }

// The faces' corners as separate vertices: any soup is then a valid CGAL mesh of disjoint triangles.
Mesh disjoint_triangles(const SurfaceMesh& m, const std::vector<Eigen::Index>& faces, std::size_t first, std::size_t count) {
  Mesh out;
  for (std::size_t i = first; i < first + count; ++i) {
    std::array<Mesh::Vertex_index, 3> v;
    for (int k = 0; k < 3; ++k) v[static_cast<std::size_t>(k)] = out.add_vertex(point(m, m.faces(faces[i], k)));
    out.add_face(v[0], v[1], v[2]);
  }
  return out;
}

// CGAL's bounded-error distance of `piece` to `target`, started from a known lower bound: its culling
// and refinement then skip every face that cannot beat it. The public entry point starts from the
// error alone and rebuilds `target`'s tree per call; this is its sequential path (CGAL 5.5,
// distance.h, bounded_error_squared_one_sided_Hausdorff_distance_impl) with the start given.
class CgalDistance {
 public:
  explicit CgalDistance(const Mesh& target) : target_(target), target_tree_(faces(target).first, faces(target).second, target, target.points()) {
    target_tree_.build();
    target_tree_.accelerate_distance_queries();
  }
  // max(lower, distance of piece to target), within error.
  double at_least(const Mesh& piece, double lower, double error) const {
    Tree1 piece_tree(faces(piece).first, faces(piece).second, piece, piece.points());
    piece_tree.build();
    piece_tree.do_not_accelerate_distance_queries();
    const CGAL::Bbox_3 box = PMP::bbox(piece) + PMP::bbox(target_);
    const double infinity = 4 * (CGAL::square(box.x_span()) + CGAL::square(box.y_span()) + CGAL::square(box.z_span()));
    auto sink = CGAL::Emptyset_iterator();
    const double start = std::max(lower, error);  // CGAL starts at least at its error
    const double h = std::sqrt(PMP::internal::bounded_error_squared_Hausdorff_distance_impl<K>(
        piece, target_, piece.points(), target_.points(), piece_tree, target_tree_, error,
        start * start, -1.0, infinity, sink));
    return h > start ? h : lower;  // no face beat the start: the distance is in [lower, start]
  }

 private:
  using Points = Mesh::Property_map<Mesh::Vertex_index, Point>;
  using Tree1 = CGAL::AABB_tree<CGAL::AABB_traits<K, CGAL::AABB_face_graph_triangle_primitive<Mesh, Points, CGAL::Tag_true, CGAL::Tag_false>>>;
  const Mesh& target_;
  Tree1 target_tree_;
};

}  // namespace

HausdorffDistance hausdorff_distance(const SurfaceMesh& from, const SurfaceMesh& to, double relative_error,
                                     const std::string& stage, const Progress& progress) {
  progress(stage, 0.0);
  HausdorffDistance out;
  if (from.faces.rows() == 0 || to.faces.rows() == 0) return out;
  std::vector<Triangle> triangles;
  triangles.reserve(static_cast<std::size_t>(to.faces.rows()));
  for (Eigen::Index f = 0; f < to.faces.rows(); ++f) triangles.emplace_back(point(to, to.faces(f, 0)), point(to, to.faces(f, 1)), point(to, to.faces(f, 2)));
  Tree tree(triangles.cbegin(), triangles.cend());
  tree.accelerate_distance_queries();

  // Each vertex's squared distance and closest triangle of `to`.
  const Eigen::Index nv = from.vertices.rows();
  std::vector<double> d2(static_cast<std::size_t>(nv));
  std::vector<Eigen::Index> closest(static_cast<std::size_t>(nv));
  double lower2 = 0;
  for (Eigen::Index v = 0; v < nv; ++v) {
    if (v % kPoll == 0) progress(stage, 0.4 * static_cast<double>(v) / static_cast<double>(nv));
    const Point p = point(from, v);
    const auto [q, id] = tree.closest_point_and_primitive(p);
    d2[static_cast<std::size_t>(v)] = CGAL::squared_distance(p, q);
    closest[static_cast<std::size_t>(v)] = id - triangles.cbegin();
    lower2 = std::max(lower2, d2[static_cast<std::size_t>(v)]);
  }

  // A face's bound: min over its corners' closest triangles t of max over corners c of d(c, t).
  // A face whose bound is within the error of the lower bound cannot move the answer by more.
  const auto open_faces = [&](double settled, double from_fraction) {
    std::vector<Eigen::Index> open;
    const double settled2 = settled * settled;
    const Eigen::Index nf = from.faces.rows();
    for (Eigen::Index f = 0; f < nf; ++f) {
      if (f % kPoll == 0) progress(stage, from_fraction + 0.1 * static_cast<double>(f) / static_cast<double>(nf));
      double bound2 = std::numeric_limits<double>::infinity();
      for (int j = 0; j < 3 && bound2 > settled2; ++j) {
        const Triangle& t = triangles[static_cast<std::size_t>(closest[static_cast<std::size_t>(from.faces(f, j))])];
        double worst2 = 0;
        for (int k = 0; k < 3 && worst2 <= settled2; ++k)
          worst2 = std::max(worst2, k == j ? d2[static_cast<std::size_t>(from.faces(f, k))] : CGAL::squared_distance(point(from, from.faces(f, k)), t));
        bound2 = std::min(bound2, worst2);
      }
      if (bound2 > settled2) open.push_back(f);
    }
    return open;
  };
  // The error's floor keeps CGAL's refinement bounded where every vertex lies on `to`.
  const Vec3 extent = from.vertices.colwise().maxCoeff() - from.vertices.colwise().minCoeff();
  const double lower = std::sqrt(lower2), floor = kErrorFloor * extent.norm();
  out.value = lower;
  out.error = relative_error * std::max(lower, floor);
  std::vector<Eigen::Index> open = open_faces(lower + out.error, 0.4);
  out.faces_refined = static_cast<long>(open.size());
  if (open.empty()) return out;  // every face settled: the distance is in [lower, lower + error]

  // The open faces' distance by CGAL, in pieces; the result is the largest of the lower bound and theirs.
  Mesh target;
  {
    std::vector<Eigen::Index> all(static_cast<std::size_t>(to.faces.rows()));
    for (Eigen::Index f = 0; f < to.faces.rows(); ++f) all[static_cast<std::size_t>(f)] = f;
    target = disjoint_triangles(to, all, 0, all.size());
  }
  const CgalDistance cgal(target);
  const auto refine = [&](double start, double error, double from_fraction, double to_fraction) {
    double h = start;
    for (std::size_t first = 0; first < open.size(); first += kPieceFaces) {
      progress(stage, from_fraction + (to_fraction - from_fraction) * static_cast<double>(first) / static_cast<double>(open.size()));
      h = cgal.at_least(disjoint_triangles(from, open, first, std::min(kPieceFaces, open.size() - first)), h, error);
    }
    return h;
  };
  out.value = refine(lower, out.error, 0.5, 0.75);
  // Vertices nearer to `to` than the floor, but a distance above it: a second pass to the value's error.
  if (out.error > relative_error * out.value && out.value > floor) {
    out.error = relative_error * out.value;
    open = open_faces(out.value + out.error, 0.75);
    out.faces_refined = static_cast<long>(open.size());
    out.value = refine(out.value, out.error, 0.85, 1.0);
  }
  progress(stage, 1.0);
  return out;
}

}  // namespace distlab::mesh
