// The one-sided Hausdorff distance (mesh/hausdorff.hpp): a closed form whose maximum lies inside a
// face, CGAL's own bounded-error distance at a tight error, soups, and cancellation.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/distance.h>
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>

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
