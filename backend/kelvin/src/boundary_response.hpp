#pragma once
// The interior's response to each boundary value: column b of G = −A_ΩΩ⁻¹ A_Ω∂ e_b (eqs. 20, 21),
// the change of V inside per unit change of V_∂ at boundary vertex b. A brush stroke's change
// of V is then Σ_b G e_b ΔV_∂b over the boundary values it changed: it reads only their columns,
// where a solve reads the whole factor in its back pass however few values changed (the change
// of a harmonic field is nonzero everywhere). Memory: n_interior × n_boundary doubles, some
// times the factor's, so it is built only when asked (Field::build_boundary_response).
#include <Eigen/Sparse>
#include <utility>
#include <vector>

#include "cholmod_solver.hpp"
#include "distlab/geometry/types.hpp"
#include "distlab/kelvin/progress.hpp"

namespace distlab::kelvin {

class BoundaryResponse {
 public:
  static double megabytes(Eigen::Index n_interior, Eigen::Index n_boundary);
  // Every column, by CHOLMOD's multi-column solve in blocks on up to two threads; reports stage
  // "response" and throws Cancelled between blocks. Same bits on one thread or two.
  void build(const CholmodSolver& solver, const Eigen::SparseMatrix<double>& a_ob, const Progress& progress);
  void clear();
  bool empty() const { return columns_.empty(); }
  double megabytes() const;
  // Bytes that applying `count` columns reads.
  double bytes_read(std::size_t count) const;
  // out += Σ G e_b d over (b, d) in `changes`, in their order for every row. threads: 1, 2 (rows
  // split in two halves), or 0: 2 when the work is large. The same bits whichever.
  void apply(const std::vector<std::pair<std::size_t, double>>& changes, VecX& out, int threads = 0) const;

 private:
  Eigen::Index rows_ = 0;
  std::vector<double> columns_;  // column-major, rows_ per boundary vertex
};

}  // namespace distlab::kelvin
