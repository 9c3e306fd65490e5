// The one marching-tetrahedra case split (mesh/marching_tetrahedra.hpp), used by the Kelvin
// iso-surfaces and the sampled level sets: the triangles each sign pattern gives, in the order
// and with the quad diagonal both callers drew before they shared it.
#include <gtest/gtest.h>

#include <array>
#include <set>
#include <utility>
#include <vector>

#include "distlab/mesh/marching_tetrahedra.hpp"

namespace {

using Triangle = std::array<int, 3>;

// A crossing's id names its edge: 10 · (inside corner + 1) + (outside corner + 1).
std::vector<Triangle> march(const bool (&in)[4]) {
  const int corners[4] = {0, 1, 2, 3};
  std::vector<Triangle> out;
  distlab::mesh::march_tetrahedron(
      corners, in, [](int i, int o) { return 10 * (i + 1) + (o + 1); },
      [&](int a, int b, int e) { out.push_back({a, b, e}); });
  return out;
}

TEST(MarchingTetrahedra, OneCornerAloneGivesTheTriangleOfItsEdges) {
  EXPECT_EQ(march({true, false, false, false}), (std::vector<Triangle>{{12, 13, 14}}));
  EXPECT_EQ(march({false, false, true, false}), (std::vector<Triangle>{{31, 32, 34}}));
  // One corner outside: the crossings on its edges from each inside corner, in corner order.
  EXPECT_EQ(march({true, true, false, true}), (std::vector<Triangle>{{13, 23, 43}}));
}

TEST(MarchingTetrahedra, TwoAndTwoGiveTheQuadSplitFromTheFirstInsideCorner) {
  // Crossings a = (i0, o0), b = (i0, o1), e = (i1, o1), f = (i1, o0): triangles (a, b, e), (a, e, f).
  EXPECT_EQ(march({true, true, false, false}), (std::vector<Triangle>{{13, 14, 24}, {13, 24, 23}}));
  EXPECT_EQ(march({false, true, false, true}), (std::vector<Triangle>{{21, 23, 43}, {21, 43, 41}}));
}

TEST(MarchingTetrahedra, EveryPatternCutsExactlyTheEdgesThatChangeSide) {
  for (int pattern = 0; pattern < 16; ++pattern) {
    const bool in[4] = {(pattern & 1) != 0, (pattern & 2) != 0, (pattern & 4) != 0, (pattern & 8) != 0};
    const int n_in = in[0] + in[1] + in[2] + in[3];
    std::set<int> cut;  // the crossings a correct split passes through
    for (int i = 0; i < 4; ++i)
      for (int o = 0; o < 4; ++o)
        if (in[i] && !in[o]) cut.insert(10 * (i + 1) + (o + 1));
    const std::vector<Triangle> tris = march(in);
    std::set<int> used;
    for (const Triangle& t : tris) used.insert(t.begin(), t.end());
    EXPECT_EQ(used, cut) << "pattern " << pattern;
    std::size_t want = n_in == 2 ? 2 : 1;  // triangles: a quad, or the corner alone on its side
    if (n_in == 0 || n_in == 4) want = 0;
    EXPECT_EQ(tris.size(), want) << "pattern " << pattern;
  }
}

}  // namespace
