#pragma once
// The semantics-aware distance h(x) of one object (kelvin-semantics-aware-distance.txt):
// prepare once (invert, tetrahedralise, assemble, factor), then set σ and query h and ∇h.
#include <Eigen/Sparse>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "distlab/geometry/types.hpp"
#include "distlab/kelvin/progress.hpp"
#include "distlab/kelvin/sigma.hpp"
#include "distlab/kelvin/store.hpp"
#include "distlab/kelvin/tet_mesh.hpp"
#include "distlab/mesh/surface.hpp"

namespace distlab::kelvin {

inline constexpr double kMaxFarRadius = 1000;  // PrepareOptions::far_radius is in [0.5, this]
inline constexpr double kMaxGrading = 1;       // PrepareOptions::grading is in [0, this]
inline constexpr int kMaxMeshThreads = 256;    // PrepareOptions::mesh_threads is in [0, this]

struct PrepareOptions {
  double lx = 0.1;             // exterior element size l_x, metres (eq. 23)
  std::optional<Vec3> centre;  // inversion centre; default: a deep interior point
  // l_y is bounded below by its value at |x| = far_radius · (largest centre-to-surface distance):
  // beyond that radius the exterior mesh coarsens quadratically instead of staying at l_x.
  double far_radius = 1.0;
  // Sharp edges (face normals deviating by more than this, degrees; none at 180): eq. 23 has
  // Mesh_3 protect them (their meshed curves follow the edges; the 5 mm wrench plate needed the
  // protection budget below), the graded sizing refines near them instead (MeshingParams). Without
  // protection edges are rounded at the element scale but boundary vertices stay on the surface.
  double feature_angle = 60.0;
  // 0: the paper's sizing, eq. 23. > 0: the graded sizing (MeshingParams::grading): the element
  // size grows by `grading` per unit distance (in y) from the inverted surface and shrinks near
  // sharp edges; fewer vertices at equal accuracy (bench_kelvin --sizing-table).
  // Not given: chosen per object and l_x by choose_grading (tet_mesh.hpp), eq. 23 or the graded
  // sizing kAutoGrading, whichever is predicted to need clearly fewer vertices; Stats::grading
  // says which.
  std::optional<double> grading;
  // Meshing limits, so that no request can hang (all deterministic counts, no wall time):
  // - max_vertices: refused up front (InvalidInput "lx") when the sizing's predicted vertex count
  //   (predict_vertices' terms, as predict_preparation's without its trial) exceeds it, and Mesh_3
  //   stops with the same error when its triangulation reaches it;
  // - max_protection_steps: sizing evaluations allowed for eq. 23's edge protection (0: automatic,
  //   30 × the estimated number of protecting balls + 2000); beyond it the features are thinner
  //   than the elements (protecting balls shrink over and over and the refinement explodes, as
  //   on the 5 mm wrench plate at l_x = 4 mm: 194k vertices, 330 s) and the object is meshed
  //   again without protection, with a warning in Stats::warnings;
  // - max_refinement_steps: sizing evaluations allowed for refinement (InvalidInput "lx" beyond).
  std::size_t max_vertices = 1'000'000;
  double max_protection_steps = 0;
  double max_refinement_steps = 1e8;
  // Meshing threads (MeshingParams::threads): 1, a mesh the same bit for bit on every run; n > 1,
  // CGAL's parallel refinement on n threads, faster, a mesh (and field) that differs from run to
  // run within the mesh's accuracy. CGAL 5.5's parallel refinement crashes its process now and
  // then (isolated_mesher.hpp), so with a mesh_worker it runs in a child process (a crash costs a
  // second meshing on one thread, not the process) and 0 (chosen) is choose_mesh_threads' count;
  // without one, n > 1 refines in this process (an opt-in) and 0 is one thread.
  // Stats::mesh_threads says which. Not part of prepare_key: fields meshed either way answer for
  // the same object.
  int mesh_threads = 0;
  // The distlab executable whose `mesh-domain` command meshes on several threads in a child
  // process ("/proc/self/exe" in the server and the CLI); empty: this process meshes itself.
  std::string mesh_worker;
};

// SHA-256 (hex, digest.hpp) of a surface: its vertex and face counts, vertices and faces. Equal
// surfaces have equal digests (an upload's link names its mesh by it).
std::string surface_digest(const mesh::SurfaceMesh& surface);

// The content key of a preparation: the surface as in surface_digest, then the inputs that
// decide the field (l_x, far_radius, feature_angle, the centre or none, grading or none). The
// field store names its entries by it (with the centre prepare chose), the server's registry
// its fields (with the centre as requested). Fields under one key are compared exactly before
// one is used for another (the key alone is never trusted).
std::string prepare_key(const mesh::SurfaceMesh& surface, const PrepareOptions& options);

struct Stats {
  long n_verts = 0, n_tets = 0;
  double grading = 0;    // the sizing meshed: PrepareOptions::grading or its choice
  int mesh_threads = 1;  // the threads it was meshed with: PrepareOptions::mesh_threads or its choice
  double size_mb = 0;
  double factor_mb = 0;                          // the Cholesky factor's share of size_mb
  double solve_read_mb = 0;                      // what a solve of a dense right-hand side reads of it (both passes)
  double t_mesh = 0, t_build = 0, t_decomp = 0;  // seconds
  double t_solve = 0;                            // last set_sigma: σ on the boundary → V (eqs. 17, 20, 21), seconds
  double t_gradient = 0;                         // last set_sigma: vertex gradients of V (0 if not asked), seconds
  long linear_boundary = -1;                     // last set_sigma: boundary values it changed if solved by linearity, else −1
  bool linear_by_response = false;               // last set_sigma: that change was applied by the boundary response
  double response_mb = 0;                        // the boundary response's memory (0: none; part of size_mb)
  // Loaded from the cache: t_mesh and t_decomp are then those of the original preparation,
  // t_build is measured again (derived data are rebuilt) and t_load is the time of the load.
  bool cached = false;
  double t_load = 0;
  // prepare_cached: seconds it waited for another process's preparation of the same field (its
  // lease, store.hpp) before loading it or taking over.
  double t_wait = 0;
  std::vector<std::string> warnings;  // e.g. edge protection skipped for thin features
};

enum class Status : std::uint8_t {
  ok,
  inside,       // the point is inside the object (or at the centre): h is not defined
  nonpositive,  // the discrete V ≤ 0 there, so h = -ln(GV) does not exist (see numerics notes)
};

// Which ∇h a query returns (Field::query).
enum class Gradient : std::uint8_t {
  smoothed,  // the paper's: vertex gradients of V interpolated like V (continuous across cells)
  cell,      // the derivative of the h the query returns: V's gradient in the cell (jumps at faces)
};

struct Sample {
  double h = 0;
  Vec3 gradient = Vec3::Zero();
  Status status = Status::ok;
};

// The checks prepare makes before any meshing (options, a closed manifold surface, and a given
// centre: inside, clear of the surface, lx and the vertex estimate), without the deepest-point
// search of a default centre. Throws InvalidInput naming the field; a server runs it before it
// accepts a job.
void check_prepare_inputs(const mesh::SurfaceMesh& surface, const PrepareOptions& options);

// What prepare will mesh for these inputs, before it meshes: the sizing it meshes (options.grading,
// or choose_grading's choice, made exactly as prepare makes it: same centre, inverted surface and
// MeshingParams) and the field vertices (Stats::n_verts) of that sizing: predict_vertices' volume
// terms (the graded sizing's with its edge term), kSurfaceVerticesPerSizingIntegral · its surface
// term, and for eq. 23 with protected sharp edges what a trial meshing at a coarse l_x makes beyond
// those terms (field.cpp). Within 1.5× of Stats::n_verts on the assets and wrapped real meshes
// (tests/server/test_estimates.cpp). Runs prepare's checks first (InvalidInput as prepare would
// throw) and, without options.centre, the same deepest-point search; costs that search plus
// 0.05–0.3 s, and the trial (about as long as meshing kProtectionTrialVertices plus the protection's
// own vertices: 0.1–5 s) where it runs. Deterministic. progress: its cancel only.
struct PreparePrediction {
  double vertices = 0;  // predicted Stats::n_verts of the sizing meshed
  double grading = 0;   // the sizing prepare meshes (Stats::grading)
  bool chosen = false;  // grading was chosen (options.grading not given)
  Vec3 centre = Vec3::Zero();
  double protection_trial_lx = 0;  // l_x of the trial meshing (0: none ran)
  int mesh_threads = 1;            // the threads prepare meshes on (PrepareOptions::mesh_threads)
  // At least this many of `vertices` lie on the object's surface (a lower bound, not a count:
  // Mesh_3 puts 0.8-5.2 vertices per unit of ∫ dA / l² there, by curvature and edge refinement).
  double boundary_vertices_min = 0;
  // The least memory the boundary response takes at these counts (Field::boundary_response_megabytes):
  // a response predicted over a limit is surely over it.
  double response_megabytes_min() const;
};
PreparePrediction predict_preparation(const mesh::SurfaceMesh& surface, const PrepareOptions& options,
                                      const Progress& progress = {});

class Field {
 public:
  // Validates the surface (closed, manifold, oriented) and builds everything σ-independent.
  static Field prepare(const mesh::SurfaceMesh& surface, const PrepareOptions& options,
                       const Progress& progress = {});
  // As prepare, but reuses <cache_dir>/<content hash>.kelvin when present and intact, and
  // writes it atomically otherwise. *hit (if given) tells whether the cache was used. Safe for
  // many processes and machines on one directory (store.hpp): while one prepares a field, the
  // others wanting it wait for it (progress stage "wait") and load it.
  static Field prepare_cached(const mesh::SurfaceMesh& surface, const PrepareOptions& options,
                              const FieldStore& store, const Progress& progress = {}, bool* hit = nullptr);
  static Field prepare_cached(const mesh::SurfaceMesh& surface, const PrepareOptions& options,
                              const std::string& cache_dir, const Progress& progress = {},
                              bool* hit = nullptr) {
    return prepare_cached(surface, options, FieldStore{cache_dir}, progress, hit);
  }

