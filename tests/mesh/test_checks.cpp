// Every refused-mesh case names its defect; valid meshes pass (and inward ones are flipped).
#include <gtest/gtest.h>

#include "distlab/geometry/error.hpp"
#include "distlab/mesh/checks.hpp"
#include "distlab/mesh/primitives.hpp"

using namespace distlab;
using namespace distlab::mesh;

namespace {

std::string refusal(SurfaceMesh m) {
  try {
    require_closed_manifold(m, "mesh");
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "mesh");
    return e.what();
  }
  return {};
}

SurfaceMesh tetra(const Vec3& o, double s) {
  SurfaceMesh m;
  m.vertices.resize(4, 3);
  m.vertices << o.transpose(), (o + Vec3(s, 0, 0)).transpose(), (o + Vec3(0, s, 0)).transpose(),
      (o + Vec3(0, 0, s)).transpose();
  m.faces.resize(4, 3);
  m.faces << 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3;
  return m;
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

}  // namespace

TEST(MeshChecks, ValidShapesPass) {
  EXPECT_EQ(refusal(box(Vec3(1, 2, 3))), "");
  EXPECT_EQ(refusal(icosphere(1.0, 3)), "");
  EXPECT_EQ(refusal(merge(box(Vec3::Ones()), icosphere(0.2, 1, Vec3(3, 0, 0)))), "");
}

TEST(MeshChecks, OpenMeshReportsBoundaryEdges) {
  SurfaceMesh m = box(Vec3::Ones());
  m.faces.conservativeResize(11, 3);
  EXPECT_TRUE(contains(refusal(m), "3 boundary edges")) << refusal(m);
}

TEST(MeshChecks, NonManifoldEdge) {
  // Two tetrahedra glued along one edge: four faces meet there.
  SurfaceMesh a = tetra(Vec3::Zero(), 1), b = tetra(Vec3::Zero(), 1);
  b.vertices.col(1) *= -1;  // mirror in y: shares the edge (0,1) along x
  b.faces.col(1).swap(b.faces.col(2));
  SurfaceMesh m = merge(a, b);
  // weld b's copies of vertices 0 and 1 onto a's
  for (Eigen::Index f = 4; f < 8; ++f)
    for (int k = 0; k < 3; ++k) {
      if (m.faces(f, k) == 4) m.faces(f, k) = 0;
      if (m.faces(f, k) == 5) m.faces(f, k) = 1;
    }
  EXPECT_TRUE(contains(refusal(m), "non-manifold edge at vertex 0")) << refusal(m);
}

TEST(MeshChecks, NonManifoldVertex) {
  SurfaceMesh a = tetra(Vec3::Zero(), 1), b = tetra(Vec3::Zero(), 1);
  b.vertices *= -1;  // point reflection keeps orientation; touches a only at the origin
  SurfaceMesh m = merge(a, b);
  for (Eigen::Index f = 4; f < 8; ++f)
    for (int k = 0; k < 3; ++k)
      if (m.faces(f, k) == 4) m.faces(f, k) = 0;
  EXPECT_TRUE(contains(refusal(m), "non-manifold vertex 0")) << refusal(m);
}

TEST(MeshChecks, InconsistentOrientation) {
  SurfaceMesh m = box(Vec3::Ones());
  std::swap(m.faces(5, 1), m.faces(5, 2));
  EXPECT_TRUE(contains(refusal(m), "inconsistently oriented")) << refusal(m);
}

TEST(MeshChecks, SelfIntersection) {
  const SurfaceMesh m = merge(icosphere(1.0, 1), icosphere(1.0, 1, Vec3(0.5, 0, 0)));
  EXPECT_TRUE(contains(refusal(m), "self-intersection")) << refusal(m);
}

TEST(MeshChecks, DegenerateFaces) {
  SurfaceMesh m = box(Vec3::Ones());
  m.faces(0, 2) = m.faces(0, 1);
  EXPECT_TRUE(contains(refusal(m), "degenerate face 0")) << refusal(m);
  SurfaceMesh flat = tetra(Vec3::Zero(), 1);
  flat.vertices(3, 2) = 0;  // all four points in a plane
  flat.vertices.row(3) << 0.5, 0.5, 0;
  EXPECT_TRUE(contains(refusal(flat), "zero-area") || contains(refusal(flat), "self-intersection"))
      << refusal(flat);
}

TEST(MeshChecks, NonFiniteCoordinates) {
  SurfaceMesh m = box(Vec3::Ones());
  m.vertices(3, 1) = std::nan("");
  EXPECT_TRUE(contains(refusal(m), "non-finite")) << refusal(m);
}

TEST(MeshChecks, InwardOrientationIsFlipped) {
  SurfaceMesh m = box(Vec3::Ones());
  m.faces.col(1).swap(m.faces.col(2));
  ASSERT_LT(signed_volume(m), 0);
  require_closed_manifold(m);
  EXPECT_NEAR(signed_volume(m), 1.0, 1e-12);
}

// "components": "largest": the piece enclosing the largest volume, whichever comes first in the
// file, with its vertices in their file order.
TEST(Checks, LargestPieceIsTheOneEnclosingTheMostVolume) {
  const SurfaceMesh small = box(Vec3(0.2, 0.2, 0.2));
  SurfaceMesh big = box(Vec3(1, 2, 1));
  big.vertices.rowwise() += Eigen::RowVector3d(3, 0, 0);
  for (const bool big_first : {true, false}) {
    const SurfaceMesh both = big_first ? merge(big, small) : merge(small, big);
    long pieces = 0;
    const SurfaceMesh piece = largest_piece(both, &pieces);
    EXPECT_EQ(pieces, 2);
    EXPECT_NEAR(signed_volume(piece), 2.0, 1e-12);
    ASSERT_EQ(piece.vertices.rows(), big.vertices.rows());
    EXPECT_EQ(piece.faces.rows(), big.faces.rows());
    EXPECT_TRUE(piece.vertices.isApprox(big.vertices));  // the big box's own vertices, in order
    EXPECT_TRUE(inspect_surface(piece).manifold());
  }
  long pieces = 0;
  EXPECT_EQ(largest_piece(small, &pieces).faces.rows(), small.faces.rows());
  EXPECT_EQ(pieces, 1);
}
