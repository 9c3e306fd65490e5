// CGAL Mesh_3 tetrahedralisation of the inverted domain. The only Mesh_3 translation unit.
// Lazy refinement queues: a cell or facet destroyed by an insertion stays queued and is skipped
// when popped (CGAL's erase counters) instead of being erased from a Double_map, O(log n) per
// conflict-zone cell (meshing ~0.9x CPU). The queues stay sorted (worst first, ties in insertion
// order), so meshing stays deterministic; the unsorted (FIFO) ones mesh 8% more vertices. It
// changes the cell and vertex bases: it must precede every CGAL include here, and no other
// translation unit may instantiate Mesh_3.
// Two instantiations: Sequential_tag (threads 1, deterministic) and Parallel_tag (TBB; a mesh
// that differs from run to run, MeshingParams::threads).
#define CGAL_MESH_3_USE_LAZY_SORTED_REFINEMENT_QUEUE
// The parallel triangulation's vertex count in O(1) (the vertex budget reads it per insertion).
#define CGAL_CONCURRENT_COMPACT_CONTAINER_APPROXIMATE_SIZE 1
#include "mesh3_heap_queue.hpp"  // those queues as heaps: the same order, the same mesh

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Mesh_complex_3_in_triangulation_3.h>
#include <CGAL/Mesh_criteria_3.h>
#include <CGAL/Mesh_error_code.h>
#include <CGAL/Mesh_triangulation_3.h>
#include <CGAL/Polygon_mesh_processing/bbox.h>
#include <CGAL/Polygon_mesh_processing/remesh.h>
#include <CGAL/Polyhedral_mesh_domain_with_features_3.h>
#include <CGAL/Random.h>
#include <CGAL/Side_of_triangle_mesh.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/make_mesh_3.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <numbers>
#include <optional>
#include <unordered_map>
#include <vector>

#include "distlab/geometry/error.hpp"
#include "distlab/kelvin/surface_tools.hpp"
#include "distlab/kelvin/tet_mesh.hpp"
#include "distlab/mesh/cgal_surface.hpp"
#include "surface_distance.hpp"

