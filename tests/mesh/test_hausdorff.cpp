// The one-sided Hausdorff distance (mesh/hausdorff.hpp): a closed form whose maximum lies inside a
// face, CGAL's own bounded-error distance at a tight error, soups, and cancellation.
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/distance.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <map>
#include <vector>

#include "distlab/geometry/progress.hpp"
#include "distlab/mesh/hausdorff.hpp"
#include "distlab/mesh/primitives.hpp"
#include "distlab/mesh/simplify.hpp"
#include "mesh/cgal_mesh.hpp"

using namespace distlab;
using namespace distlab::mesh;

namespace {

SurfaceMesh triangle(const Vec3& a, const Vec3& b, const Vec3& c) {
  SurfaceMesh m;
  m.vertices.resize(3, 3);
  m.vertices << a.transpose(), b.transpose(), c.transpose();
  m.faces.resize(1, 3);
  m.faces << 0, 1, 2;
  return m;
}

// A tiny triangle (size s) with `p` as its first corner.
SurfaceMesh speck(const Vec3& p, double s) { return triangle(p, p + Vec3(s, 0, 0), p + Vec3(0, s, 0)); }

SurfaceMesh bumpy_sphere(int level) {
  SurfaceMesh s = icosphere(1.0, level);
  for (Eigen::Index v = 0; v < s.vertices.rows(); ++v) {
    const Vec3 x = s.vertices.row(v);
    s.vertices.row(v) *= 1 + 0.05 * std::sin(5 * x.x()) * std::sin(5 * x.y()) * std::sin(5 * x.z()) + 0.01 * std::sin(40 * x.x() + 3 * x.z());
  }
  return s;
}

// A closed box of edge `size` centred at the origin, k × k squares of two triangles per face, its
// vertices shared (the browser tests' gridBox).
SurfaceMesh grid_box(double size, int k) {
  std::map<std::array<double, 3>, int> index;
  std::vector<Vec3> vertices;
  std::vector<std::array<int, 3>> faces;
  const auto vertex = [&](const Vec3& p) {
    const auto [it, added] = index.emplace(std::array<double, 3>{p.x(), p.y(), p.z()}, static_cast<int>(vertices.size()));
    if (added) vertices.push_back(p);
    return it->second;
  };
  for (int a = 0; a < 3; ++a)
    for (const int s : {-1, 1}) {
      const int u = (a + 1) % 3, v = (a + 2) % 3;
      const auto corner = [&](int i, int j) {
        Vec3 p;
        p[a] = s * size / 2;
        p[u] = (static_cast<double>(i) / k - 0.5) * size;
        p[v] = (static_cast<double>(j) / k - 0.5) * size;
        return vertex(p);
      };
      for (int i = 0; i < k; ++i)
        for (int j = 0; j < k; ++j) {
          const int c00 = corner(i, j), c10 = corner(i + 1, j), c11 = corner(i + 1, j + 1), c01 = corner(i, j + 1);
          if (s > 0) faces.insert(faces.end(), {{c00, c10, c11}, {c00, c11, c01}});
          else faces.insert(faces.end(), {{c00, c11, c10}, {c00, c01, c11}});
        }
    }
  SurfaceMesh m;
  m.vertices.resize(static_cast<Eigen::Index>(vertices.size()), 3);
  for (std::size_t i = 0; i < vertices.size(); ++i) m.vertices.row(static_cast<Eigen::Index>(i)) = vertices[i];
  m.faces.resize(static_cast<Eigen::Index>(faces.size()), 3);
  for (std::size_t f = 0; f < faces.size(); ++f)
    for (int k2 = 0; k2 < 3; ++k2) m.faces(static_cast<Eigen::Index>(f), k2) = faces[f][static_cast<std::size_t>(k2)];
  return m;
}

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Triangles = std::vector<K::Triangle_3>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<K, CGAL::AABB_triangle_primitive<K, Triangles::const_iterator>>>;

K::Point_3 at(const SurfaceMesh& m, Eigen::Index v) { return {m.vertices(v, 0), m.vertices(v, 1), m.vertices(v, 2)}; }

// CGAL's AABB tree of a surface's triangles, for closest points.
struct ClosestTriangles {
  explicit ClosestTriangles(const SurfaceMesh& m) {
    for (Eigen::Index f = 0; f < m.faces.rows(); ++f) triangles.emplace_back(at(m, m.faces(f, 0)), at(m, m.faces(f, 1)), at(m, m.faces(f, 2)));
    tree.insert(triangles.cbegin(), triangles.cend());
    tree.accelerate_distance_queries();
  }
  Triangles triangles;
  Tree tree;
};

// The faces of `from` that the plain vertex bound (min over the corners' closest triangles of the
// corners' largest distance to it) leaves above `settled`: what CGAL refined before the split bound.
long faces_open_to_the_vertex_bound(const SurfaceMesh& from, const SurfaceMesh& to, double settled) {
  const ClosestTriangles closest(to);
  long open = 0;
  for (Eigen::Index f = 0; f < from.faces.rows(); ++f) {
    double bound = std::numeric_limits<double>::infinity();
    for (int j = 0; j < 3; ++j) {
      const auto& t = *closest.tree.closest_point_and_primitive(at(from, from.faces(f, j))).second;
      double worst = 0;
      for (int k = 0; k < 3; ++k) worst = std::max(worst, std::sqrt(CGAL::squared_distance(at(from, from.faces(f, k)), t)));
      bound = std::min(bound, worst);
    }
    open += bound > settled ? 1 : 0;
  }
  return open;
}

// The largest distance to `to` over an n × n barycentric grid of points on every face of `from`.
double sampled_distance(const SurfaceMesh& from, const SurfaceMesh& to, int n) {
  const ClosestTriangles closest(to);
  double worst = 0;
  for (Eigen::Index f = 0; f < from.faces.rows(); ++f) {
    const Vec3 a = from.vertices.row(from.faces(f, 0)), b = from.vertices.row(from.faces(f, 1)), c = from.vertices.row(from.faces(f, 2));
    for (int i = 0; i <= n; ++i)
      for (int j = 0; i + j <= n; ++j) {
        const Vec3 p = a + (b - a) * i / n + (c - a) * j / n;
        worst = std::max(worst, std::sqrt(closest.tree.squared_distance(K::Point_3(p.x(), p.y(), p.z()))));
      }
  }
  return worst;
}

}  // namespace

