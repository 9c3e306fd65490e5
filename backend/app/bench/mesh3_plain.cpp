// distlab-mesh3-plain: the baseline of distlab-bench-kelvin's mesher table (issue 38). CGAL Mesh_3
// as it comes (its own refinement queues) with the paper's sizing, eq. 23, l_y = max(|y|² l_x,
// l_min), on a polyhedron given as an OFF file (the surface distlab's mesher meshes,
// kelvin::meshing_surface): the same criteria, seeds and optimisation as the mesher (mesher.cpp),
// without what distlab adds (lazy sorted queues, graded sizing, budgets, progress, threads).
// A process of its own: mesher.cpp changes Mesh_3's cell and vertex bases
// (CGAL_MESH_3_USE_LAZY_SORTED_REFINEMENT_QUEUE), so both cannot be instantiated in one program.
// usage: distlab-mesh3-plain FILE.off LX MIN_SIZE FEATURE_ANGLE [THREADS]
// THREADS > 1: CGAL's Parallel_tag (TBB) on that many threads, if CGAL was built with TBB.
// Prints one JSON line: n_verts, n_cells (in the complex), t_domain, t_refine, t_exude, t_mesh (s).
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Mesh_complex_3_in_triangulation_3.h>
#include <CGAL/Mesh_criteria_3.h>
#include <CGAL/Mesh_triangulation_3.h>
#include <CGAL/Polyhedral_mesh_domain_with_features_3.h>
#include <CGAL/Random.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/make_mesh_3.h>

#ifdef CGAL_LINKED_WITH_TBB
#include <tbb/global_control.h>
#endif

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

#include "../src/huge_page_heap.hpp"

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Polyhedron = CGAL::Surface_mesh<K::Point_3>;
using Domain = CGAL::Polyhedral_mesh_domain_with_features_3<K, Polyhedron>;
using Clock = std::chrono::steady_clock;

double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Eq. 23 with its lower bound; times `scale` (the facet distance is a tenth of it), at most
// max_ratio · |y| if given (the mesher's bound on protecting balls near the centre).
struct Eq23 {
  double lx, min_size, scale = 1, max_ratio = 0;
  K::FT operator()(const K::Point_3& p, int, const Domain::Index&) const {
    const double y2 = p.x() * p.x() + p.y() * p.y() + p.z() * p.z();
    double l = std::max(lx * y2, min_size);
    if (max_ratio > 0) l = std::min(l, max_ratio * std::sqrt(y2));
    return scale * l;
  }
};

template <class Concurrency>
int run(const Polyhedron& poly, double lx, double min_size, double feature_angle, int threads) {
  using Tr = typename CGAL::Mesh_triangulation_3<Domain, CGAL::Default, Concurrency>::type;
  using C3t3 = CGAL::Mesh_complex_3_in_triangulation_3<Tr, Domain::Corner_index, Domain::Curve_index>;
  using Criteria = CGAL::Mesh_criteria_3<Tr>;
  const auto t0 = Clock::now();
  CGAL::get_default_random() = CGAL::Random(0);
  CGAL::Random rng(0);
  Domain domain(poly, &rng);
  if (feature_angle < 180) domain.detect_features(feature_angle);
  const double t_domain = since(t0);
  Eq23 size{lx, min_size}, edge{lx, min_size, 1, 0.25}, distance{lx, min_size, 0.1};
  namespace P = CGAL::parameters;
  Criteria criteria(P::edge_size = edge, P::facet_angle = 25.0, P::facet_size = size, P::facet_distance = distance,
                    P::cell_radius_edge_ratio = 3.0, P::cell_size = size);
  auto t1 = Clock::now();
  C3t3 c3t3 = CGAL::make_mesh_3<C3t3>(domain, criteria, P::no_perturb(), P::no_exude());
  const double t_refine = since(t1);
  t1 = Clock::now();
  CGAL::exude_mesh_3(c3t3, P::time_limit = 0, P::sliver_bound = 10);
  const double t_exude = since(t1);
  std::printf(
      "{\"n_verts\": %zu, \"n_cells\": %zu, \"threads\": %d, \"t_domain\": %.6f, \"t_refine\": %.6f, \"t_exude\": %.6f, "
      "\"t_mesh\": %.6f}\n",
      c3t3.triangulation().number_of_vertices(), c3t3.number_of_cells_in_complex(), threads, t_domain, t_refine, t_exude,
      since(t0));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {          // NOLINT(bugprone-exception-escape): a failing baseline ends on its exception
  distlab::app::use_huge_page_heap(argv);  // as ours: the same heap on both sides
  if (argc < 5) {
    std::fputs("usage: distlab-mesh3-plain FILE.off LX MIN_SIZE FEATURE_ANGLE [THREADS]\n", stderr);
    return 2;
  }
  Polyhedron poly;
  std::ifstream in(argv[1]);
  if (!(in >> poly) || poly.is_empty()) {
    std::fprintf(stderr, "cannot read the OFF file %s\n", argv[1]);
    return 2;
  }
  const double lx = std::stod(argv[2]), min_size = std::stod(argv[3]), feature_angle = std::stod(argv[4]);
  const int threads = argc > 5 ? std::stoi(argv[5]) : 1;
#ifdef CGAL_LINKED_WITH_TBB
  if (threads > 1 || threads < 0) {  // -N: Parallel_tag on N threads, also N = 1
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(std::abs(threads)));
    return run<CGAL::Parallel_tag>(poly, lx, min_size, feature_angle, threads);
  }
#else
  if (threads > 1) {
    std::fputs("this build has no TBB: CGAL's Parallel_tag is not available\n", stderr);
    return 2;
  }
#endif
  return run<CGAL::Sequential_tag>(poly, lx, min_size, feature_angle, 1);
}
