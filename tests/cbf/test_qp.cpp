// The Goldfarb–Idnani solver against CGAL's exact QP solver (Gmpzf arithmetic) on random
// strictly convex problems, feasible and infeasible.
#include <random>

#include <CGAL/Gmpzf.h>
#include <CGAL/QP_functions.h>
#include <CGAL/QP_models.h>
#include <gtest/gtest.h>

#include "distlab/cbf/qp.hpp"

namespace distlab::cbf {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

struct Exact {
  bool infeasible = false;
  VectorXd x;
  double objective = 0;
};

// CGAL minimises xᵀDx + cᵀx s.t. A x (≥) b, x free; set_d takes 2D, i.e. our H.
Exact solve_exact(const MatrixXd& H, const VectorXd& f, const MatrixXd& C, const VectorXd& d) {
  const int n = static_cast<int>(H.rows()), m = static_cast<int>(C.rows());
  CGAL::Quadratic_program<double> qp(CGAL::LARGER, false, 0, false, 0);
  for (int i = 0; i < m; ++i) {
    for (int j = 0; j < n; ++j) qp.set_a(j, i, C(i, j));
    qp.set_b(i, d[i]);
  }
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j <= i; ++j) qp.set_d(i, j, H(i, j));
    qp.set_c(i, f[i]);
  }
  const auto s = CGAL::solve_quadratic_program(qp, CGAL::Gmpzf());
  Exact e;
  e.infeasible = s.is_infeasible();
  EXPECT_FALSE(s.is_unbounded());  // H ≻ 0
  if (!e.infeasible) {
    e.x.resize(n);
    int i = 0;
    for (auto it = s.variable_values_begin(); it != s.variable_values_end(); ++it)
      e.x[i++] = CGAL::to_double(*it);
    e.objective = CGAL::to_double(s.objective_value());
  }
  return e;
}

MatrixXd random_spd(std::mt19937_64& rng, int n) {
  std::normal_distribution<double> g;
  MatrixXd A(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) A(i, j) = g(rng);
  return A.transpose() * A + 0.1 * MatrixXd::Identity(n, n);
}

MatrixXd random_matrix(std::mt19937_64& rng, int r, int c) {
  std::normal_distribution<double> g;
  MatrixXd A(r, c);
  for (int i = 0; i < r; ++i)
    for (int j = 0; j < c; ++j) A(i, j) = g(rng);
  return A;
}

TEST(Qp, FeasibleProblemsMatchTheExactSolver) {
  std::mt19937_64 rng(1);
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> u01(0, 1);
  QpSolver solver;
  int with_active = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const int n = 1 + trial % 8;
    const int m = 1 + static_cast<int>(u01(rng) * 30);
    const MatrixXd H = random_spd(rng, n);
    const VectorXd f = 3 * random_matrix(rng, n, 1);
    const MatrixXd C = random_matrix(rng, m, n);
    // Feasible by construction: x0 satisfies every row, a third of them almost with equality
    // (1e-9 below: C·x0 is rounded, and the exact solver sees the rounding).
    const VectorXd x0 = random_matrix(rng, n, 1);
    VectorXd d = C * x0;
    for (int i = 0; i < m; ++i) d[i] -= u01(rng) > 0.33 ? u01(rng) : 1e-9;
    const Exact e = solve_exact(H, f, C, d);
    ASSERT_FALSE(e.infeasible);
    const QpResult r = solver.solve(H, f, C, d);
    ASSERT_EQ(r.status, QpStatus::optimal) << "trial " << trial;
    EXPECT_LT((r.x - e.x).norm(), 1e-8 * (1 + e.x.norm())) << "trial " << trial;
    EXPECT_NEAR(r.objective, e.objective, 1e-8 * (1 + std::abs(e.objective)));
    // KKT: Hx + f = Cᵀλ, λ ≥ 0, complementary slackness.
    EXPECT_LT((H * r.x + f - C.transpose() * r.lambda).norm(), 1e-8 * (1 + f.norm()));
    for (int i = 0; i < m; ++i) {
      EXPECT_GE(r.lambda[i], 0);
      EXPECT_LT(std::abs(r.lambda[i] * (C.row(i).dot(r.x) - d[i])), 1e-8);
    }
    with_active += !r.active.empty();
  }
  EXPECT_GT(with_active, 200);  // the test exercises the active-set updates
}

