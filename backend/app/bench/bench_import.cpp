// Cost of parsing a mesh in a child process (load_mesh_isolated) against parsing it in process
// (load_mesh), for the built-in assets and a 204,800-triangle binary STL:
//   distlab-bench-import --exe build/backend/app/distlab [--assets assets] [--runs 9]
// Prints one Markdown row per file: vertices, faces, median in-process and isolated times, overhead.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "../src/huge_page_heap.hpp"
#include "distlab/mesh/isolated_import.hpp"
#include "distlab/mesh/primitives.hpp"
#include "distlab/mesh/surface.hpp"

namespace fs = std::filesystem;
using namespace distlab;

namespace {

template <typename F>
double median_ms(int runs, F&& f) {
  std::vector<double> t;
  for (int i = 0; i < runs; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    t.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  distlab::app::use_huge_page_heap(argv);
  std::string exe, assets = "assets";
  int runs = 9;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i], v = argv[i + 1];
    if (a == "--exe") exe = v;
    else if (a == "--assets") assets = v;
    else if (a == "--runs") runs = std::max(1, std::stoi(v));
  }
  if (exe.empty()) {
    std::fprintf(stderr, "usage: distlab-bench-import --exe path/to/distlab [--assets DIR] [--runs N]\n");
    return 2;
  }
  std::vector<std::string> files;
  for (const char* name : {"cube", "knife", "wrench", "sphere"}) files.push_back(assets + "/" + name + ".stl");
  // Four disjoint icospheres: 2 x 81,920 + 2 x 20,480 = 204,800 triangles.
  mesh::SurfaceMesh big = mesh::icosphere(0.1, 6);
  big = mesh::merge(big, mesh::icosphere(0.1, 6, Vec3(0.3, 0, 0)));
  big = mesh::merge(big, mesh::icosphere(0.1, 5, Vec3(0, 0.3, 0)));
  big = mesh::merge(big, mesh::icosphere(0.1, 5, Vec3(0.3, 0.3, 0)));
  const fs::path big_path = fs::temp_directory_path() / "distlab-bench-import-204800.stl";
  mesh::save_mesh(big, big_path.string(), "stl");
  files.push_back(big_path.string());

  const mesh::ImportLimits limits;
  std::printf("| file | vertices | triangles | in process (ms) | child process (ms) | overhead (ms) |\n");
  std::printf("|---|---:|---:|---:|---:|---:|\n");
  for (const std::string& file : files) {
    const mesh::SurfaceMesh m = mesh::load_mesh(file);
    const double local = median_ms(runs, [&] { mesh::load_mesh(file); });
    const double child = median_ms(runs, [&] { mesh::load_mesh_isolated(file, "body", "file", limits, exe); });
    std::printf("| %s | %ld | %ld | %.2f | %.2f | %.2f |\n", fs::path(file).filename().c_str(),
                static_cast<long>(m.vertices.rows()), static_cast<long>(m.faces.rows()), local, child, child - local);
  }
  fs::remove(big_path);
  return 0;
}