namespace distlab::kelvin {
namespace {

using K = sizing::K;
using Polyhedron = sizing::Polyhedron;
using sizing::SurfaceDistance;
using Domain = CGAL::Polyhedral_mesh_domain_with_features_3<K, Polyhedron>;
template <class Concurrency>
struct Mesh3 {
  using Tr = typename CGAL::Mesh_triangulation_3<Domain, CGAL::Default, Concurrency>::type;
  using C3t3 = CGAL::Mesh_complex_3_in_triangulation_3<Tr, Domain::Corner_index, Domain::Curve_index>;
  using Criteria = CGAL::Mesh_criteria_3<Tr>;
};

// What ends a meshing attempt that went over one of its budgets (mesh_inverted_domain).
struct ProtectionBudgetExceeded {};
struct RefinementBudgetExceeded {};
// Work budget of one meshing attempt, counted in sizing-field evaluations (deterministic, unlike
// wall time): Mesh_3 evaluates the edge sizing only while it protects sharp edges, and every
// refinement step evaluates the facet/cell sizing, so the counts bound both stages.
// Counted atomically: the parallel mesher's threads share it (their counts vary from run to run,
// their bound does not).
struct Budget {
  std::atomic<long> edge_calls = 0, calls = 0;
  long max_edge_calls = 0, max_calls = 0;
  // The sizing never throws through Mesh_3: its parallel refinement holds cell locks an exception
  // leaves taken, and the other threads then retry them forever (a test hung in CI). It raises
  // Mesh_3's own stop flag (mesh_3_options' pointer_to_stop_atomic_boolean) with the first reason;
  // mesh_once throws that reason once make_mesh_3 has returned.
  enum class Reason : int { none,
                            cancelled,
                            protection,
                            refinement };
  std::atomic<bool> stop = false;
  std::atomic<Reason> reason = Reason::none;
  void request_stop(Reason r) {
    Reason none = Reason::none;
    reason.compare_exchange_strong(none, r);
    stop.store(true, std::memory_order_release);
  }
  void reset() {  // for another attempt
    edge_calls = calls = 0;
    reason = Reason::none;
    stop = false;
  }
  // Refinement's progress: every kReportEvery sizing evaluations, by their count against
  // expected_calls (MeshingParams::expected_vertices), from whichever thread counts it; never
  // back (a second attempt counts again), never past kMaxShare of the refinement's part before
  // it ends (the prediction may be short), and nothing thrown into Mesh_3.
  static constexpr long kReportEvery = 1L << 14;
  static constexpr double kMaxShare = 0.95;
  double expected_calls = 0;
  std::mutex report_mutex;
  double reported = 0;
  void report_refinement(long n, const Progress& progress) {
    if (!(expected_calls > 0) || n % kReportEvery != 0 || !progress.report) return;
    const std::unique_lock lock(report_mutex, std::try_to_lock);
    if (!lock.owns_lock()) return;
    const double f = 0.1 + 0.8 * std::min(kMaxShare, static_cast<double>(n) / expected_calls);
    if (f <= reported) return;
    reported = f;
    try {
      progress.report("mesh", f);
    } catch (...) {  // NOLINT(bugprone-empty-catch): a report is not worth a refinement left locked
    }
  }
  void throw_if_stopped() const {
    switch (reason.load()) {
      case Reason::cancelled:
        throw Cancelled();
      case Reason::protection:
        throw ProtectionBudgetExceeded{};
      case Reason::refinement:
        throw RefinementBudgetExceeded{};
      case Reason::none:
        break;
    }
  }
};

// The object's sharp edges (normals deviating by more than feature_angle) in x, where the
// exterior solution is singular (r^(2/3) at a right-angled edge): the graded sizing refines
// within kGradedEdgeRadius · l_x of them, measured at x = y/|y|².
sizing::EdgeDistance::Segments sharp_segments(const mesh::SurfaceMesh& inverted, double feature_angle) {
  mesh::SurfaceMesh x = inverted;  // the input surface again (eq. 5 is its own inverse)
  for (Eigen::Index v = 0; v < x.vertices.rows(); ++v) x.vertices.row(v) /= x.vertices.row(v).squaredNorm();
  auto point = [&x](int v) { return K::Point_3(x.vertices(v, 0), x.vertices(v, 1), x.vertices(v, 2)); };
  sizing::EdgeDistance::Segments segments;
  for (const auto& [a, b] : sharp_edges(x, feature_angle)) segments.emplace_back(point(a), point(b));
  return segments;
}

// l_y(y) = max(|y|² l_x, l_min), eq. 23 with the lower bound of Section IV-C-1; graded (g > 0):
// s_e · max(|y|² l_x + g d_y, l_min) (MeshingParams::grading). Mesh_3 calls it throughout
// refinement, so it is also where a cancellation request or a spent budget is noticed (and
// raises the Budget's stop flag).
struct Sizing {
  double lx, min_size, scale;
  const Progress* progress;
  double max_ratio = 0;  // if > 0: l_y ≤ max_ratio · |y|
  Budget* budget = nullptr;
  bool edge = false;
  // Grading (MeshingParams::grading): l_y grows by `grading` per unit distance in y from the
  // inverted surface (the domain's AABB tree), where V is harmonic and smooth.
  double grading = 0;
  const SurfaceDistance* surface = nullptr;
  // Graded sizing near sharp edges (kGradedEdgeRadius etc.): e_x the distance in x from them.
  const sizing::EdgeDistance* edges = nullptr;
  double edge_radius = 0;
  K::FT operator()(const K::Point_3& p, int, const Domain::Index&) const {
    if (progress->cancelled()) {
      budget->request_stop(Budget::Reason::cancelled);
    } else if (edge) {
      if (++budget->edge_calls > budget->max_edge_calls) budget->request_stop(Budget::Reason::protection);
    } else if (const long n = ++budget->calls; n > budget->max_calls) {
      budget->request_stop(Budget::Reason::refinement);
    } else {
      budget->report_refinement(n, *progress);
    }
    const double y2 = CGAL::to_double(p.x() * p.x() + p.y() * p.y() + p.z() * p.z());
    double l = lx * y2;
    if (grading > 0) l += grading * (*surface)(p);
    l = std::max(l, min_size);
    if (edges != nullptr && y2 > 0) {  // y = 0 is x at infinity, far from any edge
      const double ex = (*edges)(K::Point_3(p.x() / y2, p.y() / y2, p.z() / y2));
      l *= std::clamp(std::sqrt(ex / edge_radius), kGradedEdgeFloor, 1.0);
    }
    if (max_ratio > 0) l = std::min(l, max_ratio * std::sqrt(y2));
    return scale * l;
  }
};

double seconds_between(std::chrono::steady_clock::time_point a, std::chrono::steady_clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

std::string whole(double v) { return std::to_string(static_cast<long long>(std::llround(v))); }

// The polyhedron Mesh_3 meshes must follow the inverted surface, whose flat parts are sphere
// patches in y. Edges are bisected in x (Φ is its own inverse; midpoints stay on the input
// faces) until none is longer than max_length, then mapped to y. A flat triangle with edges ≤ c
// inscribed in a sphere of radius R deviates from it by at most c²/(6R): in x that is
// O(max_length²), below the element's own chord error when max_length ≤ l_x.
// Longest edge first (CGAL's remesher with splits only), so angles stay within half of the
// input's: a sliver's plane through three points of the sphere can be far from its tangent
// plane, and detect_features then finds sharp edges inside flat faces. (Splitting each edge into
// pieces and fanning, as PMP::split_long_edges does, left corner-to-corner triangles: the meshed
// boundary bulged 0.18 m out of the unit cube at every l_x.)
Polyhedron boundary_polyhedron(const mesh::SurfaceMesh& inverted, double max_length) {
  auto flip = [](const K::Point_3& p) {  // eq. 5 both ways
    const double r2 = p.x() * p.x() + p.y() * p.y() + p.z() * p.z();
    return K::Point_3(p.x() / r2, p.y() / r2, p.z() / r2);
  };
  Polyhedron poly = mesh::to_cgal_surface<K::Point_3>(inverted);
  for (auto v : poly.vertices()) poly.point(v) = flip(poly.point(v));
  namespace PMP = CGAL::Polygon_mesh_processing;
  // Splits edges longer than 4/3 of the target, i.e. max_length; no collapse, flip, smoothing.
  PMP::isotropic_remeshing(faces(poly), 0.75 * max_length, poly,
                           CGAL::parameters::number_of_iterations(1).do_collapse(false).do_flip(false).number_of_relaxation_steps(0).do_project(false));
  for (auto v : poly.vertices()) poly.point(v) = flip(poly.point(v));
  return poly;
}

// One Mesh_3 run; protect selects Mesh_3's sharp-edge protection (params.feature_angle).
template <class Concurrency>
TetMesh mesh_once(const mesh::SurfaceMesh& inverted, const MeshingParams& params, bool protect,
                  Budget& budget, const Progress& progress) {
  using Tr = typename Mesh3<Concurrency>::Tr;
  using C3t3 = typename Mesh3<Concurrency>::C3t3;
  using Criteria = typename Mesh3<Concurrency>::Criteria;
  Polyhedron poly = boundary_polyhedron(inverted, params.boundary_edge_length > 0 ? params.boundary_edge_length : params.lx);

  // Determinism: Mesh_3 and the domain draw from these generators; the default one is seeded
  // from the clock.
  const bool debug = std::getenv("DISTLAB_MESH_DEBUG") != nullptr;  // stage times and counts on stderr
  const auto t_domain = std::chrono::steady_clock::now();
  CGAL::get_default_random() = CGAL::Random(0);
  CGAL::Random rng(0);
  Domain domain(poly, &rng);
  if (protect) domain.detect_features(params.feature_angle);
  if (debug) std::fprintf(stderr, "mesh: domain %.3f s\n", seconds_between(t_domain, std::chrono::steady_clock::now()));
  progress("mesh", 0.1);

  // l_y is used as Mesh_3's own size bound (cell and facet circumradii, feature-edge length), as
  // the paper does: at equal l_x this gives vertex counts comparable to its Table I. The facet
  // distance bound is a tenth of it.
  Sizing size{params.lx, params.min_size, 1.0, &progress};
  size.budget = &budget;
  std::optional<SurfaceDistance> surface;
  if (params.grading > 0) {
    surface.emplace(poly);
    size.grading = params.grading;
    size.surface = &*surface;
  }
  std::optional<sizing::EdgeDistance> sharp;
  if (params.grading > 0 && params.feature_angle < 180) {
    sharp.emplace(sharp_segments(inverted, params.feature_angle), kGradedEdgeRadius * params.lx);
    if (!sharp->empty()) {
      size.edges = &*sharp;
      size.edge_radius = kGradedEdgeRadius * params.lx;
    }
  }
  // Protecting balls on sharp edges must stay small against the inverted edge curves (circles
  // through the origin, radius 1/(2d) for an edge at distance d from the centre): near the centre
  // |y|² l_x exceeds them and refinement never ends (seen on a 5 mm thick plate at l_x = 4 mm).
  Sizing edge = size;
  edge.max_ratio = 0.25;
  edge.edge = true;
  edge.grading = 0;  // edges lie on the surface
  Sizing distance = size;
  distance.scale = 0.1;
  namespace P = CGAL::parameters;
  Criteria criteria(P::edge_size = edge, P::facet_angle = 25.0, P::facet_size = size,
                    P::facet_distance = distance, P::cell_radius_edge_ratio = 3.0,
                    P::cell_size = size);
  // Exudation without a time limit (determinism) but with a target angle: sliver_bound = 0 asks
  // it to improve the worst cell until nothing improves, which took minutes (profiled).
  CGAL::Mesh_error_code error = CGAL::CGAL_MESH_3_NO_ERROR;
  const auto t_refine = std::chrono::steady_clock::now();
  C3t3 c3t3 = CGAL::make_mesh_3<C3t3>(
      domain, criteria, P::no_perturb(), P::no_exude(),
      P::mesh_3_options(P::maximal_number_of_vertices = params.max_vertices,
                        P::pointer_to_error_code = &error, P::pointer_to_stop_atomic_boolean = &budget.stop));
  const auto t_exude = std::chrono::steady_clock::now();
  const bool stopped = budget.stop.load();
  if (error == CGAL::CGAL_MESH_3_NO_ERROR && !stopped) CGAL::exude_mesh_3(c3t3, P::time_limit = 0, P::sliver_bound = 10);
  if (debug)
    std::fprintf(stderr, "mesh: threads=%d protect=%d stopped=%d edge_calls=%ld calls=%ld verts=%zu refine %.3f s exude %.3f s\n",
                 params.threads, protect ? 1 : 0, stopped ? 1 : 0, budget.edge_calls.load(), budget.calls.load(),
                 c3t3.triangulation().number_of_vertices(), seconds_between(t_refine, t_exude),
                 seconds_between(t_exude, std::chrono::steady_clock::now()));
  budget.throw_if_stopped();
  if (error == CGAL::CGAL_MESH_3_MAXIMAL_NUMBER_OF_VERTICES_REACHED)
    throw InvalidInput("lx", "lx is too small for this object: meshing reached the vertex budget of " +
                                 std::to_string(params.max_vertices) +
                                 " vertices (PrepareOptions::max_vertices); use a larger lx");
  progress("mesh", 0.9);
  const auto t_copy = std::chrono::steady_clock::now();

  // Indices are kept in the elements themselves, not in hash maps of handles (1 s of the cube's
  // 1.3M cells at l_x 0.02): a vertex's in its meshing_info (a double, exact for these integers;
  // refinement no longer reads it), a cell's in its subdomain index once in_domain has been read
  // from it. The complex is not used afterwards.
  Tr& tr = c3t3.triangulation();
  TetMesh out;
  out.points.resize(static_cast<Eigen::Index>(tr.number_of_vertices()), 3);
  int nv = 0;
  for (auto v = tr.finite_vertices_begin(); v != tr.finite_vertices_end(); ++v) {
    const auto& p = v->point().point();
    out.points.row(nv) << p.x(), p.y(), p.z();
    v->set_meshing_info(nv++);
  }
  out.points.conservativeResize(nv, 3);
  int nc = 0;
  for (auto c = tr.finite_cells_begin(); c != tr.finite_cells_end(); ++c) {
    out.in_domain.push_back(c3t3.is_in_complex(c) ? 1 : 0);
    c->set_subdomain_index(nc++);
  }
  out.tets.resize(nc, 4);
  out.neighbours.resize(nc, 4);
  for (auto c = tr.finite_cells_begin(); c != tr.finite_cells_end(); ++c) {
    const int i = c->subdomain_index();
    for (int k = 0; k < 4; ++k) {
      out.tets(i, k) = static_cast<int>(c->vertex(k)->meshing_info());
      const auto n = c->neighbor(k);
      out.neighbours(i, k) = tr.is_infinite(n) ? -1 : n->subdomain_index();
    }
  }
  const bool empty = std::count(out.in_domain.begin(), out.in_domain.end(), std::uint8_t{1}) == 0;
  if (debug) std::fprintf(stderr, "mesh: copy %.3f s\n", seconds_between(t_copy, std::chrono::steady_clock::now()));
  if (empty) throw InvalidInput("lx", "meshing produced no tetrahedra (is lx far larger than the object?)");
  progress("mesh", 1.0);
  return out;
}

}  // namespace

mesh::SurfaceMesh meshing_surface(const mesh::SurfaceMesh& inverted, const MeshingParams& params) {
  const Polyhedron poly = boundary_polyhedron(inverted, params.boundary_edge_length > 0 ? params.boundary_edge_length : params.lx);
  mesh::SurfaceMesh out;
  out.vertices.resize(static_cast<Eigen::Index>(poly.number_of_vertices()), 3);
  std::unordered_map<Polyhedron::Vertex_index, int> index;
  for (auto v : poly.vertices()) {
    const int i = static_cast<int>(index.size());
    index.emplace(v, i);
    const auto& p = poly.point(v);
    out.vertices.row(i) << p.x(), p.y(), p.z();
  }
  out.faces.resize(static_cast<Eigen::Index>(poly.number_of_faces()), 3);
  Eigen::Index f = 0;
  for (auto face : poly.faces()) {
    int k = 0;
    for (auto v : CGAL::vertices_around_face(poly.halfedge(face), poly)) out.faces(f, k++) = index.at(v);
    ++f;
  }
  return out;
}

SizingPrediction predict_vertices(const mesh::SurfaceMesh& inverted, const MeshingParams& params, const Progress& progress) {
  // The polyhedron the mesher meshes, its edges bisected to 2 l_x (the bulge of the sphere
  // patches matters little to a count).
  const Polyhedron poly = boundary_polyhedron(inverted, 2 * (params.boundary_edge_length > 0 ? params.boundary_edge_length : params.lx));
  const CGAL::Side_of_triangle_mesh<Polyhedron, K> side(poly);
  const SurfaceDistance distance(poly);
  double r_out = 0;
  for (auto v : poly.vertices()) r_out = std::max(r_out, std::sqrt(CGAL::to_double((poly.point(v) - CGAL::ORIGIN).squared_length())));
  // The largest |y| is 1/clearance, at the point of the surface nearest the centre, which the
  // bisected polyhedron's vertices may miss by a little: the margin keeps that sliver sampled.
  r_out *= 1.05;
  // l_y = |y|² l_x down to min_size, reached at |y| = r_min: below it equal-volume shells, above
  // it shells equal in log |y| (l_y⁻³ falls as |y|⁻⁶ there).
  const double r_min = std::min(std::sqrt(params.min_size / params.lx), r_out);
  constexpr int kInner = 16, kOuter = 96, kRays = 512;
  std::vector<std::pair<double, double>> shells;  // radius, volume per ray
  for (int i = 0; i < kInner; ++i) {
    const double a = r_min * std::cbrt(i / static_cast<double>(kInner)), b = r_min * std::cbrt((i + 1) / static_cast<double>(kInner));
    shells.emplace_back(r_min * std::cbrt((i + 0.5) / kInner), (b * b * b - a * a * a) / 3 * 4 * std::numbers::pi / kRays);
  }
  if (r_out > r_min)
    for (int i = 0; i < kOuter; ++i) {
      const double t = std::log(r_out / r_min) / kOuter;
      const double a = r_min * std::exp(i * t), b = r_min * std::exp((i + 1) * t);
      shells.emplace_back(std::sqrt(a * b), (b * b * b - a * a * a) / 3 * 4 * std::numbers::pi / kRays);
    }
  double paper = 0, graded = 0;
  for (int k = 0; k < kRays; ++k) {                      // Fibonacci directions
    if (k % 64 == 0) progress("mesh", 0.1 * k / kRays);  // the meshing's first tenth: Mesh_3 reports from 0.1
    else progress.check();
    const double z = 1 - (2 * k + 1) / static_cast<double>(kRays), rho = std::sqrt(1 - z * z), phi = k * std::numbers::pi * (3 - std::sqrt(5.0));
    for (const auto& [r, volume] : shells) {
      const K::Point_3 y(r * rho * std::cos(phi), r * rho * std::sin(phi), r * z);
      if (side(y) != CGAL::ON_BOUNDED_SIDE) continue;
      const double l = r * r * params.lx;
      paper += volume / std::pow(std::max(l, params.min_size), 3);
      graded += volume / std::pow(std::max(l + params.grading * distance(y), params.min_size), 3);
    }
  }
  double edges = 0;  // in x, where the graded sizing's edge refinement is measured
  if (params.feature_angle < 180)
    for (const K::Segment_3& e : sharp_segments(inverted, params.feature_angle)) edges += std::sqrt(CGAL::to_double(e.squared_length()));
  // ∫ dA_y / l_y² over the inverted surface, measured in x (eq. 5 is its own inverse): a face of
  // area A_x at |x| has l_y |x|² = max(l_x, min_size |x|²) there, so it adds A_x / that².
  double surface = 0;
  for (Eigen::Index f = 0; f < inverted.faces.rows(); ++f) {
    Vec3 x[3];
    for (int k = 0; k < 3; ++k) {
      const Vec3 y = inverted.vertices.row(inverted.faces(f, k)).transpose();
      x[k] = y / y.squaredNorm();
    }
    const double area = 0.5 * (x[1] - x[0]).cross(x[2] - x[0]).norm();
    const double size = std::max(params.lx, params.min_size * ((x[0] + x[1] + x[2]) / 3).squaredNorm());
    surface += area / (size * size);
  }
  SizingPrediction out;
  out.paper = kVerticesPerSizingIntegral * paper;
  out.graded = kVerticesPerSizingIntegral * graded + kGradedEdgeVerticesTypical * edges / params.lx;
  out.volume_paper = paper;
  out.volume_graded = graded;
  out.surface = surface;
  out.edge_length = edges;
  return out;
}

double eq23_vertex_bound(const MeshingParams& params) {
  // Once inside |y| < ρ (l_y = min_size), once outside (l_y⁻³ = (|y|² l_x)⁻³).
  const double rho = std::sqrt(params.min_size / params.lx);
  return kVerticesPerSizingIntegral * 2 * 4 * std::numbers::pi / 3 / std::pow(rho * params.lx, 3);
}

double choose_grading(const mesh::SurfaceMesh& inverted, const MeshingParams& params, const Progress& progress,
                      SizingPrediction* prediction) {
  if (!(eq23_vertex_bound(params) >= kAutoPredictFrom)) return 0;
  MeshingParams graded = params;
  graded.grading = kAutoGrading;
  const SizingPrediction p = predict_vertices(inverted, graded, progress);
  if (prediction != nullptr) *prediction = p;
  return p.graded <= kAutoGradedShare * p.paper ? kAutoGrading : 0;
}

// Sequential (threads 1) or CGAL's parallel refinement in an arena of params.threads threads.
TetMesh mesh_once(const mesh::SurfaceMesh& inverted, const MeshingParams& params, bool protect,
                  Budget& budget, const Progress& progress) {
  if (params.threads <= 1) return mesh_once<CGAL::Sequential_tag>(inverted, params, protect, budget, progress);
  tbb::task_arena arena(params.threads);
  return arena.execute([&] { return mesh_once<CGAL::Parallel_tag>(inverted, params, protect, budget, progress); });
}

TetMesh mesh_inverted_domain(const mesh::SurfaceMesh& inverted, const MeshingParams& params,
                             const Progress& progress, std::string* warning) {
  Budget budget;
  // Refinement: Mesh_3 evaluates the sizing field a few tens of times per inserted vertex.
  budget.max_calls = static_cast<long>(std::min<double>(params.max_refinement_evaluations, 4e18));
  budget.max_edge_calls = static_cast<long>(std::min<double>(params.max_protection_evaluations, 4e18));
  budget.expected_calls = params.expected_vertices * kSizingCallsPerVertex;
  // The graded sizing refines near the sharp edges itself (the edge factor) and protects none:
  // on the wrench, protecting balls cost 2-5x the meshing time and gave a field farther from a
  // fine reference with more vertices; and Mesh_3 finds them in y, where the sphere patches near
  // the centre fake a varying set of features (20, 28 or 174 curves as l_x varies).
  const bool protect = params.feature_angle < 180 && params.grading <= 0;
  if (protect) {
    try {
      return mesh_once(inverted, params, true, budget, progress);
    } catch (const ProtectionBudgetExceeded&) {
      // Thin features (protecting balls of opposite edges of a thin plate overlap and shrink
      // without end): mesh again without edge protection, and say so.
      if (warning)
        *warning = "sharp-edge protection (feature_angle " + whole(params.feature_angle) +
                   ") did not converge within " + whole(params.max_protection_evaluations) +
                   " steps (features thinner than the element size); meshed without edge protection "
                   "(feature_angle 180)";
    } catch (const RefinementBudgetExceeded&) {
      throw InvalidInput("lx", "lx is too small for this object: meshing exceeded its budget of " +
                                   whole(params.max_refinement_evaluations) +
                                   " refinement steps; use a larger lx");
    }
    budget.reset();
  }
  try {
    return mesh_once(inverted, params, false, budget, progress);
  } catch (const RefinementBudgetExceeded&) {
    throw InvalidInput("lx", "lx is too small for this object: meshing exceeded its budget of " +
                                 whole(params.max_refinement_evaluations) +
                                 " refinement steps; use a larger lx");
  }
}

}  // namespace distlab::kelvin
