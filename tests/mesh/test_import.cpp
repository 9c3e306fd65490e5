// Import, welding and export round trips through assimp for every supported format.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "distlab/geometry/error.hpp"
#include "distlab/mesh/checks.hpp"
#include "distlab/mesh/primitives.hpp"
#include "distlab/mesh/surface.hpp"
#include "mesh/hostile_meshes.hpp"
#include "temp_dir.hpp"

namespace fs = std::filesystem;
using namespace distlab;
using namespace distlab::mesh;
using namespace distlab::test;

TEST(MeshImport, RoundTripEveryFormatWeldsAndStaysClosed) {
  const SurfaceMesh sphere = icosphere(0.25, 2);
  ASSERT_GT(signed_volume(sphere), 0);
  for (const std::string format : {"stl", "obj", "ply", "glb"}) {
    const fs::path path = process_temp_dir() / ("sphere." + format);
    save_mesh(sphere, path.string(), format);
    SurfaceMesh back = load_mesh(path.string());
    // STL stores three corners per face: welding must bring it back to the indexed mesh.
    EXPECT_EQ(back.vertices.rows(), sphere.vertices.rows()) << format;
    EXPECT_EQ(back.faces.rows(), sphere.faces.rows()) << format;
    EXPECT_NO_THROW(require_closed_manifold(back)) << format;
    EXPECT_NEAR(signed_volume(back), signed_volume(sphere), 1e-6) << format;
  }
  // OBJ is one file: no material library is written or referenced.
  std::ifstream obj(process_temp_dir() / "sphere.obj");
  const std::string text((std::istreambuf_iterator<char>(obj)), std::istreambuf_iterator<char>());
  EXPECT_EQ(text.find("mtllib"), std::string::npos);
  EXPECT_FALSE(fs::exists(process_temp_dir() / "sphere.mtl"));
}

TEST(MeshImport, ReadsOffText) {
  const fs::path path = process_temp_dir() / "tet.off";
  std::ofstream(path) << "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
  SurfaceMesh tet = load_mesh(path.string());
  EXPECT_EQ(tet.vertices.rows(), 4);
  EXPECT_EQ(tet.faces.rows(), 4);
  require_closed_manifold(tet);
  EXPECT_NEAR(signed_volume(tet), 1.0 / 6.0, 1e-12);
}

TEST(MeshImport, MissingAndUnreadableFilesNameTheField) {
  try {
    load_mesh("/nonexistent/file.stl");
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "mesh.path");
    EXPECT_NE(std::string(e.what()).find("no such file"), std::string::npos);
  }
  const fs::path path = process_temp_dir() / "garbage.stl";
  std::ofstream(path) << "this is not a mesh";
  EXPECT_THROW(load_mesh(path.string()), InvalidInput);
}

// Garbage named .stl is called what it is (not a size-limit error from its "triangle count").
TEST(MeshImport, BinaryStlMustBe84Plus50NBytes) {
  const SurfaceMesh cube = box(Vec3(0.1, 0.2, 0.3));
  const fs::path good = process_temp_dir() / "cube.stl";
  save_mesh(cube, good.string(), "stl");
  std::ifstream in(good, std::ios::binary);
  const std::string bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  ASSERT_EQ(bytes.size(), 84u + 50u * static_cast<std::size_t>(cube.faces.rows()));
  EXPECT_EQ(binary_stl_triangles(bytes, "body"), static_cast<std::uint32_t>(cube.faces.rows()));
  // A binary file whose header happens to start with "solid" is still binary.
  std::string solid_header = bytes;
  solid_header.replace(0, 5, "solid");
  EXPECT_EQ(binary_stl_triangles(solid_header, "body"), static_cast<std::uint32_t>(cube.faces.rows()));
  EXPECT_EQ(binary_stl_triangles("solid x\nfacet normal 0 0 1\n", "body"), std::nullopt);

  std::string garbage(1000, '\0');
  for (std::size_t i = 0; i < garbage.size(); ++i) garbage[i] = static_cast<char>((i * 7919u + 13u) % 251u);
  const std::vector<std::pair<std::string, std::string>> bad = {
      {garbage, "header says n = "},                                                     // a huge "n" from random bytes
      {bytes + "x", "but the file has " + std::to_string(bytes.size() + 1) + " bytes"},  // one byte too many
      {bytes.substr(0, bytes.size() - 50), "header says n = 12"},                        // truncated
      {"abc", "only 3 bytes"}};
  for (const auto& [b, says] : bad) {
    try {
      binary_stl_triangles(b, "body");
      ADD_FAILURE() << "accepted " << b.size() << " bytes";
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.field(), "body");
      EXPECT_NE(std::string(e.what()).find("not a valid STL"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("84 + 50"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
    }
    // The importer refuses the same file with the same message.
    const fs::path path = process_temp_dir() / "bad.stl";
    std::ofstream(path, std::ios::binary) << b;
    try {
      load_mesh(path.string(), "mesh.path");
      ADD_FAILURE() << "load_mesh accepted " << b.size() << " bytes";
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.field(), "mesh.path");
      EXPECT_NE(std::string(e.what()).find("not a valid STL"), std::string::npos) << e.what();
    }
  }
}

TEST(MeshExport, UnknownFormatIsRefused) {
  try {
    save_mesh(box(Vec3::Ones()), (process_temp_dir() / "x.abc").string(), "abc");
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "format");
  }
}

