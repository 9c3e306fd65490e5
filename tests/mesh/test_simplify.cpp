// Simplification of big inputs (mesh/simplify.hpp): the face count, closedness, and the reported
// one-sided Hausdorff distance against two independent measures.
#include <CGAL/AABB_face_graph_triangle_primitive.h>
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/distance.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>

#include "distlab/geometry/error.hpp"
#include "distlab/mesh/checks.hpp"
#include "distlab/mesh/primitives.hpp"
#include "distlab/mesh/simplify.hpp"
#include "mesh/cgal_mesh.hpp"

using namespace distlab;
using namespace distlab::mesh;

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Mesh = CGAL::Surface_mesh<K::Point_3>;

using distlab::test::to_cgal;

// The unit icosphere at level 6 (81,920 faces) with bumps of 5 % radius (level 7 made the
// oracles below take 45 s).
SurfaceMesh bumpy_sphere() {
  SurfaceMesh s = icosphere(1.0, 6);
  for (Eigen::Index v = 0; v < s.vertices.rows(); ++v) {
    const Vec3 x = s.vertices.row(v);
    s.vertices.row(v) *= 1 + 0.05 * std::sin(5 * x.x()) * std::sin(5 * x.y()) * std::sin(5 * x.z());
  }
  return s;
}

}  // namespace

// 81,920 faces down to 5,000: at most that many, closed and manifold; the reported distance
// (bounded error, 5 %) is at least the largest distance of the input's vertices to the result
// (CGAL's AABB tree on the result's faces) and within 5 % of the one-sided Hausdorff distance
// computed to 1e-6.
TEST(Simplify, ABumpySphereFitsTheFaceCountStaysClosedAndItsDistanceIsChecked) {
  const SurfaceMesh input = bumpy_sphere();
  ASSERT_GT(input.faces.rows(), 80000);
  const SimplifyResult r = simplify(input, 5000);
  EXPECT_LE(r.surface.faces.rows(), 5000);
  EXPECT_GT(r.surface.faces.rows(), 4750);
  EXPECT_EQ(topology_defect(r.surface), "");
  EXPECT_NEAR(signed_volume(r.surface), signed_volume(input), 0.01 * signed_volume(input));
  const Mesh a = to_cgal(input), b = to_cgal(r.surface);
  using Tree = CGAL::AABB_tree<CGAL::AABB_traits<K, CGAL::AABB_face_graph_triangle_primitive<Mesh>>>;
  Tree tree(faces(b).first, faces(b).second, b);
  tree.accelerate_distance_queries();
  double vertex_max = 0;
  for (auto v : a.vertices()) vertex_max = std::max(vertex_max, std::sqrt(tree.squared_distance(a.point(v))));
  namespace PMP = CGAL::Polygon_mesh_processing;
  const double exact = PMP::bounded_error_Hausdorff_distance<CGAL::Sequential_tag>(a, b, 1e-6);
  std::printf("reported %.6f, input vertices (AABB) %.6f, CGAL bounded-error %.6f\n", r.input_to_result, vertex_max, exact);
  EXPECT_GT(vertex_max, 0);
  EXPECT_GE(r.input_to_result, vertex_max - 1e-12);
  EXPECT_NEAR(r.input_to_result, exact, 0.05 * exact + 1e-6);
}

TEST(Simplify, FewerFacesThanAskedIsReturnedAsIs) {
  const SurfaceMesh s = icosphere(1.0, 2);
  const SimplifyResult r = simplify(s, 1000);
  EXPECT_EQ(r.surface.faces, s.faces);
  EXPECT_EQ(r.input_to_result, 0);
}

TEST(Simplify, ANonManifoldInputIsRefusedByName) {
  SurfaceMesh s = icosphere(1.0, 2);
  s.faces.conservativeResize(s.faces.rows() + 1, 3);
  s.faces.row(s.faces.rows() - 1) = s.faces.row(0);  // an edge shared by three faces
  try {
    simplify(s, 10);
    FAIL() << "a non-manifold input was simplified";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "simplify");
  }
}

TEST(Simplify, ACancelStopsIt) {
  std::atomic<bool> cancel{false};
  Progress progress;
  progress.cancel = &cancel;
  int reports = 0;
  progress.report = [&](const std::string& stage, double fraction) {
    EXPECT_EQ(stage, "simplify");
    if (fraction > 0) cancel = true;
    ++reports;
  };
  EXPECT_THROW(simplify(icosphere(1.0, 5), 100, "simplify", progress), Cancelled);
  EXPECT_GE(reports, 2);
}

// A scan's noise (a ripple finer than the grid): edge collapses that would turn a face over are
// refused, so the result does not cross itself (7 pairs of faces did without that rule), which a
// preparation would refuse.
TEST(Simplify, ANoisyScanSimplifiesWithoutCrossingItself) {
  const SurfaceMesh input = rippled_torus(316);  // 199,712 faces
  const SimplifyResult r = simplify(input, 20000);
  EXPECT_LE(r.surface.faces.rows(), 20000);
  EXPECT_EQ(topology_defect(r.surface), "");
  std::vector<std::pair<Mesh::Face_index, Mesh::Face_index>> crossing;
  CGAL::Polygon_mesh_processing::self_intersections(to_cgal(r.surface), std::back_inserter(crossing));
  EXPECT_EQ(crossing.size(), 0u);
}
