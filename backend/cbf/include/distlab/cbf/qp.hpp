#pragma once
// Dense strictly convex QP: min ½ xᵀHx + fᵀx  s.t.  C x ≥ d  (H positive definite).
// Goldfarb–Idnani dual active-set method (D. Goldfarb, A. Idnani, "A numerically stable dual
// method for solving strictly convex quadratic programs", Math. Programming 27, 1983), written
// here from the paper's algorithm with Eigen because no Debian package ships a dense QP solver
// for C++ (quadprog is Fortran/R/Python only). Starts at the unconstrained minimum and adds the
// most violated constraint each step, so it detects infeasibility exactly when the dual step is
// unbounded (the paper's Step 2(c)(i)).
#include <vector>

#include <Eigen/Core>

namespace distlab::cbf {

enum class QpStatus { optimal,
                      infeasible,
                      iteration_limit };

struct QpResult {
  QpStatus status = QpStatus::optimal;
  Eigen::VectorXd x;       // the solution (the last iterate if not optimal)
  Eigen::VectorXd lambda;  // multipliers, one per row of C (0 for inactive rows)
  std::vector<int> active;
  int iterations = 0;  // constraints added or dropped
  double objective = 0;
};

struct QpOptions {
  double feasibility_tol = 1e-10;  // row i counts as violated below −tol·(1 + |d_i|)
  int max_iterations = 0;          // 0: 10·(n + m) + 50
};

class QpSolver {
 public:
  // Throws std::invalid_argument if H is not positive definite or the sizes disagree.
  QpResult solve(const Eigen::MatrixXd& H, const Eigen::VectorXd& f, const Eigen::MatrixXd& C,
                 const Eigen::VectorXd& d, const QpOptions& options = {});

 private:
  void add_column(int q);          // apply Givens to dvec_ tail, J_ columns; append R column
  void drop_column(int k, int q);  // remove active column k, restore R triangular
  Eigen::MatrixXd J_, R_;          // workspace, reused between solves
  Eigen::VectorXd dvec_;
};

const char* to_string(QpStatus s);

}  // namespace distlab::cbf
