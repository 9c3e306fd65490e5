// Polygon faces (OBJ, OFF, PLY) become triangles of the file's own vertices: non-convex and
// non-planar faces, faces with a hole written as one loop, and refusals that name the file's face.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "distlab/geometry/error.hpp"
#include "distlab/mesh/surface.hpp"
#include "temp_dir.hpp"

namespace fs = std::filesystem;
using namespace distlab;
using namespace distlab::mesh;
using distlab::test::write_temp_file;

namespace {

using V3 = std::array<double, 3>;
using Polygon = std::vector<int>;

// The three text formats of the same polygons (ostringstream: GCC 12 raises a false -Wrestrict
// on chains of std::string concatenation).
std::string obj(const std::vector<V3>& vertices, const std::vector<Polygon>& faces) {
  std::ostringstream s;
  s.precision(17);
  for (const V3& v : vertices) s << "v " << v[0] << ' ' << v[1] << ' ' << v[2] << '\n';
  for (const Polygon& f : faces) {
    s << 'f';
    for (const int i : f) s << ' ' << i + 1;
    s << '\n';
  }
  return s.str();
}

// The vertex and face lines of OFF and ASCII PLY.
std::string off_body(const std::vector<V3>& vertices, const std::vector<Polygon>& faces) {
  std::ostringstream s;
  s.precision(17);
  for (const V3& v : vertices) s << v[0] << ' ' << v[1] << ' ' << v[2] << '\n';
  for (const Polygon& f : faces) {
    s << f.size();
    for (const int i : f) s << ' ' << i;
    s << '\n';
  }
  return s.str();
}

std::string off(const std::vector<V3>& vertices, const std::vector<Polygon>& faces) {
  std::ostringstream s;
  s << "OFF\n"
    << vertices.size() << ' ' << faces.size() << " 0\n"
    << off_body(vertices, faces);
  return s.str();
}

std::string ply(const std::vector<V3>& vertices, const std::vector<Polygon>& faces) {
  std::ostringstream s;
  s << "ply\nformat ascii 1.0\nelement vertex " << vertices.size() << "\nproperty double x\nproperty double y\nproperty double z\nelement face "
    << faces.size() << "\nproperty list uchar int vertex_indices\nend_header\n"
    << off_body(vertices, faces);
  return s.str();
}

// An L-shaped prism: the L (area 3) in z = 0 and z = 1, each cap ONE 6-corner face, listed from
// the corner (2, 1) from which a fan would cover the notch outside the L (its first triangle
// (2,1), (1,1), (1,2) lies outside). Vertex 12 is unused, vertex 13 repeats vertex 0's position.
const std::vector<std::array<double, 2>> kL = {{2, 1}, {1, 1}, {1, 2}, {0, 2}, {0, 0}, {2, 0}};  // counter-clockwise

std::vector<V3> l_vertices() {
  std::vector<V3> v;
  for (const double z : {0.0, 1.0})
    for (const auto& p : kL) v.push_back({p[0], p[1], z});
  v.push_back({9, 9, 9});
  v.push_back(v[0]);
  return v;
}

std::vector<Polygon> l_faces() {
  std::vector<Polygon> f = {{5, 4, 3, 2, 1, 0}, {6, 7, 8, 9, 10, 11}};  // bottom (seen from below), top
  for (int i = 0; i < 6; ++i) f.push_back({i, (i + 1) % 6, 6 + (i + 1) % 6, 6 + i});
  return f;
}

bool inside_l(double x, double y) { return x > 0 && y > 0 && ((x < 2 && y < 1) || (x < 1 && y < 2)); }

Eigen::Vector3d corner(const SurfaceMesh& m, Eigen::Index t, int k) { return m.vertices.row(m.faces(t, k)).transpose(); }
Eigen::Vector3d normal(const SurfaceMesh& m, Eigen::Index t) {
  return 0.5 * (corner(m, t, 1) - corner(m, t, 0)).cross(corner(m, t, 2) - corner(m, t, 0));
}

// Closed and consistently oriented by its indices: every edge in exactly two triangles, once in
// each direction (independent of the library's checks).
void expect_closed(const SurfaceMesh& m) {
  std::map<std::pair<int, int>, int> directed;
  for (Eigen::Index t = 0; t < m.faces.rows(); ++t)
    for (int k = 0; k < 3; ++k) ++directed[{m.faces(t, k), m.faces(t, (k + 1) % 3)}];
  for (const auto& [e, n] : directed) {
    EXPECT_EQ(n, 1) << "edge " << e.first << "-" << e.second << " used " << n << " times in one direction";
    EXPECT_EQ(directed.count({e.second, e.first}), 1u) << "edge " << e.first << "-" << e.second << " is on the boundary";
  }
}

// The triangles of the file's face f, by the numbering surface.hpp promises.
std::vector<Eigen::Index> triangles_of(const SurfaceMesh& m, std::size_t f) {
  Eigen::Index first = 0;
  for (std::size_t g = 0; g < f; ++g) first += m.polygon_corners[g] - 2;
  std::vector<Eigen::Index> out;
  for (Eigen::Index t = first; t < first + m.polygon_corners[f] - 2; ++t) out.push_back(t);
  return out;
}

double shoelace(const std::vector<std::array<double, 2>>& p) {
  double a = 0;
  for (std::size_t i = 0; i < p.size(); ++i) a += p[i][0] * p[(i + 1) % p.size()][1] - p[(i + 1) % p.size()][0] * p[i][1];
  return 0.5 * a;
}

void expect_refused(const std::string& file, const std::string& text, const std::string& says) {
  try {
    load_mesh(write_temp_file(file, text).string(), "upload");
    ADD_FAILURE() << file << " was accepted";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "upload");
    EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
  }
}

}  // namespace

