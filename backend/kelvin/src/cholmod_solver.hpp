#pragma once
// Supernodal Cholesky of the reduced stiffness matrix A_ΩΩ (eq. 22, with LLᵀ in place of LU:
// A_ΩΩ is symmetric positive definite). Wraps CHOLMOD so the factor can be cached to disk.
#include <Eigen/Sparse>
#include <iosfwd>
#include <memory>

#include "distlab/geometry/types.hpp"

namespace distlab::kelvin {

class CholmodSolver {
 public:
  CholmodSolver();
  ~CholmodSolver();
  CholmodSolver(const CholmodSolver&) = delete;
  CholmodSolver& operator=(const CholmodSolver&) = delete;

  // lower: the lower triangle (with diagonal) of an SPD matrix, compressed column storage.
  void factorize(const Eigen::SparseMatrix<double>& lower);
  // Solves A x = b in place (b must have size n).
  void solve(VecX& b) const;
  Eigen::Index size() const;
  double factor_megabytes() const;

  void save(std::ostream& out) const;
  // Returns false if the stream does not hold a consistent factor.
  bool load(std::istream& in);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace distlab::kelvin