  Field(Field&&) noexcept;
  Field& operator=(Field&&) noexcept;
  ~Field();

  // Solves eqs. 17, 20, 21 for V with V_∂ = e^(−σ)/|y|, and (unless gradients is false) the
  // vertex gradients of V. Without them, queries return NaN gradients: a caller that needs only
  // h (or only V, as a σ update between gradient queries) saves their cost.
  // A σ that is the last one with brushes appended (a brush stroke) is solved by linearity: only
  // the boundary values the new brushes reach change, and the change of V solves eq. 21 with a
  // right-hand side that is zero elsewhere (same field to rounding, ~1e-15 relative). A σ that
  // changes only the constant (no brush "towards" a value) scales V by e^(−Δconstant): no solve.
  // by_linearity false always solves in full (the reference of tests and benchmarks).
  void set_sigma(const SigmaSpec& sigma, bool gradients = true, bool by_linearity = true);
  // Work a later set_sigma needs, that any thread may do now without the field's lock (it
  // reads only the preparation and its own copies): the full solve that bounds the rounding
  // of strokes solved by linearity. Empty if none is due or it was handed out already. A
  // set_sigma that needs it waits for it, or does it itself if nobody ran it: the answer is
  // the same bit for bit whoever runs it, and when. Ask for it where set_sigma may be called;
  // run it while the Field lives.
  std::function<void()> background_work() const;