TEST(Qp, DegenerateAndDependentRows) {
  // Duplicated and positively dependent rows: the solver must not stall or lose optimality.
  std::mt19937_64 rng(2);
  QpSolver solver;
  for (int trial = 0; trial < 100; ++trial) {
    const int n = 2 + trial % 6;
    const MatrixXd H = random_spd(rng, n);
    const VectorXd f = 5 * random_matrix(rng, n, 1);
    MatrixXd base = random_matrix(rng, n, n);
    MatrixXd C(3 * n, n);
    VectorXd d(3 * n);
    for (int i = 0; i < n; ++i) {
      C.row(3 * i) = base.row(i);
      C.row(3 * i + 1) = base.row(i);        // duplicate
      C.row(3 * i + 2) = 2.0 * base.row(i);  // scaled copy
      d[3 * i] = 0.5;
      d[3 * i + 1] = 0.5;
      d[3 * i + 2] = 1.0;
    }
    const Exact e = solve_exact(H, f, C, d);
    const QpResult r = solver.solve(H, f, C, d);
    ASSERT_EQ(e.infeasible, r.status == QpStatus::infeasible) << "trial " << trial;
    if (!e.infeasible) {
      ASSERT_EQ(r.status, QpStatus::optimal);
      EXPECT_LT((r.x - e.x).norm(), 1e-7 * (1 + e.x.norm())) << "trial " << trial;
    }
  }
}

TEST(Qp, InfeasibleProblemsAreDetected) {
  QpSolver solver;
  // x1 ≥ 1, x2 ≥ 1, −x1 − x2 ≥ −1: empty.
  MatrixXd C(3, 2);
  C << 1, 0, 0, 1, -1, -1;
  VectorXd d(3);
  d << 1, 1, -1;
  const MatrixXd H = MatrixXd::Identity(2, 2);
  const VectorXd f = VectorXd::Zero(2);
  ASSERT_TRUE(solve_exact(H, f, C, d).infeasible);
  EXPECT_EQ(solver.solve(H, f, C, d).status, QpStatus::infeasible);

  // Random problems with random right-hand sides: the status agrees with CGAL in every case,
  // and both outcomes occur.
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u01(0, 1);
  int infeasible = 0, feasible = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const int n = 1 + trial % 5;
    const int m = n + 1 + static_cast<int>(u01(rng) * 12);
    const MatrixXd Hn = random_spd(rng, n);
    const VectorXd fn = random_matrix(rng, n, 1);
    const MatrixXd Cn = random_matrix(rng, m, n);
    const VectorXd dn = 2 * random_matrix(rng, m, 1).array() + 1.0;
    const Exact e = solve_exact(Hn, fn, Cn, dn);
    const QpResult r = solver.solve(Hn, fn, Cn, dn);
    ASSERT_EQ(e.infeasible, r.status == QpStatus::infeasible) << "trial " << trial;
    if (e.infeasible) {
      ++infeasible;
    } else {
      ++feasible;
      ASSERT_EQ(r.status, QpStatus::optimal);
      EXPECT_LT((r.x - e.x).norm(), 1e-7 * (1 + e.x.norm())) << "trial " << trial;
    }
  }
  EXPECT_GT(infeasible, 30);
  EXPECT_GT(feasible, 30);
}

TEST(Qp, RejectsIndefiniteH) {
  QpSolver solver;
  MatrixXd H(2, 2);
  H << 1, 0, 0, -1;
  EXPECT_THROW(solver.solve(H, VectorXd::Zero(2), MatrixXd(0, 2), VectorXd(0)),
               std::invalid_argument);
}

}  // namespace
}  // namespace distlab::cbf