// From one acute triangle to specks at its corners: every vertex is at distance 0 and the farthest
// point is the circumcentre, at the circumradius.
TEST(Hausdorff, TheMaximumInsideAFaceIsTheCircumradius) {
  const Vec3 a(0, 0, 0), b(1, 0, 0), c(0.4, 0.8, 0);
  const double s = 1e-6;
  const SurfaceMesh to = merge(merge(speck(a, s), speck(b, s)), speck(c, s));
  const double ab = (b - a).norm(), bc = (c - b).norm(), ca = (a - c).norm();
  const double area = 0.5 * (b - a).cross(c - a).norm();
  const double circumradius = ab * bc * ca / (4 * area);
  const HausdorffDistance h = hausdorff_distance(triangle(a, b, c), to, 0.05, "distance");
  EXPECT_EQ(h.faces_refined, 1);
  EXPECT_GT(h.error, 0);
  EXPECT_NEAR(h.value, circumradius, h.error + 2 * s);
  // The other direction: every speck point is within s of a corner.
  const HausdorffDistance back = hausdorff_distance(to, triangle(a, b, c), 0.05, "distance");
  EXPECT_LE(back.value, s * (1 + 1e-9));
}

// A bumpy sphere against its simplification: within the reported error of CGAL's bounded-error
// distance at 1e-7, and at least the largest vertex distance.
TEST(Hausdorff, AgreesWithCgalsBoundedErrorDistanceAtATightError) {
  const SurfaceMesh input = bumpy_sphere(5);
  const SurfaceMesh coarse = simplify(input, 1500).surface;
  const HausdorffDistance h = hausdorff_distance(input, coarse, 0.05, "distance");
  const auto a = test::to_cgal(input), b = test::to_cgal(coarse);
  const double exact = CGAL::Polygon_mesh_processing::bounded_error_Hausdorff_distance<CGAL::Sequential_tag>(a, b, 1e-7);
  std::printf("distlab %.7f (error %.2g, %ld of %ld faces refined), CGAL at 1e-7 %.7f\n", h.value, h.error, h.faces_refined,
              static_cast<long>(input.faces.rows()), exact);
  EXPECT_GT(exact, 1e-3);
  EXPECT_NEAR(h.value, exact, h.error + 1e-7);
  EXPECT_LE(h.error, 0.05 * h.value + 1e-15);
  EXPECT_LT(h.faces_refined, input.faces.rows());
  // Swapped roles: a coarse `from` has faces far bigger than the distance, so CGAL refines most.
  const double back = CGAL::Polygon_mesh_processing::bounded_error_Hausdorff_distance<CGAL::Sequential_tag>(b, a, 1e-7);
  const HausdorffDistance hb = hausdorff_distance(coarse, input, 0.05, "distance");
  EXPECT_NEAR(hb.value, back, hb.error + 1e-7);
}