// The L prism loads closed from OBJ, OFF and PLY; each cap's triangles lie inside the L, turn the
// cap's way, and add up to its area; the file's vertices are the mesh's, in order.
TEST(PolygonFaces, NonConvexCapsOfAClosedPrism) {
  const std::vector<V3> vertices = l_vertices();
  const std::vector<Polygon> faces = l_faces();
  ASSERT_DOUBLE_EQ(shoelace(kL), 3.0);
  for (const auto& [format, text] : {std::pair{"obj", obj(vertices, faces)}, {"off", off(vertices, faces)}, {"ply", ply(vertices, faces)}}) {
    SCOPED_TRACE(format);
    const SurfaceMesh m = load_mesh(write_temp_file(std::string("l.") + format, text).string());
    ASSERT_EQ(m.vertices.rows(), static_cast<Eigen::Index>(vertices.size()));
    for (std::size_t v = 0; v < vertices.size(); ++v)
      for (int k = 0; k < 3; ++k) EXPECT_EQ(m.vertices(static_cast<Eigen::Index>(v), k), vertices[v][static_cast<std::size_t>(k)]) << "vertex " << v;
    ASSERT_EQ(m.polygon_corners, (std::vector<int>{6, 6, 4, 4, 4, 4, 4, 4}));
    ASSERT_EQ(m.faces.rows(), 4 + 4 + 6 * 2);
    expect_closed(m);
    EXPECT_NEAR(signed_volume(m), 3.0, 1e-12);
    for (const std::size_t cap : {0u, 1u}) {
      const double up = cap == 0 ? -1.0 : 1.0;  // the cap's outward normal's z
      double area = 0;
      for (const Eigen::Index t : triangles_of(m, cap)) {
        for (int k = 0; k < 3; ++k) EXPECT_LT(m.faces(t, k), 12) << "triangle " << t << " uses a vertex not of the file's face";
        const Eigen::Vector3d c = (corner(m, t, 0) + corner(m, t, 1) + corner(m, t, 2)) / 3;
        EXPECT_TRUE(inside_l(c.x(), c.y())) << "triangle " << t << " of cap " << cap << " lies outside the L, centroid " << c.transpose();
        EXPECT_GT(normal(m, t).z() * up, 0) << "triangle " << t << " turns against its cap";
        area += std::abs(normal(m, t).z());
      }
      EXPECT_NEAR(area, 3.0, 1e-12) << "cap " << cap;
    }
  }
}

// A five-pointed star (ten corners, five reflex) as one face: eight triangles inside the star,
// each turning the face's way, of total area the star's.
TEST(PolygonFaces, StarIsTriangulatedInside) {
  std::vector<std::array<double, 2>> star;
  std::vector<V3> vertices;
  for (int i = 0; i < 10; ++i) {
    const double r = i % 2 == 0 ? 1.0 : 0.38, a = M_PI / 2 + i * M_PI / 5;
    star.push_back({r * std::cos(a), r * std::sin(a)});
    vertices.push_back({star.back()[0], star.back()[1], 0.5});
  }
  const SurfaceMesh m = load_mesh(write_temp_file("star.obj", obj(vertices, {{1, 2, 3, 4, 5, 6, 7, 8, 9, 0}})).string());
  ASSERT_EQ(m.faces.rows(), 8);
  double area = 0;
  for (Eigen::Index t = 0; t < m.faces.rows(); ++t) {
    EXPECT_GT(normal(m, t).z(), 0) << "triangle " << t;
    area += normal(m, t).z();
    // Inside the star: the centroid is inside the inner pentagon, or inside the tip it belongs to.
    const Eigen::Vector3d c = (corner(m, t, 0) + corner(m, t, 1) + corner(m, t, 2)) / 3;
    int crossings = 0;  // even-odd test against the star's outline
    for (std::size_t i = 0; i < star.size(); ++i) {
      const auto& p = star[i];
      const auto& q = star[(i + 1) % star.size()];
      if ((p[1] > c.y()) != (q[1] > c.y()) && c.x() < p[0] + (c.y() - p[1]) * (q[0] - p[0]) / (q[1] - p[1])) ++crossings;
    }
    EXPECT_EQ(crossings % 2, 1) << "triangle " << t << " lies outside the star";
  }
  EXPECT_NEAR(area, shoelace(star), 1e-12);
}