namespace {

std::string slurp(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void expect_file_order(const SurfaceMesh& m, const std::string& format) {
  ASSERT_EQ(m.vertices.rows(), static_cast<Eigen::Index>(kFileVertices.size())) << format << ": duplicates kept, nothing welded";
  for (std::size_t v = 0; v < kFileVertices.size(); ++v)
    for (int k = 0; k < 3; ++k) EXPECT_EQ(m.vertices(static_cast<Eigen::Index>(v), k), kFileVertices[v][static_cast<std::size_t>(k)]) << format << " vertex " << v;
  ASSERT_EQ(m.faces.rows(), static_cast<Eigen::Index>(kFileFaces.size())) << format;
  for (std::size_t f = 0; f < kFileFaces.size(); ++f)
    for (int k = 0; k < 3; ++k) EXPECT_EQ(m.faces(static_cast<Eigen::Index>(f), k), kFileFaces[f][static_cast<std::size_t>(k)]) << format << " face " << f;
}

}  // namespace

// Per-vertex arrays are given in the file's vertex order: the loader must return exactly the
// file's vertices in that order, duplicates included, not the order the faces meet them.
TEST(MeshImport, KeepsTheFilesVertexOrderAndDuplicates) {
  expect_file_order(load_mesh(write_temp_file("order.obj", obj_text()).string()), "obj");
  expect_file_order(load_mesh(write_temp_file("order.off", off_text()).string()), "off");
  expect_file_order(load_mesh(write_temp_file("order.ply", ply_ascii()).string()), "ascii ply");
  expect_file_order(load_mesh(write_temp_file("order_b.ply", ply_binary()).string()), "binary ply");
}

// Polygons become triangles of the file's vertex ids (no vertex added or renumbered), turning as
// the polygon does (this one clockwise seen from +z).
TEST(MeshImport, PolygonsAreTriangulatedWithFileIds) {
  const SurfaceMesh m = load_mesh(write_temp_file("quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 9 9 9\nf 4 3 2 1\n").string());
  ASSERT_EQ(m.vertices.rows(), 5);
  ASSERT_EQ(m.faces.rows(), 2);
  double area = 0;
  for (Eigen::Index t = 0; t < 2; ++t) {
    for (int k = 0; k < 3; ++k) EXPECT_LT(m.faces(t, k), 4);
    const Vec3 a = m.vertices.row(m.faces(t, 0)), b = m.vertices.row(m.faces(t, 1)), c = m.vertices.row(m.faces(t, 2));
    area += 0.5 * (b - a).cross(c - a).z();
  }
  EXPECT_NEAR(area, -1.0, 1e-12);
}

// An OBJ vertex line that CGAL's reader cannot read (a NaN, a word, two coordinates) is refused
// naming its line and vertex; a w or a colour after the three coordinates is read as before.
TEST(MeshImport, ObjVertexLinesNeedThreeFiniteCoordinates) {
  const std::string tail = "v 1 0 0\nf 1 2 3\nf 1 3 4\n";
  for (const auto& [line, says] : std::vector<std::pair<std::string, std::string>>{
           {"v 0 0.1 nan", "has \"nan\""}, {"v 0 inf 0", "has \"inf\""}, {"v 0 0.1 x", "has \"x\""}, {"v 0 0.1", "has fewer"}}) {
    try {
      load_mesh(write_temp_file("nan.obj", "# a comment\nv 0 0 0\n" + line + "\nv 0 1 0\n" + tail).string(), "upload");
      ADD_FAILURE() << line << ": accepted";
    } catch (const InvalidInput& e) {
      const std::string m = e.what();
      EXPECT_EQ(e.field(), "upload") << m;
      EXPECT_NE(m.find("line 3: vertex 1 (counted from 0) needs three finite coordinates, " + says), std::string::npos) << m;
    }
  }
  const SurfaceMesh m = load_mesh(write_temp_file("w.obj", "v 0 0 0 1\nv 0 1e-1 0 0.5 0.5 0.5\nv 0 1 1\n" + tail).string());
  EXPECT_EQ(m.vertices.rows(), 4);
  EXPECT_EQ(m.vertices(1, 1), 0.1);
}

// Per-face data in the file's order: the file's face f is triangles T(f) … T(f) + k_f − 3 with
// T(f) = Σ_{g<f} (k_g − 2) (surface.hpp). The file mixes a pentagon, a triangle and a quad (plus
// another triangle) of known areas in the plane z = 0; gathering the triangles' areas per file
// face by that rule gives each polygon's shoelace area. Any other numbering (the quad's triangles
// first, faces sorted by size) mixes areas of different faces and fails.
TEST(MeshImport, TrianglesOfEachFileFaceFollowInTheFilesOrder) {
  const std::string obj =
      "v 0 0 0\nv 4 0 0\nv 4 1 0\nv 2 3 0\nv 0 1 0\n"  // convex pentagon, area 8
      "v 10 0 0\nv 13 0 0\nv 10 2 0\n"                 // right triangle, area 3
      "v 20 0 0\nv 25 0 0\nv 25 7 0\nv 20 7 0\n"       // rectangle, area 35
      "v 30 0 0\nv 31 0 0\nv 30 1 0\n"                 // right triangle, area 0.5
      "f 1 2 3 4 5\nf 6 7 8\nf 9 10 11 12\nf 13 14 15\n";
  const SurfaceMesh m = load_mesh(write_temp_file("mixed.obj", obj).string());
  const std::vector<int> corners = {5, 3, 4, 3};
  ASSERT_EQ(m.faces.rows(), 3 + 1 + 2 + 1);
  const auto shoelace = [&](const std::vector<int>& ids) {
    double a = 0;
    for (std::size_t i = 0; i < ids.size(); ++i) {
      const auto p = m.vertices.row(ids[i]), q = m.vertices.row(ids[(i + 1) % ids.size()]);
      a += p(0) * q(1) - q(0) * p(1);
    }
    return 0.5 * a;
  };
  const std::vector<std::vector<int>> polygons = {{0, 1, 2, 3, 4}, {5, 6, 7}, {8, 9, 10, 11}, {12, 13, 14}};
  Eigen::Index t = 0;
  for (std::size_t f = 0; f < corners.size(); ++f) {
    double area = 0;
    for (int j = 0; j < corners[f] - 2; ++j, ++t) {
      const Vec3 a = m.vertices.row(m.faces(t, 0)), b = m.vertices.row(m.faces(t, 1)), c = m.vertices.row(m.faces(t, 2));
      area += 0.5 * (b - a).cross(c - a).z();  // signed: triangles of the file's winding have no negative part here
      for (int k = 0; k < 3; ++k)
        EXPECT_NE(std::find(polygons[f].begin(), polygons[f].end(), m.faces(t, k)), polygons[f].end()) << "triangle " << t << " is not of face " << f;
    }
    EXPECT_NEAR(area, shoelace(polygons[f]), 1e-12) << "file face " << f;
  }
  EXPECT_NEAR(shoelace(polygons[0]), 8.0, 1e-12);  // the areas differ, so a mix-up shows
  EXPECT_NEAR(shoelace(polygons[2]), 35.0, 1e-12);
}

// The corner counts travel with the mesh (after dropped repeated corners), so that a triangle is
// named as the user's face: triangle 3 is face 2's (the quad's) second; a triangle file has none.
TEST(MeshImport, TrianglesAreNamedByTheFilesFaces) {
  const std::string v = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv -1 0.5 0\n";
  const SurfaceMesh m = load_mesh(write_temp_file("names.obj", v + "f 1 2 3 4 5\nf 1 2 3\nf 1 1 2 3 4\n").string());
  EXPECT_EQ(m.polygon_corners, (std::vector<int>{5, 3, 4}));
  const std::vector<std::string> names = {"face 0 (triangle 0 of its 5-corner polygon)", "face 0 (triangle 1 of its 5-corner polygon)",
                                          "face 0 (triangle 2 of its 5-corner polygon)", "face 1",
                                          "face 2 (triangle 0 of its 4-corner polygon)", "face 2 (triangle 1 of its 4-corner polygon)"};
  ASSERT_EQ(m.faces.rows(), static_cast<Eigen::Index>(names.size()));
  for (Eigen::Index t = 0; t < m.faces.rows(); ++t) EXPECT_EQ(file_face_name(m, t), names[static_cast<std::size_t>(t)]);
  EXPECT_TRUE(load_mesh(write_temp_file("tri.obj", v + "f 1 2 3\nf 1 3 4\n").string()).polygon_corners.empty());
  SurfaceMesh stale = m;
  stale.polygon_corners = {4};  // counts that do not cover the faces are no numbering
  EXPECT_EQ(file_face_name(stale, 4), "face 4");
}

// A polygon that repeats a vertex in neighbouring corners (a zero-length edge) loses the repeated
// corner and is the polygon without it; one that repeats it at corners apart, pinching into two
// loops, is refused naming the face, the vertex and the corners (0-based), before any surface
// check (tests/mesh/test_polygon_faces.cpp has the other polygons that are no disk).
TEST(MeshImport, RepeatedCornersAreDroppedAndPinchedPolygonsNamed) {
  const std::string v = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 2 0\nv 0 2 0\n";
  SurfaceMesh m = load_mesh(write_temp_file("dup.obj", v + "f 1 2 3\nf 1 2 2 3 4 1\n").string());
  ASSERT_EQ(m.faces.rows(), 1 + 2);  // the quad (1 2 3 0): corners 0 and 2 repeat their predecessors
  EXPECT_EQ(m.polygon_corners, (std::vector<int>{3, 4}));
  for (Eigen::Index t = 1; t < 3; ++t)
    for (int k = 0; k < 3; ++k) EXPECT_LT(m.faces(t, k), 4);
  try {
    load_mesh(write_temp_file("pinch.obj", v + "f 1 2 3\nf 1 2 3 5 6 3\n").string(), "upload");
    FAIL() << "a pinched polygon was accepted";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "upload");
    EXPECT_NE(std::string(e.what()).find("face 1 lists vertex 2 at corners 2 and 5"), std::string::npos) << e.what();
  }
}