TEST(Hausdorff, IdenticalSurfacesAreAtZeroAndSoupsAreTaken) {
  const SurfaceMesh s = icosphere(1.0, 3);
  EXPECT_NEAR(hausdorff_distance(s, s, 0.05, "distance").value, 0, 1e-12);
  // A soup: a face repeated, and a fourth face on one edge (not a manifold).
  SurfaceMesh soup = s;
  soup.faces.conservativeResize(s.faces.rows() + 2, 3);
  soup.faces.row(s.faces.rows()) = s.faces.row(0);
  soup.vertices.conservativeResize(s.vertices.rows() + 1, 3);
  // 3 p for a vertex p of the convex polyhedron inscribed in the unit sphere: p is its closest
  // point, at 2; the new face's farthest point is that corner (the distance to a convex solid is convex).
  const Eigen::Index p = s.faces(0, 2);
  soup.vertices.row(s.vertices.rows()) = 3 * s.vertices.row(p);
  soup.faces.row(s.faces.rows() + 1) << s.faces(0, 0), s.faces(0, 1), static_cast<int>(s.vertices.rows());
  const HausdorffDistance h = hausdorff_distance(soup, s, 0.05, "distance");
  EXPECT_NEAR(h.value, 2, 1e-9);
}

TEST(Hausdorff, ACancelledTokenStopsIt) {
  const SurfaceMesh input = bumpy_sphere(4);
  std::atomic<bool> cancel{true};
  Progress progress;
  progress.cancel = &cancel;
  EXPECT_THROW(hausdorff_distance(input, icosphere(1.0, 2), 0.05, "distance", progress), Cancelled);
}

// A flat-faced box of 4,800 faces against its simplification to 2,000 (the big-upload case): every
// point of the input lies on the result, and the input faces straddling the result's flat edges are
// settled by splitting them along those edges instead of by CGAL's refinement down to the error.
TEST(Hausdorff, AFlatBoxLiesOnItsSimplification) {
  const SurfaceMesh input = grid_box(0.4, 20);
  ASSERT_EQ(input.faces.rows(), 4800);
  const SurfaceMesh coarse = simplify(input, 2000).surface;
  const HausdorffDistance h = hausdorff_distance(input, coarse, 0.05, "distance");
  const double sampled = sampled_distance(input, coarse, 16);
  const long before = faces_open_to_the_vertex_bound(input, coarse, h.value + h.error);
  std::printf("value %.3g (error %.3g), sampled %.3g; faces refined %ld, by the vertex bound alone %ld of %ld\n", h.value,
              h.error, sampled, h.faces_refined, before, static_cast<long>(input.faces.rows()));
  EXPECT_GT(h.error, 0);
  EXPECT_LE(h.value, h.error);
  EXPECT_LE(sampled, h.error);
  EXPECT_GT(before, 100);
  EXPECT_LE(h.faces_refined * 20, before);
}

// A box folded along x = 0 (its top a shallow roof), finely gridded off the fold and jittered,
// against the coarse folded box: input faces straddling the fold are settled by the split bound,
// and the value agrees with CGAL's bounded-error distance at 1e-7.
TEST(Hausdorff, TheSplitBoundHoldsAcrossAFold) {
  const auto fold = [](SurfaceMesh m) {
    for (Eigen::Index v = 0; v < m.vertices.rows(); ++v) m.vertices(v, 2) += 0.08 * std::abs(m.vertices(v, 0));
    return m;
  };
  const SurfaceMesh coarse = fold(grid_box(0.4, 2));
  SurfaceMesh input = fold(grid_box(0.4, 15));
  for (Eigen::Index v = 0; v < input.vertices.rows(); ++v) input.vertices(v, 2) += 2e-4 * std::sin(12.9898 * static_cast<double>(v));
  const HausdorffDistance h = hausdorff_distance(input, coarse, 0.05, "distance");
  const auto a = test::to_cgal(input), b = test::to_cgal(coarse);
  const double exact = CGAL::Polygon_mesh_processing::bounded_error_Hausdorff_distance<CGAL::Sequential_tag>(a, b, 1e-7);
  const long before = faces_open_to_the_vertex_bound(input, coarse, h.value + h.error);
  std::printf("distlab %.7f (error %.2g), CGAL at 1e-7 %.7f; faces refined %ld, by the vertex bound alone %ld of %ld\n", h.value,
              h.error, exact, h.faces_refined, before, static_cast<long>(input.faces.rows()));
  EXPECT_GT(exact, 1e-4);
  EXPECT_NEAR(h.value, exact, h.error + 1e-7);
  EXPECT_LT(h.faces_refined, before);
}
