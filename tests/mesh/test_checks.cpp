// Every refused-mesh case names its defect; valid meshes pass (and inward ones are flipped); the
// defects of a mesh as the user gave it are found where they are, in the file's numbering.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <vector>

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
  EXPECT_TRUE(contains(refusal(m), "vertices counted from 0 in the file's order")) << refusal(m);  // OBJ counts from 1
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

namespace {

// Every face with three file vertices of its own (an OBJ or PLY that repeats positions per face).
SurfaceMesh soup(const SurfaceMesh& m) {
  SurfaceMesh out;
  out.vertices.resize(3 * m.faces.rows(), 3);
  out.faces.resize(m.faces.rows(), 3);
  for (Eigen::Index f = 0; f < m.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      out.vertices.row(3 * f + k) = m.vertices.row(m.faces(f, k));
      out.faces(f, k) = static_cast<int>(3 * f + k);
    }
  return out;
}

// How find_defects numbers a position: the first file vertex a face uses there.
int first_at(const SurfaceMesh& m, const Eigen::RowVector3d& p) {
  for (Eigen::Index v = 0; v < m.vertices.rows(); ++v)
    if (m.vertices.row(v) == p && (m.faces.array() == static_cast<int>(v)).any()) return static_cast<int>(v);
  return -1;
}

}  // namespace

TEST(MeshDefects, AClosedBoxHasNone) {
  const MeshDefects d = find_defects(box(Vec3(1, 2, 3)), 100);
  EXPECT_EQ(d.boundary_edges + d.non_manifold_edges + d.non_manifold_vertices + d.degenerate_faces + d.self_intersections, 0);
  EXPECT_EQ(d.unchecked_faces, 0);
  EXPECT_TRUE(d.self_intersections_complete);
  ASSERT_EQ(d.pieces.size(), 1u);
  EXPECT_EQ(d.pieces[0].faces, 12);
  EXPECT_NEAR(std::abs(d.pieces[0].volume), 6.0, 1e-12);
  EXPECT_EQ(d.pieces[0].runs, (std::vector<std::array<long, 2>>{{0, 12}}));
  EXPECT_EQ(d.largest, 0);
  EXPECT_FALSE(d.truncated);
}

// The hole of a removed face: its three edges, each named by the first file vertex at its ends
// (the file repeats every position per face); a limit of one lists one and keeps the count.
TEST(MeshDefects, AnOpenSoupNamesItsHoleInTheFilesNumbering) {
  const SurfaceMesh closed = box(Vec3(1, 2, 3));
  SurfaceMesh open = soup(closed);
  const Eigen::Index removed = 5;
  open.faces.row(removed) = open.faces.row(open.faces.rows() - 1);  // face 11 moves to 5
  open.faces.conservativeResize(open.faces.rows() - 1, 3);
  std::vector<std::array<int, 2>> expected;
  for (int k = 0; k < 3; ++k) {
    const int a = first_at(open, closed.vertices.row(closed.faces(removed, k)));
    const int b = first_at(open, closed.vertices.row(closed.faces(removed, (k + 1) % 3)));
    ASSERT_GE(std::min(a, b), 0);
    expected.push_back({std::min(a, b), std::max(a, b)});
  }
  std::sort(expected.begin(), expected.end());
  const MeshDefects d = find_defects(open, 100);
  EXPECT_EQ(d.boundary_edges, 3);
  EXPECT_EQ(d.boundary, expected);
  EXPECT_EQ(d.non_manifold_edges + d.non_manifold_vertices + d.degenerate_faces + d.self_intersections, 0);
  ASSERT_EQ(d.pieces.size(), 1u);
  EXPECT_EQ(d.pieces[0].runs, (std::vector<std::array<long, 2>>{{0, 11}}));
  EXPECT_FALSE(d.truncated);

  const MeshDefects one = find_defects(open, 1);
  EXPECT_EQ(one.boundary_edges, 3);
  EXPECT_EQ(one.boundary, (std::vector<std::array<int, 2>>{expected[0]}));
  EXPECT_TRUE(one.truncated);
}

