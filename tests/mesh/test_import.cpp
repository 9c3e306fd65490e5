// Import, welding and export round trips through assimp for every supported format.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "distlab/geometry/error.hpp"
#include "distlab/mesh/checks.hpp"
#include "distlab/mesh/primitives.hpp"
#include "distlab/mesh/surface.hpp"

namespace fs = std::filesystem;
using namespace distlab;
using namespace distlab::mesh;

namespace {

fs::path temp_dir() {
  fs::path dir = fs::temp_directory_path() / ("distlab_mesh_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir;
}

}  // namespace

TEST(MeshImport, RoundTripEveryFormatWeldsAndStaysClosed) {
  const SurfaceMesh sphere = icosphere(0.25, 2);
  ASSERT_GT(signed_volume(sphere), 0);
  for (const std::string format : {"stl", "obj", "ply", "glb"}) {
    const fs::path path = temp_dir() / ("sphere." + format);
    save_mesh(sphere, path.string(), format);
    SurfaceMesh back = load_mesh(path.string());
    // STL stores three corners per face: welding must bring it back to the indexed mesh.
    EXPECT_EQ(back.vertices.rows(), sphere.vertices.rows()) << format;
    EXPECT_EQ(back.faces.rows(), sphere.faces.rows()) << format;
    EXPECT_NO_THROW(require_closed_manifold(back)) << format;
    EXPECT_NEAR(signed_volume(back), signed_volume(sphere), 1e-6) << format;
  }
}

TEST(MeshImport, ReadsOffText) {
  const fs::path path = temp_dir() / "tet.off";
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
  const fs::path path = temp_dir() / "garbage.stl";
  std::ofstream(path) << "this is not a mesh";
  EXPECT_THROW(load_mesh(path.string()), InvalidInput);
}

// Garbage named .stl is called what it is (not a size-limit error from its "triangle count").
TEST(MeshImport, BinaryStlMustBe84Plus50NBytes) {
  const SurfaceMesh cube = box(Vec3(0.1, 0.2, 0.3));
  const fs::path good = temp_dir() / "cube.stl";
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
      {garbage, "header says n = "},                 // a huge "n" from random bytes
      {bytes + "x", "but the file has " + std::to_string(bytes.size() + 1) + " bytes"},  // one byte too many
      {bytes.substr(0, bytes.size() - 50), "header says n = 12"},             // truncated
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
    const fs::path path = temp_dir() / "bad.stl";
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
    save_mesh(box(Vec3::Ones()), (temp_dir() / "x.abc").string(), "abc");
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "format");
  }
}