// Non-planar faces: a quad with a lifted corner, and a non-convex (dart) quad with a lifted reflex
// corner, listed so that a fan around its first corner would use the diagonal outside it.
TEST(PolygonFaces, NonPlanarQuadsKeepTheirCornersAndTurn) {
  const SurfaceMesh quad = load_mesh(write_temp_file("lifted.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0.1\nv 0 1 0\nf 1 2 3 4\n").string());
  ASSERT_EQ(quad.faces.rows(), 2);
  std::set<int> used;
  for (Eigen::Index t = 0; t < 2; ++t) {
    EXPECT_GT(normal(quad, t).z(), 0);
    for (int k = 0; k < 3; ++k) used.insert(quad.faces(t, k));
  }
  EXPECT_EQ(used, (std::set<int>{0, 1, 2, 3}));
  EXPECT_NEAR(std::abs(normal(quad, 0).z()) + std::abs(normal(quad, 1).z()), 1.0, 1e-12);

  // The dart (0,0), (2,1), (0,2), (0.5,1): the diagonal from (0,0) to (0,2) runs outside it.
  const SurfaceMesh dart = load_mesh(write_temp_file("dart.obj", "v 0 0 0\nv 2 1 0\nv 0 2 0\nv 0.5 1 0.05\nf 1 2 3 4\n").string());
  ASSERT_EQ(dart.faces.rows(), 2);
  for (Eigen::Index t = 0; t < 2; ++t) {
    EXPECT_GT(normal(dart, t).z(), 0) << "triangle " << t << " turns against the face: it lies outside the dart";
    std::set<int> corners{dart.faces(t, 0), dart.faces(t, 1), dart.faces(t, 2)};
    EXPECT_TRUE(corners.count(1) && corners.count(3)) << "the dart is cut along (2,1)-(0.5,1)";
  }
  EXPECT_NEAR(normal(dart, 0).z() + normal(dart, 1).z(), shoelace({{0, 0}, {2, 1}, {0, 2}, {0.5, 1}}), 1e-12);
}

// A polygon with a vertical edge (its corners 2 and 3 one above the other, seen along its normal)
// is triangulated in space: three triangles of its own corners, turning with it (normals up).
TEST(PolygonFaces, FoldedPolygonIsTriangulatedInSpace) {
  const SurfaceMesh m = load_mesh(write_temp_file("fold.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 1 1 0.3\nv 0 1 0\nf 1 2 3 4 5\n").string());
  ASSERT_EQ(m.faces.rows(), 3);
  std::set<int> used;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (Eigen::Index t = 0; t < 3; ++t) {
    for (int k = 0; k < 3; ++k) used.insert(m.faces(t, k));
    sum += normal(m, t);
  }
  EXPECT_EQ(used, (std::set<int>{0, 1, 2, 3, 4}));
  // The vector area of any triangulation of a closed polyline is the polyline's: (0, -0.15, 1).
  EXPECT_NEAR(sum.x(), 0.0, 1e-12);
  EXPECT_NEAR(sum.y(), -0.15, 1e-12);
  EXPECT_NEAR(sum.z(), 1.0, 1e-12);

  // Triangulating in space searches in O(k³): over 200 corners such a face is refused, by name.
  std::vector<V3> circle;
  Polygon loop;
  for (int i = 0; i < 200; ++i) {
    circle.push_back({std::cos(i * M_PI / 100), std::sin(i * M_PI / 100), 0});
    loop.push_back(i);
  }
  circle.push_back({1, 0, 0.3});  // above corner 0
  loop.insert(loop.begin() + 1, 200);
  expect_refused("big_fold.obj", obj(circle, {{0, 1, 2}, loop}), "face 1 folds over itself: its vertices 0 and 200 coincide seen along its normal, and with its 201 corners (over 200)");
}

