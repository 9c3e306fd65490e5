// Writes the fuzzers' seed corpus: a tetrahedron in every mesh format (mesh/), GAP requests with
// every shape type (gap/) and an inline CBF scenario (cbf/). Usage: make_seeds SOURCE_DIR OUT_DIR.
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "mesh_bytes.hpp"

namespace fs = std::filesystem;
using nlohmann::json;
using namespace distlab::test::mesh_bytes;

namespace {

void put(const fs::path& p, const std::string& bytes) {
  fs::create_directories(p.parent_path());
  std::ofstream(p, std::ios::binary | std::ios::trunc) << bytes;
}

std::string read(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::ostringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

}  // namespace

// A failure to write the corpus ends on its uncaught exception (std::terminate prints it).
int main(int argc, char** argv) {  // NOLINT(bugprone-exception-escape)
  if (argc != 3) {
    std::cerr << "usage: make_seeds SOURCE_DIR OUT_DIR\n";
    return 2;
  }
  const fs::path src = argv[1], out = argv[2];
  const std::vector<float> v = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  const std::vector<std::vector<std::int64_t>> f = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  const std::vector<std::array<float, 9>> t = {{0, 0, 0, 0, 1, 0, 1, 0, 0}, {0, 0, 0, 1, 0, 0, 0, 0, 1}, {0, 0, 0, 0, 0, 1, 0, 1, 0}, {1, 0, 0, 0, 1, 0, 0, 0, 1}};
  put(out / "mesh" / "tetra.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n");
  put(out / "mesh" / "tetra.off", "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n");
  put(out / "mesh" / "tetra_ascii.ply",
      "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 4\n"
      "property list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n");
  put(out / "mesh" / "tetra_binary.ply", ply_binary("4", "4", v, f));
  put(out / "mesh" / "tetra_binary.stl", binary_stl(4, t, std::string(1, '\x01') + std::string(79, ' ')));
  std::string ascii = "solid t\n";
  for (const auto& tri : t) {
    ascii += "facet normal 0 0 0\nouter loop\n";
    for (int k = 0; k < 3; ++k)
      ascii += "vertex " + std::to_string(tri[3 * k]) + " " + std::to_string(tri[3 * k + 1]) + " " + std::to_string(tri[3 * k + 2]) + "\n";
    ascii += "endloop\nendfacet\n";
  }
  put(out / "mesh" / "tetra_ascii.stl", ascii + "endsolid t\n");
  put(out / "mesh" / "tetra.glb", glb(v, {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3}, 4, 12));
  if (fs::exists(src / "assets" / "cube.stl")) put(out / "mesh" / "cube.stl", read(src / "assets" / "cube.stl"));

  // GAP requests: the example file and every shape type.
  for (const auto& e : fs::directory_iterator(src / "assets" / "gap"))
    if (e.path().extension() == ".json") put(out / "gap" / e.path().filename(), read(e.path()));
  const std::vector<json> shapes = {
      {{"type", "box"}, {"size", {1, 0.6, 0.4}}, {"pose", {{"position", {0, 0, 0}}, {"quaternion", {1, 0, 0, 0}}}}},
      {{"type", "sphere"}, {"radius", 0.3}, {"pose", {{"position", {2, 0, 0}}}}},
      {{"type", "cylinder"}, {"radius", 0.2}, {"height", 0.5}, {"pose", {{"position", {0, 2, 0}}}}},
      {{"type", "capsule"}, {"radius", 0.2}, {"height", 0.5}, {"pose", {{"position", {0, 0, 2}}}}},
      {{"type", "polytope"}, {"A", {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}}}, {"b", {1, 1, 1, 1, 1, 1}}, {"weights", {1, 1, 1, 1, 1, 1}}, {"rho", {{"center", {0, 0, 0}}, {"radius", 3}}}},
      {{"type", "convex_hull"}, {"points", {{0, 0, 0}, {0.3, 0, 0}, {0, 0.3, 0}, {0, 0, 0.3}}}, {"pose", {{"position", {-2, 0, 0}}}}}};
  for (std::size_t i = 0; i < shapes.size(); ++i)
    put(out / "gap" / ("pair_" + std::to_string(i) + ".json"),
        json{{"a", shapes[i]}, {"b", shapes[(i + 1) % shapes.size()]}, {"params", {{"h", 0.1}, {"k", 2}, {"eps", 0.01}, {"sigma", 0.5}, {"solver", i % 2 ? "newton" : "fixed_point"}, {"max_iter", 50}, {"gradient", true}, {"validate", i % 3 == 0}}}}
            .dump());
  // Validation of a shape seen for the first time costs 10 s for a cylinder under the fuzz
  // instrumentation (70 ms in Release): the pairs above validate some shapes, the batch none.
  put(out / "gap" / "batch.json",
      json{{"pairs", {{{"a", shapes[0]}, {"b", shapes[1]}}, {{"a", shapes[2]}, {"b", shapes[3]}}}}, {"params", {{"validate", false}}}}
          .dump());

  // CBF: the corridor scenario inline, short.
  const fs::path corridor = src / "assets" / "scenarios" / "corridor.json";
  if (fs::exists(corridor)) {
    json sc = json::parse(read(corridor));
    sc["duration"] = 0.05;
    put(out / "cbf" / "corridor_inline.json", json{{"scenario", sc}, {"metric", "gap"}, {"params", {{"record_pairs", true}}}}.dump());
    put(out / "cbf" / "corridor_params.json",
        json{{"scenario", sc}, {"metric", "euclidean"}, {"params", {{"dt", 0.01}, {"margins", {{"gap", {{"obstacle", 0.002}}}}}, {"gap", {{"k", 3}}}}}}.dump());
  }
  return 0;
}