TEST(MeshDefects, NonManifoldEdgeAndVertex) {
  // Two tetrahedra sharing only the edge (0, 1): the second turned half a turn about x.
  SurfaceMesh a = tetra(Vec3::Zero(), 1), b = tetra(Vec3::Zero(), 1);
  b.vertices.col(1) *= -1;
  b.vertices.col(2) *= -1;
  SurfaceMesh m = merge(a, b);
  for (Eigen::Index f = 4; f < 8; ++f)
    for (int k = 0; k < 3; ++k) {
      if (m.faces(f, k) == 4) m.faces(f, k) = 0;
      if (m.faces(f, k) == 5) m.faces(f, k) = 1;
    }
  const MeshDefects edge = find_defects(m, 100);
  EXPECT_EQ(edge.non_manifold_edges, 1);
  EXPECT_EQ(edge.non_manifold, (std::vector<std::array<int, 2>>{{0, 1}}));
  EXPECT_EQ(edge.boundary_edges, 0);
  EXPECT_GT(edge.unchecked_faces, 0);  // the faces a halfedge mesh cannot take there
  EXPECT_EQ(edge.pieces.size(), 1u);   // joined across the shared edge

  // Two tetrahedra touching at the origin only: one pinched vertex, two pieces.
  SurfaceMesh c = tetra(Vec3::Zero(), 1), e = tetra(Vec3::Zero(), 1);
  e.vertices *= -1;
  SurfaceMesh pinched = merge(c, e);
  for (Eigen::Index f = 4; f < 8; ++f)
    for (int k = 0; k < 3; ++k)
      if (pinched.faces(f, k) == 4) pinched.faces(f, k) = 0;
  const MeshDefects vertex = find_defects(pinched, 100);
  EXPECT_EQ(vertex.non_manifold_vertices, 1);
  EXPECT_EQ(vertex.pinched, std::vector<int>{0});
  EXPECT_EQ(vertex.boundary_edges + vertex.non_manifold_edges, 0);
  EXPECT_EQ(vertex.pieces.size(), 2u);
}

// Two overlapping spheres: every intersecting pair has one face of each (CGAL's test), in the
// file's face numbering; the larger sphere is the piece "components": "largest" keeps.
TEST(MeshDefects, SelfIntersectionsAndPieces) {
  const SurfaceMesh small = icosphere(0.9, 1), large = icosphere(1.0, 1, Vec3(0.5, 0, 0));
  const SurfaceMesh m = merge(small, large);
  const long n = static_cast<long>(small.faces.rows());
  const MeshDefects d = find_defects(m, 100000);
  EXPECT_GT(d.self_intersections, 0);
  EXPECT_TRUE(d.self_intersections_complete);
  EXPECT_EQ(d.intersecting.size(), static_cast<std::size_t>(d.self_intersections));
  for (const auto& [f, g] : d.intersecting) {
    EXPECT_LT(f, n);
    EXPECT_GE(g, n);
  }
  ASSERT_EQ(d.pieces.size(), 2u);
  EXPECT_EQ(d.pieces[0].runs, (std::vector<std::array<long, 2>>{{0, n}}));
  EXPECT_EQ(d.pieces[1].runs, (std::vector<std::array<long, 2>>{{n, static_cast<long>(large.faces.rows())}}));
  EXPECT_NEAR(d.pieces[1].volume, signed_volume(large), 1e-12);
  EXPECT_EQ(d.largest, 1);

  // The search stops at the limit and says so.
  const MeshDefects two = find_defects(m, 2);
  EXPECT_EQ(two.intersecting.size(), 2u);
  EXPECT_FALSE(two.self_intersections_complete);
  EXPECT_TRUE(two.truncated);
}

TEST(MeshDefects, DegenerateFacesAreListedAndNotTested) {
  SurfaceMesh m = box(Vec3::Ones());
  m.faces(3, 2) = m.faces(3, 1);
  const MeshDefects d = find_defects(m, 100);
  EXPECT_EQ(d.degenerate_faces, 1);
  EXPECT_EQ(d.degenerate, std::vector<int>{3});
  EXPECT_GE(d.unchecked_faces, 1);
  EXPECT_GT(d.boundary_edges, 0);  // the collapsed face leaves its neighbours open
}