// A square with a square hole written as one loop that runs in along a bridge edge and back out
// (concave_polygon.obj's way): the hole stays open, the bridge bounds nothing. A face that lists
// the same cycle three times over (box_longline.obj's way) is that cycle once.
TEST(PolygonFaces, HoleThroughABridgeAndRepeatedCycles) {
  const std::string v = "v 0 0 0\nv 4 0 0\nv 4 4 0\nv 0 4 0\nv 1 1 0\nv 1 3 0\nv 3 3 0\nv 3 1 0\n";
  // Outer counter-clockwise from vertex 1, across to the hole at 5, around it clockwise, back.
  const SurfaceMesh m = load_mesh(write_temp_file("hole.obj", v + "f 1 2 3 4 1 5 6 7 8 5\n").string());
  ASSERT_EQ(m.faces.rows(), 8);
  EXPECT_EQ(m.polygon_corners, (std::vector<int>{10}));
  double area = 0;
  for (Eigen::Index t = 0; t < m.faces.rows(); ++t) {
    EXPECT_GT(normal(m, t).z(), 0) << "triangle " << t;
    area += normal(m, t).z();
    const Eigen::Vector3d c = (corner(m, t, 0) + corner(m, t, 1) + corner(m, t, 2)) / 3;
    EXPECT_FALSE(c.x() > 1 && c.x() < 3 && c.y() > 1 && c.y() < 3) << "triangle " << t << " covers the hole";
  }
  EXPECT_NEAR(area, 16.0 - 4.0, 1e-12);

  const SurfaceMesh cycles = load_mesh(write_temp_file("cycles.obj", v + "f 1 2 3 4 1 2 3 4 1 2 3 4\nf 1 2 3\n").string());
  EXPECT_EQ(cycles.polygon_corners, (std::vector<int>{4, 3}));
  ASSERT_EQ(cycles.faces.rows(), 3);
  EXPECT_NEAR(normal(cycles, 0).z() + normal(cycles, 1).z(), 16.0, 1e-12);
}

// Polygons that are no disk are refused at import naming the file's face (counted from 0 among
// the faces, triangles included) and what is wrong with it.
TEST(PolygonFaces, PolygonsThatAreNoDiskAreRefusedByTheFilesFace) {
  const std::string v = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 2 0\nv 0 2 0\n";
  const std::string before = "f 1 2 3\nf 1 3 4\n";  // faces 0 and 1
  expect_refused("bowtie.obj", v + before + "f 1 2 4 3\n", "face 2's edges cross each other");
  // Two triangles meeting at vertex 2: (0, 1, 2) and (2, 4, 5).
  expect_refused("pinch.obj", v + before + "f 1 2 3 5 6 3\n", "face 2 lists vertex 2 at corners 2 and 5, which are not neighbours");
  // The edge from vertex 4 (2, 2) back to vertex 0 runs through vertex 2 (1, 1).
  expect_refused("touch.obj", v + before + "f 1 2 3 4 3 5\n", "face 2 touches itself: its vertex 2 lies on its edge between vertices 0 and 4");
  // The same refusals from OFF, whose faces count the same way.
  expect_refused("bowtie.off", "OFF\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 3 2\n", "face 0's edges cross each other");
}

// A polygon without area (collinear corners) stays a fan of zero-area triangles, for the surface
// checks to name (or "fix" to remove), as a degenerate triangle of the file would.
TEST(PolygonFaces, ZeroAreaPolygonsAreLeftToTheChecks) {
  const SurfaceMesh m = load_mesh(write_temp_file("flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 3 0 0\nf 1 2 3 4\nf 1 2 4\n").string());
  ASSERT_EQ(m.faces.rows(), 3);
  EXPECT_EQ(m.faces.row(0), Eigen::RowVector3i(0, 1, 2));
  EXPECT_EQ(m.faces.row(1), Eigen::RowVector3i(0, 2, 3));
  EXPECT_EQ(file_face_name(m, 1), "face 0 (triangle 1 of its 4-corner polygon)");
}

// The assimp test models that fanning refused (a face with a hole through a bridge, a face that
// repeats its cycle) load (test_stl.cpp has sphereWithHole.stl).
TEST(PolygonFaces, AssimpModelsWithPolygonFacesLoad) {
  const fs::path root = "/usr/share/assimp/models";
  if (!fs::is_directory(root)) GTEST_SKIP() << "assimp-testmodels is not installed";
  const SurfaceMesh concave = load_mesh((root / "OBJ/concave_polygon.obj").string());
  EXPECT_EQ(concave.vertices.rows(), 64);
  EXPECT_EQ(concave.faces.rows(), 64);  // one 66-corner face around a hole: 64 distinct corners
  // box.obj with its first face "4 3 2 1" written as "1 2 3 4" 234 times over: the same box with
  // that face turned the other way (as the file has it), closed.
  const SurfaceMesh box = load_mesh((root / "OBJ/box_longline.obj").string());
  ASSERT_EQ(box.faces.rows(), 12);
  SurfaceMesh turned = box;
  for (Eigen::Index t = 0; t < 2; ++t) std::swap(turned.faces(t, 1), turned.faces(t, 2));
  expect_closed(turned);
  const SurfaceMesh space = load_mesh((root / "OBJ/space_in_material_name.obj").string());
  EXPECT_EQ(space.faces.rows(), 64);
}
