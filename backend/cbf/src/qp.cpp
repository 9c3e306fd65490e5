// Goldfarb–Idnani dual active-set method; the notation follows the paper: J = L⁻ᵀQ with H = LLᵀ
// and N⁺ (active normals) = Q[R; 0], z = J₂J₂ᵀn⁺ the primal step, r = R⁻¹J₁ᵀn⁺ the dual step.
#include "distlab/cbf/qp.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/Cholesky>

namespace distlab::cbf {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Rotation [c s; −s c] mapping (a, b) to (hypot, 0).
void givens(double a, double b, double& c, double& s) {
  const double h = std::hypot(a, b);
  if (h == 0) {
    c = 1;
    s = 0;
  } else {
    c = a / h;
    s = b / h;
  }
}

// J ← J Gᵀ on columns i, i+1 (so that Jᵀn is rotated by G).
void rotate_columns(Eigen::MatrixXd& J, int i, double c, double s) {
  for (Eigen::Index r = 0; r < J.rows(); ++r) {
    const double a = J(r, i), b = J(r, i + 1);
    J(r, i) = c * a + s * b;
    J(r, i + 1) = -s * a + c * b;
  }
}

}  // namespace

const char* to_string(QpStatus s) {
  switch (s) {
    case QpStatus::optimal:
      return "optimal";
    case QpStatus::infeasible:
      return "infeasible";
    case QpStatus::iteration_limit:
      return "iteration_limit";
  }
  return "?";
}

void QpSolver::add_column(int q) {
  const int n = static_cast<int>(J_.rows());
  // Zero dvec_[q+1..n−1] from the bottom up; the new column of R is dvec_[0..q].
  for (int j = n - 1; j > q; --j) {
    double c, s;
    givens(dvec_[j - 1], dvec_[j], c, s);
    dvec_[j - 1] = c * dvec_[j - 1] + s * dvec_[j];
    dvec_[j] = 0;
    rotate_columns(J_, j - 1, c, s);
  }
  R_.col(q).head(q + 1) = dvec_.head(q + 1);
}

void QpSolver::drop_column(int k, int q) {
  // Remove column k of the q active columns; the rest is upper Hessenberg from column k on.
  for (int j = k; j < q - 1; ++j) R_.col(j).head(j + 2) = R_.col(j + 1).head(j + 2);
  for (int j = k; j < q - 1; ++j) {
    double c, s;
    givens(R_(j, j), R_(j + 1, j), c, s);
    for (int col = j; col < q - 1; ++col) {
      const double a = R_(j, col), b = R_(j + 1, col);
      R_(j, col) = c * a + s * b;
      R_(j + 1, col) = -s * a + c * b;
    }
    R_(j + 1, j) = 0;
    rotate_columns(J_, j, c, s);
  }
}

QpResult QpSolver::solve(const Eigen::MatrixXd& H, const Eigen::VectorXd& f,
                         const Eigen::MatrixXd& C, const Eigen::VectorXd& d,
                         const QpOptions& options) {
  const int n = static_cast<int>(H.rows());
  const int m = static_cast<int>(C.rows());
  if (H.cols() != n || f.size() != n || (m > 0 && C.cols() != n) || d.size() != m)
    throw std::invalid_argument("qp: inconsistent sizes");
  Eigen::LLT<Eigen::MatrixXd> llt(H);
  if (llt.info() != Eigen::Success) throw std::invalid_argument("qp: H is not positive definite");

  // Unconstrained minimum x = −H⁻¹f; J = L⁻ᵀ (Q = I, no active constraint).
  QpResult res;
  res.x = -llt.solve(f);
  res.lambda = Eigen::VectorXd::Zero(m);
  J_ = llt.matrixU().solve(Eigen::MatrixXd::Identity(n, n));  // U = Lᵀ, so J = U⁻¹ = L⁻ᵀ
  R_.setZero(n, n);
  dvec_.resize(n);

  std::vector<int>& A = res.active;
  std::vector<double> u;  // multipliers of A
  std::vector<char> in_active(m, 0);
  const int limit = options.max_iterations > 0 ? options.max_iterations : 10 * (n + m) + 50;
  auto finish = [&](QpStatus status) {
    res.status = status;
    for (std::size_t i = 0; i < A.size(); ++i) res.lambda[A[i]] = u[i];
    res.objective = 0.5 * res.x.dot(H * res.x) + f.dot(res.x);
    return res;
  };

  for (;;) {
    // Step 1: choose the most violated inactive constraint.
    int p = -1;
    double worst = 0;
    for (int i = 0; i < m; ++i) {
      if (in_active[i]) continue;
      const double s = C.row(i).dot(res.x) - d[i];
      if (s < -options.feasibility_tol * (1 + std::abs(d[i])) && s < worst) {
        worst = s;
        p = i;
      }
    }
    if (p < 0) return finish(QpStatus::optimal);
    const Eigen::VectorXd np = C.row(p).transpose();
    std::vector<double> uplus = u;
    uplus.push_back(0.0);

    // Step 2: move until constraint p is satisfied (full step) or an active one drops.
    for (;;) {
      if (++res.iterations > limit) {
        u.assign(uplus.begin(), uplus.begin() + static_cast<long>(A.size()));
        return finish(QpStatus::iteration_limit);
      }
      const int q = static_cast<int>(A.size());
      dvec_.noalias() = J_.transpose() * np;
      const Eigen::VectorXd z = J_.rightCols(n - q) * dvec_.tail(n - q);
      const Eigen::VectorXd r =
          R_.topLeftCorner(q, q).triangularView<Eigen::Upper>().solve(dvec_.head(q));

      // Partial step: the largest t keeping the active multipliers ≥ 0.
      double t1 = kInf;
      int k = -1;
      for (int j = 0; j < q; ++j)
        if (r[j] > 0 && uplus[j] / r[j] < t1) {
          t1 = uplus[j] / r[j];
          k = j;
        }
      // Full step: n_pᵀz = ‖J₂ᵀn_p‖²; zero means n_p depends linearly on the active normals.
      const double curv = dvec_.tail(n - q).squaredNorm();
      const double s_p = np.dot(res.x) - d[p];
      const double t2 = curv > 1e-24 * dvec_.squaredNorm() ? -s_p / curv : kInf;

      if (t1 == kInf && t2 == kInf) {  // Step 2(c)(i): the dual is unbounded
        u.assign(uplus.begin(), uplus.begin() + q);
        return finish(QpStatus::infeasible);
      }
      const double t = std::min(t1, t2);
      if (t2 < kInf) res.x += t * z;
      for (int j = 0; j < q; ++j) uplus[j] -= t * r[j];
      uplus[q] += t;
      if (t2 <= t1) {  // full step: p joins the active set
        add_column(q);
        A.push_back(p);
        in_active[p] = 1;
        u = uplus;
        break;
      }
      // Partial step: drop constraint k and retry p.
      drop_column(k, q);
      in_active[A[k]] = 0;
      A.erase(A.begin() + k);
      uplus.erase(uplus.begin() + k);  // the entry of p stays last
    }
  }
}

}  // namespace distlab::cbf
