// Simplifying a generated scan (mesh::simplify) and its reported one-sided Hausdorff distance
// (mesh::hausdorff_distance), beside the distance a user would otherwise call: CGAL's
// bounded_error_Hausdorff_distance on the whole input at the same error:
//   distlab-bench-simplify [--faces 2000000] [--target 100000] [--baseline-max 500000]
// The scan is mesh::rippled_torus (bumps and a ripple finer than its grid: a scan's noise). Prints a Markdown row per size and one JSON line per size; peak memory is the
// process's VmHWM, so the baseline runs last.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/distance.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "../src/huge_page_heap.hpp"
#include "distlab/mesh/hausdorff.hpp"
#include "distlab/mesh/primitives.hpp"
#include "distlab/mesh/simplify.hpp"

using namespace distlab;

namespace {

CGAL::Surface_mesh<CGAL::Epick::Point_3> to_cgal(const mesh::SurfaceMesh& m) {
  CGAL::Surface_mesh<CGAL::Epick::Point_3> sm;
  std::vector<CGAL::SM_Vertex_index> v;
  for (Eigen::Index i = 0; i < m.vertices.rows(); ++i) v.push_back(sm.add_vertex({m.vertices(i, 0), m.vertices(i, 1), m.vertices(i, 2)}));
  for (Eigen::Index f = 0; f < m.faces.rows(); ++f) sm.add_face(v[m.faces(f, 0)], v[m.faces(f, 1)], v[m.faces(f, 2)]);
  return sm;
}

double peak_mb() {
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);)
    if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024;
  return 0;
}

template <typename F>
double seconds(F&& f) {
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

int main(int argc, char** argv) {  // NOLINT(bugprone-exception-escape): a benchmark may stop on a bad argument
  distlab::app::use_huge_page_heap(argv);
  long faces = 2000000, target = 100000, baseline_max = 500000;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    const long v = std::stol(argv[i + 1]);
    if (a == "--faces") faces = v;
    else if (a == "--target") target = v;
    else if (a == "--baseline-max") baseline_max = v;
  }
  const int n = static_cast<int>(std::lround(std::sqrt(faces / 2.0)));
  const mesh::SurfaceMesh input = mesh::rippled_torus(n);
  mesh::SimplifyResult r;
  const double t_simplify = seconds([&] { r = mesh::simplify(input, static_cast<std::size_t>(target)); });
  mesh::HausdorffDistance h;
  const double t_distance = seconds([&] { h = mesh::hausdorff_distance(input, r.surface, 0.05, "distance"); });
  const double mb = peak_mb();
  // Pairs of the result's faces that intersect (a preparation refuses any).
  std::vector<std::pair<CGAL::SM_Face_index, CGAL::SM_Face_index>> crossing;
  CGAL::Polygon_mesh_processing::self_intersections(to_cgal(r.surface), std::back_inserter(crossing));
  double t_cgal = -1, cgal = -1;
  if (input.faces.rows() <= baseline_max) {
    const auto a = to_cgal(input), b = to_cgal(r.surface);
    t_cgal = seconds([&] { cgal = CGAL::Polygon_mesh_processing::bounded_error_Hausdorff_distance<CGAL::Sequential_tag>(a, b, h.error); });
  }
  std::printf(
      "| input faces | result faces | simplify s (with its distance) | distance s | refined faces | distance mm | ± mm | "
      "CGAL whole s | CGAL mm | peak MB before CGAL | self-intersecting pairs |\n|---|---|---|---|---|---|---|---|---|---|---|\n");
  std::printf("| %ld | %ld | %.1f | %.2f | %ld | %.4f | %.4f | %s | %s | %.0f | %zu |\n", static_cast<long>(input.faces.rows()),
              static_cast<long>(r.surface.faces.rows()), t_simplify, t_distance, h.faces_refined, 1e3 * h.value, 1e3 * h.error,
              t_cgal < 0 ? "—" : std::to_string(t_cgal).substr(0, 6).c_str(), cgal < 0 ? "—" : std::to_string(1e3 * cgal).substr(0, 6).c_str(), mb, crossing.size());
  std::printf(
      "{\"input_faces\": %ld, \"result_faces\": %ld, \"simplify_seconds\": %.3f, \"distance_seconds\": %.3f, \"faces_refined\": %ld, "
      "\"distance\": %.6g, \"error\": %.3g, \"cgal_seconds\": %.3f, \"cgal_distance\": %.6g, \"peak_mb\": %.0f, \"self_intersections\": %zu}\n",
      static_cast<long>(input.faces.rows()), static_cast<long>(r.surface.faces.rows()), t_simplify, t_distance, h.faces_refined,
      h.value, h.error, t_cgal, cgal, mb, crossing.size());
}
