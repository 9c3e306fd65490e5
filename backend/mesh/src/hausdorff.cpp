// One-sided Hausdorff distance of big surfaces (hausdorff.hpp).
//
// CGAL's bounded-error Hausdorff distance alone costs ~95 µs and ~2 KB per face of `from` on a
// 2M-face scan against its 100k-face simplification (190 s, 7.8 GB at once): its culling bounds
// a node of `from` by its box diagonal, which settles little at the scale of a scan's faces. The
// vertex bound below settles almost every face first; CGAL refines the rest, to the same error.
// A face straddling an edge of `to` (its corners closest to different triangles) is split along
// that edge first: CGAL would subdivide it towards the edge until its pieces are below the error,
// ~12 levels on a flat CAD box whose every point lies on its simplification (4,800 faces to 2,000:
// 3,725 faces refined in 287 s at load 10; split, none in 0.1 s).
#include "distlab/mesh/hausdorff.hpp"

#include <CGAL/AABB_face_graph_triangle_primitive.h>
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/distance.h>
#include <CGAL/Surface_mesh.h>

#include <boost/iterator/function_output_iterator.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
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
// A face split along the edges of `to` near it: at most this many triangles and cuts.
constexpr std::size_t kNearMax = 32;
constexpr int kSplitBudget = 32;

Point point(const SurfaceMesh& m, Eigen::Index v) { return {m.vertices(v, 0), m.vertices(v, 1), m.vertices(v, 2)}; }

// A convex polygon within a face of `from`: the face, cut by planes.
struct Piece {
  static constexpr int kCapacity = 16;
  std::array<Point, kCapacity> corners;
  int size = 0;
  void add(const Point& p) { corners[static_cast<std::size_t>(size++)] = p; }
};

// The squared distance of the piece's farthest corner from t: it bounds every point of the piece
// (the distance to a triangle is convex). Stops once above `enough2`.
double farthest2(const Piece& piece, const Triangle& t, double enough2) {
  double worst2 = 0;
  for (int i = 0; i < piece.size && worst2 <= enough2; ++i) worst2 = std::max(worst2, CGAL::squared_distance(piece.corners[static_cast<std::size_t>(i)], t));
  return worst2;
}

struct Plane {
  Point origin{0, 0, 0};
  K::Vector_3 normal{0, 0, 0};
};

K::Vector_3 unit_normal(const Triangle& t) {
  const K::Vector_3 n = CGAL::normal(t[0], t[1], t[2]);
  return n / std::sqrt(n.squared_length());
}

// The plane through t's edge k (corners k, k + 1) where the nearest points change over from t to
// its neighbour across it: it contains their mean normal (the bisector of a fold; across a flat
// edge, the plane square to both). Without a neighbour among `near`, square to t. Normal towards t.
Plane edge_plane(const Triangle& t, int k, const std::vector<const Triangle*>& near) {
  const Point &p = t[k], &q = t[k + 1];
  K::Vector_3 mean = unit_normal(t);
  for (const Triangle* u : near) {
    int shared = 0;
    for (int i = 0; i < 3; ++i) shared += (*u)[i] == p || (*u)[i] == q ? 1 : 0;
    if (shared != 2 || u == &t) continue;
    const K::Vector_3 nu = unit_normal(*u);
    const K::Vector_3 sum = mean * nu < 0 ? mean - nu : mean + nu;  // `to` may be a soup: orientations may differ
    if (sum.squared_length() > 1e-12) mean = sum;
    break;
  }
  K::Vector_3 n = CGAL::cross_product(q - p, mean);
  if (n * (t[k + 2] - p) < 0) n = -n;
  return {p, n};
}