// Indexed formats written by save_mesh come back in the same order (PLY, and glTF's accessors).
TEST(MeshImport, IndexedRoundTripKeepsOrder) {
  const SurfaceMesh sphere = icosphere(0.25, 2);
  for (const std::string format : {"ply", "glb"}) {
    const fs::path path = process_temp_dir() / ("order." + format);
    save_mesh(sphere, path.string(), format);
    const SurfaceMesh back = load_mesh(path.string());
    ASSERT_EQ(back.vertices.rows(), sphere.vertices.rows()) << format;
    EXPECT_EQ(back.vertices, sphere.vertices.cast<float>().cast<double>()) << format;
    EXPECT_EQ(back.faces, sphere.faces) << format;
  }
}

// STL has no vertex list: its vertices are the distinct corner positions in order of first
// appearance, facet by facet (the contract in surface.hpp), read here from the bytes directly.
TEST(MeshImport, StlVerticesAreCornersInOrderOfFirstAppearance) {
  const fs::path path = process_temp_dir() / "box.stl";
  save_mesh(box(Vec3(0.1, 0.2, 0.3)), path.string(), "stl");
  const std::string bytes = slurp(path);
  std::vector<std::array<float, 3>> first;
  std::vector<int> corner_ids;
  for (std::size_t c = 0; c < (bytes.size() - 84) / 50 * 3; ++c) {
    std::array<float, 3> p;
    std::memcpy(p.data(), bytes.data() + 84 + 50 * (c / 3) + 12 * (1 + c % 3), 12);
    auto it = std::find(first.begin(), first.end(), p);
    corner_ids.push_back(static_cast<int>(it - first.begin()));
    if (it == first.end()) first.push_back(p);
  }
  const SurfaceMesh m = load_mesh(path.string());
  ASSERT_EQ(m.vertices.rows(), static_cast<Eigen::Index>(first.size()));
  for (std::size_t v = 0; v < first.size(); ++v)
    for (int k = 0; k < 3; ++k) EXPECT_EQ(m.vertices(static_cast<Eigen::Index>(v), k), first[v][static_cast<std::size_t>(k)]);
  for (std::size_t c = 0; c < corner_ids.size(); ++c) EXPECT_EQ(m.faces(static_cast<Eigen::Index>(c / 3), static_cast<int>(c % 3)), corner_ids[c]);
}

