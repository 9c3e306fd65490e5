// The exact-position weld (mesh/weld.hpp): the map from the user's vertices to the welded ones.
#include <gtest/gtest.h>

#include <cmath>

#include "distlab/mesh/checks.hpp"
#include "distlab/mesh/primitives.hpp"
#include "distlab/mesh/weld.hpp"

using namespace distlab;
using namespace distlab::mesh;

TEST(Weld, ClosedMeshWithoutDuplicatesIsUnchanged) {
  const SurfaceMesh m = icosphere(0.3, 2);
  const Welded w = weld(m);
  EXPECT_EQ(w.surface.vertices, m.vertices);
  EXPECT_EQ(w.surface.faces, m.faces);
  for (std::size_t i = 0; i < w.to_welded.size(); ++i) EXPECT_EQ(w.to_welded[i], static_cast<int>(i));
}

// A triangle soup (each face with its own three vertices, as an STL lists them) welds back into
// the closed box; every user vertex maps to the welded vertex at its position.
TEST(Weld, SoupWeldsToTheClosedMeshAndMapsEveryVertex) {
  const SurfaceMesh box_mesh = box(Vec3(1, 0.6, 0.4));
  SurfaceMesh soup;
  soup.vertices.resize(3 * box_mesh.faces.rows(), 3);
  soup.faces.resize(box_mesh.faces.rows(), 3);
  for (Eigen::Index f = 0; f < box_mesh.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      soup.vertices.row(3 * f + k) = box_mesh.vertices.row(box_mesh.faces(f, k));
      soup.faces(f, k) = static_cast<int>(3 * f + k);
    }
  EXPECT_NE(topology_defect(soup), "") << "a soup is open";
  const Welded w = weld(soup);
  EXPECT_EQ(w.surface.vertices.rows(), 8);
  EXPECT_EQ(w.surface.faces.rows(), box_mesh.faces.rows());
  EXPECT_EQ(topology_defect(w.surface), "");
  ASSERT_EQ(w.to_welded.size(), 3 * static_cast<std::size_t>(box_mesh.faces.rows()));
  for (Eigen::Index v = 0; v < soup.vertices.rows(); ++v)
    EXPECT_EQ(Vec3(w.surface.vertices.row(w.to_welded[static_cast<std::size_t>(v)])), Vec3(soup.vertices.row(v)));
  // Welded vertices are numbered by their first user vertex.
  EXPECT_EQ(w.to_welded[0], 0);
  for (std::size_t v = 1, next = 1; v < w.to_welded.size(); ++v)
    if (w.to_welded[v] >= static_cast<int>(next)) {
      EXPECT_EQ(w.to_welded[v], static_cast<int>(next++));
    }
}

// −0 and +0 are one position; a vertex no face uses maps to −1 and is dropped; positions that
// differ in the last bit stay apart (no tolerance).
TEST(Weld, SignedZeroUnusedVerticesAndNoTolerance) {
  SurfaceMesh m;
  m.vertices.resize(6, 3);
  m.vertices << 0, 0, 0,  //
      1, 0, 0,            //
      0, 1, 0,            //
      -0.0, 0, -0.0,      //
      5, 5, 5,            //
      std::nextafter(1.0, 2.0), 0, 0;
  m.faces.resize(2, 3);
  m.faces << 0, 1, 2, 3, 2, 5;
  const Welded w = weld(m);
  EXPECT_EQ(w.to_welded, (std::vector<int>{0, 1, 2, 0, -1, 3}));
  EXPECT_EQ(w.surface.vertices.rows(), 4);
  EXPECT_EQ(w.surface.faces(1, 0), 0);
  EXPECT_EQ(w.surface.faces(1, 2), 3);
}