// The piece's parts on either side of the plane (positive first); they share their cut points,
// so together they cover the piece.
std::array<Piece, 2> split(const Piece& piece, const Plane& plane) {
  std::array<Piece, 2> out;
  std::array<double, Piece::kCapacity> s{};
  for (int i = 0; i < piece.size; ++i) s[static_cast<std::size_t>(i)] = plane.normal * (piece.corners[static_cast<std::size_t>(i)] - plane.origin);
  for (int i = 0; i < piece.size; ++i) {
    const int j = (i + 1) % piece.size;
    const Point& p = piece.corners[static_cast<std::size_t>(i)];
    const double si = s[static_cast<std::size_t>(i)], sj = s[static_cast<std::size_t>(j)];
    if (si >= 0) out[0].add(p);
    if (si <= 0) out[1].add(p);
    if ((si > 0 && sj < 0) || (si < 0 && sj > 0)) {
      const Point cut = p + (piece.corners[static_cast<std::size_t>(j)] - p) * (si / (si - sj));
      out[0].add(cut);
      out[1].add(cut);
    }
  }
  return out;
}

// A squared bound on the distance of the piece's points to `to`, given the triangles `near` it:
// the best one's farthest corner, or, once both parts on either side of an edge plane of one of
// them (the nearest that cuts it) are settled, `settled2`. Any split with any triangle per part
// bounds the piece, so the planes decide only how tight it is. Splits at most `budget` more
// times; returns at most `settled2` only when the piece is within it.
double split_bound2(const Piece& piece, const std::vector<const Triangle*>& near, double settled2, int& budget) {
  std::array<std::pair<double, const Triangle*>, kNearMax> order;
  for (std::size_t i = 0; i < near.size(); ++i) order[i] = {farthest2(piece, *near[i], std::numeric_limits<double>::infinity()), near[i]};
  std::sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(near.size()));
  const double best2 = near.empty() ? std::numeric_limits<double>::infinity() : order[0].first;
  if (best2 <= settled2 || budget <= 0 || piece.size + 2 > Piece::kCapacity) return best2;
  // The first triangle, nearest first, with an edge plane that cuts the piece: the one it reaches farthest past.
  const double tolerance = 1e-6 * std::sqrt(settled2);
  for (std::size_t i = 0; i < near.size(); ++i) {
    const Triangle& t = *order[i].second;
    double past = tolerance;
    int edge = -1;
    Plane cut;
    for (int k = 0; k < 3; ++k) {
      const Plane plane = edge_plane(t, k, near);
      const double scale = std::sqrt(plane.normal.squared_length());
      double inside = 0, outside = 0;
      for (int c = 0; c < piece.size; ++c) {
        const double s = plane.normal * (piece.corners[static_cast<std::size_t>(c)] - plane.origin) / scale;
        inside = std::max(inside, s), outside = std::max(outside, -s);
      }
      if (inside > tolerance && outside > past) past = outside, edge = k, cut = plane;
    }
    if (edge < 0) continue;
    --budget;
    const std::array<Piece, 2> sides = split(piece, cut);
    if (split_bound2(sides[0], near, settled2, budget) > settled2) return best2;  // only "settled or not" matters
    return std::min(best2, split_bound2(sides[1], near, settled2, budget));
  }
  return best2;
}

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

  // A face's bound: min over its corners' closest triangles t of max over corners c of d(c, t),
  // or else that of its split along the edges of the triangles of `to` near it (split_bound2).
  // A face whose bound is within the error of the lower bound cannot move the answer by more.
  const double cut_slack = 64 * std::numeric_limits<double>::epsilon() * from.vertices.cwiseAbs().maxCoeff();  // cut points' rounding
  const auto open_faces = [&](double settled, double from_fraction) {
    std::vector<Eigen::Index> open;
    std::vector<const Triangle*> near;
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
      if (bound2 > settled2 && settled > cut_slack) {
        // Split along the edges of the triangles within `settled` of the face.
        Piece face;
        for (int k = 0; k < 3; ++k) face.add(point(from, from.faces(f, k)));
        const CGAL::Bbox_3 box = face.corners[0].bbox() + face.corners[1].bbox() + face.corners[2].bbox();
        const CGAL::Bbox_3 reach(box.xmin() - settled, box.ymin() - settled, box.zmin() - settled, box.xmax() + settled, box.ymax() + settled, box.zmax() + settled);
        near.clear();
        tree.all_intersected_primitives(reach, boost::make_function_output_iterator([&](Iterator t) { near.push_back(&*t); }));
        const double below = (settled - cut_slack) * (settled - cut_slack);
        int budget = kSplitBudget;
        if (near.size() <= kNearMax && split_bound2(face, near, below, budget) <= below) continue;
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