// Each hostile file is refused with InvalidInput naming the field, without a crash and without
// allocating what the file declares (peak RSS grows by less than 200 MB over all of them).
// Collada (the format of many URDF collision meshes) through assimp: the file's <unit meter> scales
// the vertices, its up_axis does not rotate them (URDF's convention), and the vertices keep the
// file's order. A Z_UP file in millimetres: vertex (x, y, z) mm is read as (x, y, z) / 1000 m.
TEST(MeshImport, ColladaAppliesItsUnitNotItsUpAxis) {
  const std::string dae = R"(<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><unit name="millimeter" meter="0.001"/><up_axis>Z_UP</up_axis></asset>
  <library_geometries><geometry id="g"><mesh>
    <source id="p"><float_array id="pa" count="12">0 0 0 100 0 0 0 200 0 0 0 300</float_array>
      <technique_common><accessor source="#pa" count="4" stride="3">
        <param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
      </accessor></technique_common></source>
    <vertices id="v"><input semantic="POSITION" source="#p"/></vertices>
    <triangles count="4"><input semantic="VERTEX" source="#v" offset="0"/><p>0 2 1 0 1 3 0 3 2 1 2 3</p></triangles>
  </mesh></geometry></library_geometries>
  <library_visual_scenes><visual_scene id="s"><node id="n"><instance_geometry url="#g"/></node></visual_scene></library_visual_scenes>
  <scene><instance_visual_scene url="#s"/></scene>
</COLLADA>)";
  const SurfaceMesh m = load_mesh(write_temp_file("tet.dae", dae).string());
  ASSERT_EQ(m.faces.rows(), 4);
  // assimp may repeat a vertex per face corner; the distinct positions, in order of first use, are the file's.
  std::vector<Vec3> seen;
  for (Eigen::Index f = 0; f < m.faces.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const Vec3 v = m.vertices.row(m.faces(f, c));
      if (std::find(seen.begin(), seen.end(), v) == seen.end()) seen.push_back(v);
    }
  ASSERT_EQ(seen.size(), 4u);
  const std::vector<Vec3> expected = {{0, 0, 0}, {0, 0.2, 0}, {0.1, 0, 0}, {0, 0, 0.3}};  // first use: 0 2 1, then 3
  // assimp holds coordinates as floats: equal to float rounding (2^-24 relative).
  for (std::size_t i = 0; i < 4; ++i) EXPECT_LE((seen[i] - expected[i]).norm(), 6e-8 * expected[i].norm()) << i;
  EXPECT_THROW(load_mesh(write_temp_file("broken.dae", "<COLLADA><library_geometries>").string()), InvalidInput);
}

