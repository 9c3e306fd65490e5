#pragma once
// State of a prepared Field, shared by the translation units of distlab_kelvin.
#include <Eigen/Sparse>
#include <atomic>
#include <memory>
#include <mutex>
#include <utility>
#include <vector>

#include "boundary_response.hpp"
#include "cholmod_solver.hpp"
#include "distlab/kelvin/field.hpp"
#include "distlab/kelvin/surface_tools.hpp"
#include "locator.hpp"

namespace distlab::kelvin {

// A full solve of an earlier σ that set_sigma uses a few stroke edits later (field.cpp,
// kRefreshLead). It reads only what preparation built and its own copy of the boundary chains,
// so any thread may do it (Field::background_work) while the field goes on solving other σ.
struct Refresh {
  VecX chain;          // boundary_chain of the σ it solves
  bool apart = false;  // that σ was separable: it solves W, else V inside
  int edits = 0;       // linear_edits when it was taken
  std::once_flag once;
  std::atomic<bool> handed_out{false};
  VecX solved;  // W or V inside, per interior vertex (set once `once` has run)
};

struct Field::Impl {
  // Inputs and the mesh (what the cache stores, together with the factor).
  mesh::SurfaceMesh surface;
  PrepareOptions options;    // effective (feature_angle 180 when protection was skipped)
  PrepareOptions requested;  // as asked (centre filled in): what the cache entry must match
  Vec3 centre = Vec3::Zero();
  TetMesh tm;
  CholmodSolver solver;
  BoundaryResponse response;  // empty unless built (Field::build_boundary_response)

  // Derived in build(): vertex roles, A_Ω∂ (eq. 20), gradient weights, locator, σ sampling.
  std::vector<int> slot;                // per point: interior index ≥ 0, boundary b as -(b + 2), unused -1
  std::vector<int> interior, boundary;  // point ids
  std::vector<int> domain_tets;
  std::vector<int> boundary_facets;  // 4 · cell + k: the face of a domain cell opposite its vertex k, on ∂Ω_inv
  // Vertex stars: for point v, entries star[star_start[v] … star_start[v+1]) are 4 · (index into
  // domain_tets) + (local vertex): the domain cells around v.
  std::vector<int> star_start, star;
  std::vector<Eigen::Matrix<double, 4, 3>> grad_weights;  // per domain tet: vol · ∇φ_j
  VecX star_volume;                                       // per point
  Eigen::SparseMatrix<double> a_ob;                       // A_Ω∂
  Eigen::SparseMatrix<double> a_oo_lower;                 // lower triangle of A_ΩΩ
  PackedMesh packed;                                      // tm repacked for queries (packed_mesh.hpp)
  Locator locator;
  std::unique_ptr<SurfaceOracle> oracle;
  std::vector<int> boundary_face;
  std::vector<Vec3> boundary_weights;

  // State for the current σ.
  VecX boundary_sigma;
  VecX V;                      // per point (V and ∇V are also in packed.vertices, beside the positions)
  bool has_gradients = false;  // set_sigma(…, gradients = false) leaves ∇V out
  // The σ that V solves (valid only with `solved`), and the σ edits solved by linearity since
  // the last full solve (field.cpp, set_sigma).
  SigmaSpec solved_sigma;
  bool solved = false;
  int linear_edits = 0;
  std::shared_ptr<Refresh> refresh;  // taken, not yet used (none after a full solve)
  // Per boundary vertex, σ's terms summed in order, without the constant while σ has no brush
  // "towards" a value (field.cpp, separable); and for such a σ W, the interior solve of σ − c
  // (V = e^(−c) W inside).
  VecX boundary_chain;
  VecX W;
  Stats stats;
  // Seconds of each phase of the last build() (for the build profile; phases after the stars
  // run on two threads, each timed on its own).
  std::vector<std::pair<const char*, double>> build_phases;

  // Assembles everything derived from tm (t_build); factor() then factors A_ΩΩ (t_decomp).
  void build(const Progress& progress);
  void factor(const Progress& progress);
  void finish_stats();
};

// The name of a store entry: the content key (prepare_key) qualified by the entry format, so that
// processes of two versions sharing a directory keep their entries apart.
std::string entry_key(const std::string& content_key);
// HMAC key of a cache directory (<dir>/cache.key, 32 bytes, mode 0600, created at first use).
std::string cache_mac_key(const std::string& dir);
// Cache I/O. A file is u64 payload size, payload, HMAC-SHA256(mac_key, payload). load returns
// nullptr (and removes nothing) when the file is absent, not intact, not written under mac_key,
// or prepared from other inputs than (surface, requested): the file stores its full inputs and
// they are compared byte for byte, so a colliding name can never serve a wrong object.
std::unique_ptr<Field::Impl> load_prepared(const std::string& path, const std::string& key,
                                           const mesh::SurfaceMesh& surface, const PrepareOptions& requested,
                                           const std::string& mac_key);
// save writes the entry to `tmp`, a new private file (progress "cache" 0.5 to 0.9 while it
// writes), flushed to disk; the store publishes it (store_impl.hpp).
void save_prepared(const Field::Impl& m, const std::string& tmp, const std::string& key,
                   const std::string& mac_key, const Progress& progress = {});

}  // namespace distlab::kelvin
