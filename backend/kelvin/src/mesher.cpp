// CGAL Mesh_3 tetrahedralisation of the inverted domain. The only Mesh_3 translation unit.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Mesh_complex_3_in_triangulation_3.h>
#include <CGAL/Mesh_criteria_3.h>
#include <CGAL/Mesh_triangulation_3.h>
#include <CGAL/Polyhedral_mesh_domain_with_features_3.h>
#include <CGAL/Random.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/make_mesh_3.h>

#include <unordered_map>

#include "distlab/geometry/error.hpp"
#include "distlab/kelvin/tet_mesh.hpp"

namespace distlab::kelvin {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Polyhedron = CGAL::Surface_mesh<K::Point_3>;
using Domain = CGAL::Polyhedral_mesh_domain_with_features_3<K, Polyhedron>;
using Tr = CGAL::Mesh_triangulation_3<Domain, CGAL::Default, CGAL::Sequential_tag>::type;
using C3t3 = CGAL::Mesh_complex_3_in_triangulation_3<Tr, Domain::Corner_index, Domain::Curve_index>;
using Criteria = CGAL::Mesh_criteria_3<Tr>;

// l_y(y) = max(|y|² l_x, l_min), eq. 23 with the lower bound of Section IV-C-1. Mesh_3 calls it
// throughout refinement, so it is also where a cancellation request is noticed.
struct Sizing {
  double lx, min_size, scale;
  const Progress* progress;
  double max_ratio = 0;  // if > 0: l_y ≤ max_ratio · |y|
  K::FT operator()(const K::Point_3& p, int, const Domain::Index&) const {
    progress->check();
    const double y2 = CGAL::to_double(p.x() * p.x() + p.y() * p.y() + p.z() * p.z());
    double l = std::max(lx * y2, min_size);
    if (max_ratio > 0) l = std::min(l, max_ratio * std::sqrt(y2));
    return scale * l;
  }
};

}  // namespace

TetMesh mesh_inverted_domain(const mesh::SurfaceMesh& inverted, const MeshingParams& params,
                             const Progress& progress) {
  Polyhedron poly;
  std::vector<Polyhedron::Vertex_index> vi;
  for (Eigen::Index v = 0; v < inverted.vertices.rows(); ++v)
    vi.push_back(poly.add_vertex(K::Point_3(inverted.vertices(v, 0), inverted.vertices(v, 1),
                                            inverted.vertices(v, 2))));
  for (Eigen::Index f = 0; f < inverted.faces.rows(); ++f)
    poly.add_face(vi[static_cast<size_t>(inverted.faces(f, 0))], vi[static_cast<size_t>(inverted.faces(f, 1))],
                  vi[static_cast<size_t>(inverted.faces(f, 2))]);

  // Determinism: Mesh_3 and the domain draw from these generators; the default one is seeded
  // from the clock.
  CGAL::get_default_random() = CGAL::Random(0);
  CGAL::Random rng(0);
  Domain domain(poly, &rng);
  domain.detect_features(params.feature_angle);
  progress("mesh", 0.1);

  // l_y is used as Mesh_3's own size bound (cell and facet circumradii, feature-edge length), as
  // the paper does: at equal l_x this gives vertex counts comparable to its Table I. The facet
  // distance bound is a tenth of it.
  const Sizing size{params.lx, params.min_size, 1.0, &progress};
  // Protecting balls on sharp edges must stay small against the inverted edge curves (circles
  // through the origin, radius 1/(2d) for an edge at distance d from the centre): near the centre
  // |y|² l_x exceeds them and refinement never ends (seen on a 5 mm thick plate at l_x = 4 mm).
  Sizing edge = size;
  edge.max_ratio = 0.25;
  const Sizing distance{params.lx, params.min_size, 0.1, &progress};
  namespace P = CGAL::parameters;
  Criteria criteria(P::edge_size = edge, P::facet_angle = 25.0, P::facet_size = size,
                    P::facet_distance = distance, P::cell_radius_edge_ratio = 3.0,
                    P::cell_size = size);
  // Exudation without a time limit (determinism) but with a target angle: sliver_bound = 0 asks
  // it to improve the worst cell until nothing improves, which took minutes (profiled).
  C3t3 c3t3 = CGAL::make_mesh_3<C3t3>(domain, criteria, P::no_perturb(),
                                      P::exude(P::time_limit = 0, P::sliver_bound = 10));
  progress("mesh", 0.9);

  const Tr& tr = c3t3.triangulation();
  std::unordered_map<Tr::Vertex_handle, int> vindex;
  TetMesh out;
  out.points.resize(static_cast<Eigen::Index>(tr.number_of_vertices()), 3);
  int nv = 0;
  for (auto v = tr.finite_vertices_begin(); v != tr.finite_vertices_end(); ++v) {
    const auto& p = v->point().point();
    out.points.row(nv) << p.x(), p.y(), p.z();
    vindex.emplace(v, nv++);
  }
  out.points.conservativeResize(nv, 3);
  std::unordered_map<Tr::Cell_handle, int> cindex;
  int nc = 0;
  for (auto c = tr.finite_cells_begin(); c != tr.finite_cells_end(); ++c) cindex.emplace(c, nc++);
  out.tets.resize(nc, 4);
  out.neighbours.resize(nc, 4);
  out.in_domain.resize(static_cast<size_t>(nc));
  for (auto c = tr.finite_cells_begin(); c != tr.finite_cells_end(); ++c) {
    const int i = cindex.at(c);
    for (int k = 0; k < 4; ++k) {
      out.tets(i, k) = vindex.at(c->vertex(k));
      const auto n = c->neighbor(k);
      out.neighbours(i, k) = tr.is_infinite(n) ? -1 : cindex.at(n);
    }
    out.in_domain[static_cast<size_t>(i)] = c3t3.is_in_complex(c) ? 1 : 0;
  }
  if (c3t3.number_of_cells_in_complex() == 0)
    throw InvalidInput("lx", "meshing produced no tetrahedra (is lx far larger than the object?)");
  progress("mesh", 1.0);
  return out;
}

}  // namespace distlab::kelvin
