// Import, welding and export round trips through assimp for every supported format.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

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

TEST(MeshExport, UnknownFormatIsRefused) {
  try {
    save_mesh(box(Vec3::Ones()), (temp_dir() / "x.abc").string(), "abc");
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "format");
  }
}
