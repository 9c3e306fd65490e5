// STL import: ASCII or binary decided by the binary size formula and the ASCII keywords (never the
// first bytes alone), and every refusal says what is wrong with the file.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "distlab/geometry/error.hpp"
#include "distlab/mesh/primitives.hpp"
#include "distlab/mesh/surface.hpp"
#include "temp_dir.hpp"

namespace fs = std::filesystem;
using namespace distlab;
using namespace distlab::mesh;
using distlab::test::write_temp_file;

namespace {

// Two facets sharing an edge, after a first line given by the test.
std::string ascii(const std::string& first_line, const std::string& last_line = "endsolid") {
  return first_line +
         "\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 1 0 0\n   vertex 0 1 0\n  endloop\n endfacet\n"
         " facet normal 0 0 1\n  outer loop\n   vertex 1 0 0\n   vertex 1 1 0\n   vertex 0 1 0\n  endloop\n endfacet\n" +
         last_line + "\n";
}

void expect_two_facets(const SurfaceMesh& m) {
  ASSERT_EQ(m.vertices.rows(), 4);  // corners by first appearance: (0,0), (1,0), (0,1), (1,1)
  EXPECT_EQ(m.vertices.row(3), Eigen::RowVector3d(1, 1, 0));
  ASSERT_EQ(m.faces.rows(), 2);
  EXPECT_EQ(m.faces.row(1), Eigen::RowVector3i(1, 3, 2));
}

std::string refusal(const std::string& name, const std::string& bytes) {
  try {
    load_mesh(write_temp_file(name, bytes).string(), "upload");
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "upload");
    return e.what();
  }
  ADD_FAILURE() << name << " was accepted";
  return {};
}

std::string binary_box(const std::string& header_start) {
  const fs::path path = write_temp_file("box.stl", "");
  save_mesh(box(Eigen::Vector3d(0.1, 0.2, 0.3)), path.string(), "stl");
  std::ifstream in(path, std::ios::binary);
  std::string bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  bytes.replace(0, header_start.size(), header_start);
  return bytes;
}

}  // namespace

// ASCII files whose "solid" line is not "solid name\n": a tab (assimp's sphereWithHole.stl), a
// name with spaces, none, capitals, and several solids.
TEST(StlImport, AsciiIsReadWhateverFollowsSolid) {
  expect_two_facets(load_mesh(write_temp_file("tab.stl", ascii("solid\ttiny sphere")).string()));
  expect_two_facets(load_mesh(write_temp_file("spaces.stl", ascii("solid my part, rev 2", "endsolid my part, rev 2")).string()));
  expect_two_facets(load_mesh(write_temp_file("bare.stl", ascii("solid")).string()));
  expect_two_facets(load_mesh(write_temp_file("crlf.stl", ascii("  solid x\r")).string()));
  expect_two_facets(load_mesh(write_temp_file("caps.stl", ascii("SOLID X", "ENDSOLID X")).string()));
  const std::string two = ascii("solid a") + "solid empty\nendsolid empty\n";
  expect_two_facets(load_mesh(write_temp_file("two.stl", two).string()));
}

// A binary STL whose 80-byte header starts with "solid", even "solid x\nfacet normal ...", is
// binary: its size is 84 + 50·n for its count n.
TEST(StlImport, BinaryWithASolidHeaderIsBinary) {
  for (const std::string header : {"solid box", "solid x\nfacet normal 0 0 1\nouter loop\n"}) {
    const std::string bytes = binary_box(header);
    EXPECT_EQ(binary_stl_triangles(bytes, "body"), 12u);
    const SurfaceMesh m = load_mesh(write_temp_file("solid_header.stl", bytes).string());
    EXPECT_EQ(m.vertices.rows(), 8);
    EXPECT_EQ(m.faces.rows(), 12);
    EXPECT_NEAR(signed_volume(m), 0.1 * 0.2 * 0.3, 1e-9);
  }
}

// A truncated binary file is called that, with its header's count and both sizes, whether or not
// its header starts with "solid"; never a unit or coordinate problem.
TEST(StlImport, TruncatedBinarySaysTheSizeDoesNotMatch) {
  for (const std::string header : {"binary box", "solid box"}) {
    const std::string bytes = binary_box(header).substr(0, 84 + 50 * 12 - 50);
    const std::string why = refusal("truncated.stl", bytes);
    EXPECT_NE(why.find("header says n = 12, i.e. 684 bytes, but the file has 634 bytes"), std::string::npos) << why;
    EXPECT_EQ(why.find("unit"), std::string::npos) << why;
    if (header == "solid box") {
      EXPECT_NE(why.find("starts with \"solid\" like an ASCII STL but holds binary bytes"), std::string::npos) << why;
    }
  }
}

// An ASCII file that breaks the format is refused naming the line and what was expected there.
TEST(StlImport, BadAsciiNamesTheLine) {
  const std::string good = ascii("solid\tpart");
  const auto replace = [&](const std::string& from, const std::string& to) {
    std::string s = good;
    s.replace(s.find(from), from.size(), to);
    return s;
  };
  const std::vector<std::pair<std::string, std::string>> cases = {
      {replace("vertex 1 1 0", "vertex 1 one 0"), "ASCII STL, line 12: expected a vertex coordinate, found 'one'"},
      {good.substr(0, good.rfind("endsolid")), "expected \"endsolid\" (the file is truncated), found the end of the file"},
      {replace("  outer loop\n   vertex 1 0 0", "  outer loop\n   vertex 5 5 5\n   vertex 1 0 0"), "ASCII STL, line 15: facet 1 has 4 vertices; an STL facet is a triangle"},
      {replace(" facet normal 0 0 1\n  outer loop\n   vertex 1 0 0", " facet normal 0 0 1\n  outr loop\n   vertex 1 0 0"), "ASCII STL, line 10: expected \"outer\", found 'outr'"},
      {good + "garbage\n", "ASCII STL, line 17: expected \"solid\" or the end of the file after \"endsolid\", found 'garbage'"},
      {"solid nothing\nendsolid nothing\n", "the ASCII STL has no facets"},
      {replace("vertex 1 1 0", "vertex 1 nan 0"), "ASCII STL, line 12: a vertex has a non-finite coordinate"},
  };
  for (const auto& [text, says] : cases) {
    const std::string why = refusal("bad.stl", text);
    EXPECT_NE(why.find(says), std::string::npos) << why;
  }
}

// Every STL of assimp's test models loads, sphereWithHole.stl ("solid\t...") as ASCII.
TEST(StlImport, AssimpStlModelsLoad) {
  const fs::path root = "/usr/share/assimp/models/STL";
  if (!fs::is_directory(root)) GTEST_SKIP() << "assimp-testmodels is not installed";
  for (const auto& e : fs::directory_iterator(root)) {
    if (e.path().extension() != ".stl" && e.path().extension() != ".STL") continue;
    SCOPED_TRACE(e.path().string());
    EXPECT_GT(load_mesh(e.path().string()).faces.rows(), 0);
  }
  const SurfaceMesh sphere = load_mesh((root / "sphereWithHole.stl").string());
  EXPECT_GT(sphere.faces.rows(), 100);
  EXPECT_LT(sphere.vertices.cwiseAbs().maxCoeff(), 10.0);  // ASCII coordinates, not float bits of text
}
