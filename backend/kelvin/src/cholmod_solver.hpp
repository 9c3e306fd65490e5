#pragma once
// Supernodal Cholesky of the reduced stiffness matrix A_ΩΩ (eq. 22, with LLᵀ in place of LU:
// A_ΩΩ is symmetric positive definite). Wraps CHOLMOD so the factor can be cached to disk.
#include <Eigen/Sparse>
#include <functional>
#include <iosfwd>
#include <memory>

#include "distlab/geometry/types.hpp"
#include "supernodal_solve.hpp"

namespace distlab::kelvin {

class CholmodSolver {
 public:
  CholmodSolver();
  ~CholmodSolver();
  CholmodSolver(const CholmodSolver&) = delete;
  CholmodSolver& operator=(const CholmodSolver&) = delete;

  // lower: the lower triangle (with diagonal) of an SPD matrix, compressed column storage. If it
  // throws, the solver holds no factor. done(fraction in [0, 1)), if given, is called after the
  // analysis with its share of the time, then every 250 ms from another thread with an estimate
  // from the elapsed time against the analysis's flop count at the last factorization's speed
  // (CHOLMOD reports nothing while it factors); none comes after this returns.
  void factorize(const Eigen::SparseMatrix<double>& lower, const std::function<void(double)>& done = {});
  // A supernodal factor's values are kept in the order solve() reads them (SolveValues, 0.62–0.66x
  // the time of reading CHOLMOD's layout), rewritten in CHOLMOD's own array: neither factorize()
  // nor load() keeps CHOLMOD's layout. The calls that need it rebuild it from the solve's values;
  // solve_cholmod() keeps that copy until this frees it.
  void release_cholmod_values();
  // Solves A x = b in place (b must have size n): forward and back substitution over the
  // supernodal factor, skipping in the forward pass every supernode whose part of the permuted
  // right-hand side is still zero (b = −A_Ω∂ V_∂ of eq. 20 is nonzero only next to the boundary).
  // Large factors are solved on two threads, two lanes of the elimination tree
  // (supernodal_solve.hpp); the answer is the same bit for bit on one thread.
  void solve(VecX& b) const;
  // The same on the calling thread alone, with the caller's workspace: safe beside solve() and
  // other such calls (the factor is only read), so a solve can run off the caller's critical
  // path. Same answer bit for bit.
  struct Scratch {
    std::vector<double> work;  // the permuted vector
    SolveWorkspace workspace;
  };
  void solve(VecX& b, Scratch& scratch) const;
  bool can_solve_alone() const;  // the factor is supernodal (else solve(b, scratch) throws)
  // 1 or 2 (the default on a machine with two or more hardware threads).
  void set_solve_threads(int threads);
  // (heavier lane + the rest) / all, in factor entries read: the two-thread solve's share of the
  // one-thread time if reading entries is the cost (1: one lane).
  double critical_share() const;
  // The same through CHOLMOD's own cholmod_solve2 (reference and benchmark baseline). It keeps
  // CHOLMOD's copy of the values (rebuilt if released; factor_megabytes counts it).
  void solve_cholmod(VecX& b) const;
  // Solves A X = B in place for ncol columns (column-major, size() rows each) by cholmod_solve2,
  // block_columns at a time, two blocks at once on two threads, each with its own CHOLMOD
  // workspace: safe beside solve(), and the same bits on one thread or two. A released copy of
  // CHOLMOD's values is rebuilt for the call and freed after it; meanwhile save() and
  // solve_cholmod() of this solver wait. after_round(fraction done) runs on the calling thread
  // after every two blocks; it may throw (Cancelled) to stop, and must not call this solver.
  void solve_columns(double* b, long ncol, long block_columns, const std::function<void(double)>& after_round) const;
  // Share of the factor's entries read by the last solve() (forward and back together, in [0.5, 1]).
  double last_read_fraction() const;
  Eigen::Index size() const;
  // The solve's values, CHOLMOD's copy while it is there, and the row indices.
  double factor_megabytes() const;
  // Bytes one solve() of a dense right-hand side reads from the factor, both passes: the entries
  // of entries_read (supernodal_solve.hpp) and the row indices below each diagonal block.
  double solve_megabytes() const;

  void save(std::ostream& out) const;
  std::uint64_t saved_bytes() const;  // what save() writes
  // Returns false if the stream does not hold a consistent factor (the solver then holds none).
  bool load(std::istream& in);

 private:
  // The supernodal solve of b in place through the permuted vector w; the entries skipped.
  double solve_permuted(VecX& b, std::vector<double>& w, SolveWorkspace& workspace, bool threads) const;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace distlab::kelvin