TEST(MeshImport, HostileFilesAreRefusedWithoutExhaustion) {
  rusage before{};
  ::getrusage(RUSAGE_SELF, &before);
  int i = 0;
  for (const auto& [format, bytes] : hostile_meshes()) {
    const fs::path path = write_temp_file("hostile" + std::to_string(i++) + "." + format, bytes);
    try {
      const SurfaceMesh m = load_mesh(path.string(), "upload");
      ADD_FAILURE() << "accepted hostile file " << i - 1 << " (" << format << ", " << m.vertices.rows() << " vertices)";
    } catch (const InvalidInput& e) {
      std::printf("hostile %d (%s): %s\n", i - 1, format.c_str(), e.what());
      EXPECT_EQ(e.field(), "upload") << e.what();
      EXPECT_EQ(std::string(e.what()).find(process_temp_dir().path()), std::string::npos) << "message reveals the path: " << e.what();
    }
  }
  rusage after{};
  ::getrusage(RUSAGE_SELF, &after);
  EXPECT_LT(after.ru_maxrss - before.ru_maxrss, 200 * 1024) << "KB of peak RSS";
}

// Non-finite coordinates are named as such (not as a parse failure).
TEST(MeshImport, NonFiniteCoordinatesAreNamed) {
  const auto files = hostile_meshes();
  for (std::size_t k = files.size() - 2; k < files.size(); ++k) {
    const fs::path path = write_temp_file("nonfinite" + std::to_string(k) + "." + files[k].first, files[k].second);
    try {
      load_mesh(path.string(), "upload");
      ADD_FAILURE() << files[k].first;
    } catch (const InvalidInput& e) {
      EXPECT_NE(std::string(e.what()).find("non-finite"), std::string::npos) << e.what();
    }
  }
}