  // The boundary response: the change of V inside per unit change of each boundary value
  // (columns of −A_ΩΩ⁻¹ A_Ω∂, eqs. 20, 21), n_interior × n_boundary doubles. With it, a brush
  // stroke that changes few boundary values reads only their columns instead of the whole
  // factor (0.2–0.3× a full solve for 5% of the surface, bench_kelvin), whenever that reads
  // less. Built only if it fits max_megabytes and the memory is there (returns whether the field
  // has one; true at once if it had one already), with progress stage "response" (CHOLMOD's
  // multi-column solve, ~4 s at 26k vertices); Stats::response_mb. Same field to rounding with
  // or without it, and the same strokes give the same V bit for bit as long as the response is
  // kept or not kept.
  bool build_boundary_response(double max_megabytes, const Progress& progress = {});
  void release_boundary_response();
  double boundary_response_megabytes() const;  // what it takes (or would take) in memory

  // h(x) and ∇h(x) (Algorithm 1). hint: the cell of a previous query (updated), or nullptr
  // to locate through the seeding grid; it changes the speed, not the answer. ∇h is the paper's smoothed gradient: vertex gradients of
  // V (volume-weighted over each star [36]) interpolated like V, then eq. 18. It is continuous,
  // whereas h (V interpolated linearly per cell) has a derivative that jumps across faces; the two
  // differ by O(l_x), and the smoothed one is the closer to the exact ∇h (test_gradient.cpp).
  // Gradient::cell returns instead the derivative of the returned h inside its cell (what finite
  // differences of h see), also when set_sigma skipped the vertex gradients.
  Sample query(const Vec3& x, int* hint = nullptr, Gradient kind = Gradient::smoothed) const;
  std::vector<Sample> query(const std::vector<Vec3>& points) const;  // coherent order helps

  // Closed, oriented boundary of {h ≥ level} (marching tetrahedra mapped back by eq. 5),
  // normals pointing to increasing h. Where σ > level it runs along the object's surface.
  // Empty (no vertices, no faces) when the field never takes the level, i.e. level < minimum()
  // (to 1e-9 relative): {h ≥ level} is then the whole exterior, and its boundary, the object's
  // surface, is no level set of h.
  mesh::SurfaceMesh isosurface(double level) const;
  // The smallest h of the discrete field (at a mesh vertex; h grows without bound far away).
  double minimum() const;

  const Stats& stats() const;
  const TetMesh& tet_mesh() const;           // y-space cells
  const mesh::SurfaceMesh& surface() const;  // the validated input surface
  Vec3 centre() const;
  // Meshed boundary vertices mapped back to x (they lie on the input surface) and σ there.
  std::vector<Vec3> boundary_points() const;
  const VecX& boundary_sigma() const;
  // Vertex values of V (indexed like tet_mesh().points; NaN for vertices outside Ω_inv).
  const VecX& vertex_values() const;

  // For benchmarks: A_ΩΩ of eq. 21 (full symmetric) and a solve with its CHOLMOD factor, by the
  // solve set_sigma uses or (cholmod_reference) by CHOLMOD's own cholmod_solve2, which from then on
  // keeps a second copy of the factor's values in CHOLMOD's layout.
  Eigen::SparseMatrix<double> reduced_matrix() const;
  void solve_reduced(VecX& rhs, bool cholmod_reference = false) const;
  // Threads of each σ solve: 1, or 2 (the default with two or more hardware threads; the
  // answer is the same bit for bit).
  void set_solve_threads(int threads);

  struct Impl;

 private:
  explicit Field(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace distlab::kelvin
