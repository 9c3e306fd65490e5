// Time and one-sided Hausdorff distances of mesh::wrap (CGAL 3D Alpha Wrapping) and mesh::fix
// on real meshes and a generated 200k-triangle sphere (icosphere level 7: 327,680 triangles cut
// to the first 200,000, an open surface):
//   distlab-bench-wrap [--runs 3] FILE...
// α is the default (bounding-box diagonal / 20) and diagonal / 50. Prints a Markdown row per case
// (median time of the runs) and one JSON line per case.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "../src/huge_page_heap.hpp"
#include "distlab/mesh/primitives.hpp"
#include "distlab/mesh/repair.hpp"
#include "distlab/mesh/surface.hpp"

using namespace distlab;

int main(int argc, char** argv) {
  distlab::app::use_huge_page_heap(argv);
  int runs = 3;
  std::vector<std::pair<std::string, mesh::SurfaceMesh>> cases;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--runs" && i + 1 < argc) {
      runs = std::stoi(argv[++i]);
      continue;
    }
    cases.emplace_back(std::filesystem::path(a).filename().string(), mesh::load_mesh(a));
  }
  mesh::SurfaceMesh big = mesh::icosphere(1.0, 7);
  big.faces.conservativeResize(200000, 3);
  cases.emplace_back("icosphere-200k (open)", big);
  std::printf("| mesh | triangles | α / diagonal | wrap triangles | median s | input→wrap / diag | wrap→input / diag |\n|---|---|---|---|---|---|---|\n");
  for (const auto& [name, m] : cases) {
    const double d = (m.vertices.colwise().maxCoeff() - m.vertices.colwise().minCoeff()).norm();
    for (const double ratio : {20.0, 50.0}) {
      std::vector<double> t;
      mesh::RepairResult r;
      for (int k = 0; k < runs; ++k) {
        const auto t0 = std::chrono::steady_clock::now();
        r = mesh::wrap(m, {d / ratio, 0}, mesh::WrapBudget{10000000, 1e9, 1e9});  // unbounded: the benchmark times the wrap
        t.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      }
      std::sort(t.begin(), t.end());
      std::printf("| %s | %ld | 1/%.0f | %ld | %.3f | %.4f | %.4f |\n", name.c_str(), static_cast<long>(m.faces.rows()), ratio,
                  static_cast<long>(r.surface.faces.rows()), t[t.size() / 2], r.input_to_result / d, r.result_to_input / d);
      std::printf(
          "{\"mesh\": \"%s\", \"triangles\": %ld, \"alpha\": %.6g, \"offset\": %.6g, \"wrap_triangles\": %ld, \"seconds\": %.4f, "
          "\"input_to_wrap\": %.6g, \"wrap_to_input\": %.6g, \"diagonal\": %.6g}\n",
          name.c_str(), static_cast<long>(m.faces.rows()), r.alpha, r.offset, static_cast<long>(r.surface.faces.rows()),
          t[t.size() / 2], r.input_to_result, r.result_to_input, d);
    }
  }
}
