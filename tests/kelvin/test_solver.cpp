// The supernodal triangular solves of CholmodSolver (white box) against CHOLMOD's own
// cholmod_solve2 and Eigen's simplicial LDLᵀ, for dense and for sparse right-hand sides (the
// forward pass skips supernodes whose right-hand side is zero).
#include <gtest/gtest.h>

#include <dlfcn.h>

#include <Eigen/SparseCholesky>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <numeric>
#include <random>
#include <sstream>
#include <thread>
#include <vector>

#include "boundary_response.hpp"
#include "cholmod_solver.hpp"
#include "elapsed_progress.hpp"

using namespace distlab;
using namespace distlab::kelvin;

namespace {

// 7-point Laplacian on an n³ grid (Dirichlet outside) with random positive edge weights: SPD,
// with supernodes of every size under nested dissection.
Eigen::SparseMatrix<double> grid_matrix(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> w(0.5, 2.0);
  auto id = [n](int i, int j, int k) { return (k * n + j) * n + i; };
  std::vector<Eigen::Triplet<double>> t;
  std::vector<double> diag(static_cast<size_t>(n) * n * n, 0.0);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const int a = id(i, j, k);
        const int nb[3] = {i + 1 < n ? id(i + 1, j, k) : -1, j + 1 < n ? id(i, j + 1, k) : -1, k + 1 < n ? id(i, j, k + 1) : -1};
        for (int b : nb) {
          const double e = w(rng);
          diag[static_cast<size_t>(a)] += e;
          if (b < 0) continue;  // Dirichlet neighbour
          diag[static_cast<size_t>(b)] += e;
          t.emplace_back(std::max(a, b), std::min(a, b), -e);
        }
        diag[static_cast<size_t>(a)] += 3 * w(rng) * (i == 0 || j == 0 || k == 0);
      }
  for (size_t a = 0; a < diag.size(); ++a) t.emplace_back(static_cast<int>(a), static_cast<int>(a), diag[a]);
  Eigen::SparseMatrix<double> lower(n * n * n, n * n * n);
  lower.setFromTriplets(t.begin(), t.end());
  return lower;
}

}  // namespace

TEST(KelvinSolver, SupernodalSolveMatchesCholmodAndEigen) {
  const Eigen::SparseMatrix<double> lower = grid_matrix(18, 1);
  CholmodSolver solver;
  solver.factorize(lower);
  const Eigen::SparseMatrix<double> full = lower.selfadjointView<Eigen::Lower>();
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(full);
  ASSERT_EQ(ldlt.info(), Eigen::Success);
  std::mt19937 rng(2);
  std::normal_distribution<double> g;
  std::bernoulli_distribution keep(0.02);
  for (int trial = 0; trial < 6; ++trial) {
    VecX b = VecX::Zero(lower.rows());
    for (Eigen::Index i = 0; i < b.size(); ++i)
      if (trial < 2 || keep(rng)) b[i] = g(rng);       // dense, then sparse
    if (trial == 5) b.setZero(), b[b.size() / 2] = 1;  // a single entry
    VecX x = b, y = b;
    solver.solve(x);
    solver.solve_cholmod(y);
    const VecX z = ldlt.solve(b);
    EXPECT_LT((x - y).norm(), 1e-12 * y.norm()) << trial;
    EXPECT_LT((x - z).norm(), 1e-11 * z.norm()) << trial;
    EXPECT_LT((full * x - b).norm(), 1e-12 * b.norm()) << trial;
    // Sparse right-hand sides skip supernodes in the forward pass; dense ones read everything.
    EXPECT_EQ(solver.last_read_fraction() < 1.0, trial >= 2) << trial << " " << solver.last_read_fraction();
  }
  // The zero vector solves to zero.
  VecX zero = VecX::Zero(lower.rows());
  solver.solve(zero);
  EXPECT_EQ(zero.norm(), 0.0);
}

// A dense SPD matrix has a dense factor: whatever its supernodes, a solve reads the n(n+1)/2
// entries of the lower triangle in each pass, and the row indices below each diagonal block
// (at most n(n−1)/2), but not the upper triangles CHOLMOD stores with the diagonal blocks.
TEST(KelvinSolver, BytesReadBySolveCountTheLowerTriangleOnly) {
  const int n = 120;
  std::mt19937 rng(10);
  std::uniform_real_distribution<double> u(-1, 1);
  Eigen::MatrixXd m(n, n);
  for (double& v : m.reshaped()) v = u(rng);
  const Eigen::MatrixXd spd = m * m.transpose() + n * Eigen::MatrixXd::Identity(n, n);
  const Eigen::SparseMatrix<double> lower = spd.triangularView<Eigen::Lower>().toDenseMatrix().sparseView();
  CholmodSolver solver;
  solver.factorize(lower);
  const double triangle = 8.0 * n * (n + 1) / 2, indices = 4.0 * n * (n - 1) / 2;
  EXPECT_GE(solver.solve_megabytes(), 2 * triangle / 1e6);
  EXPECT_LE(solver.solve_megabytes(), 2 * (triangle + indices) / 1e6);
  // CHOLMOD makes one supernode of the dense matrix. Its values in the solve's order: the lower
  // triangle and the upper parts of the 8 × 8 diagonal blocks (15 of them), rewritten in CHOLMOD's
  // array: its own layout, the dense 120 × 120 block, is gone after the factorization.
  const double solve_order = triangle + 8.0 * 15 * 28 + 4.0 * 3 * n, cholmod_copy = 8.0 * n * n;
  EXPECT_DOUBLE_EQ(solver.factor_megabytes(), solve_order / 1e6);
  solver.release_cholmod_values();
  EXPECT_DOUBLE_EQ(solver.factor_megabytes(), solve_order / 1e6);
  // A dense right-hand side reads everything.
  VecX b = VecX::LinSpaced(n, -1, 2), x = b;
  solver.solve(x);
  EXPECT_EQ(solver.last_read_fraction(), 1.0);
  EXPECT_LT((spd * x - b).norm(), 1e-12 * b.norm());
  // CHOLMOD's layout is rebuilt for the columns' solve and freed after it, also when the solve is
  // stopped; the reference solve keeps it.
  Eigen::MatrixXd columns = Eigen::MatrixXd::Identity(n, 3);
  solver.solve_columns(columns.data(), 3, 2, {});
  EXPECT_LT((spd * columns - Eigen::MatrixXd::Identity(n, 3)).norm(), 1e-12);
  EXPECT_DOUBLE_EQ(solver.factor_megabytes(), solve_order / 1e6);
  EXPECT_THROW(solver.solve_columns(columns.data(), 3, 1, [](double) { throw std::runtime_error("stop"); }),
               std::runtime_error);
  EXPECT_DOUBLE_EQ(solver.factor_megabytes(), solve_order / 1e6);
  VecX y = b;
  solver.solve_cholmod(y);
  EXPECT_LT((y - x).norm(), 1e-13 * x.norm());
  EXPECT_DOUBLE_EQ(solver.factor_megabytes(), (solve_order + cholmod_copy) / 1e6);
}

// The solve's order holds every value a solve reads, and nothing else but zeros. Supernode 0 has
// 11 columns (chunks of 8 and 3) and 15 rows: 7 below the first chunk (an odd count: a padded tile
// of the kernels' 8-wide path) and 4 below the second; supernode 1 has 3 columns and 1 row below
// (a padded 3-wide tile); supernode 2 is one entry.
TEST(KelvinSolver, SolveOrderKeepsTheLowerTrianglesExactly) {
  const int super[] = {0, 11, 14, 15}, pi[] = {0, 15, 19, 20}, px[] = {0, 165, 177, 178};
  std::vector<int> rows(20);
  std::iota(rows.begin(), rows.begin() + 15, 0);
  std::iota(rows.begin() + 15, rows.begin() + 19, 11);
  rows[19] = 14;
  SupernodalFactor f{15, 3, super, pi, px, rows.data()};
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(1, 2);
  std::vector<double> x(178);
  for (double& v : x) v = u(rng);
  auto* cholmod = static_cast<double*>(std::malloc(x.size() * sizeof(double)));  // taken over
  std::copy(x.begin(), x.end(), cholmod);
  const SolveValues packed = pack_in_place(f, cholmod);
  // 8 × 8 + 4 tiles × 2 rows × 8, then 3 × 3 + 2 tiles × 2 × 3; 3 × 3 + 1 tile × 2 × 3; 1.
  EXPECT_EQ(packed.start, (std::vector<long>{0, 128 + 21, 128 + 21 + 15, 128 + 21 + 15 + 1}));
  // Every stored value of the lower triangles is there once (all are in [1, 2]); the rest is zero.
  const long lower = (165 - 55) + (12 - 3) + 1;
  EXPECT_EQ(std::count_if(packed.values.begin(), packed.values.end(), [](double v) { return v != 0.0; }), lower);
  f.values = packed.values.data();
  f.start = packed.start.data();
  std::vector<double> back(178, -1.0);
  unpack_values(f, back.data());
  for (int k = 0; k < 3; ++k) {
    const int ncol = super[k + 1] - super[k], nrow = pi[k + 1] - pi[k];
    for (int c = 0; c < ncol; ++c)
      for (int r = 0; r < nrow; ++r) {
        const int i = px[k] + c * nrow + r;
        EXPECT_EQ(back[i], r >= c ? x[i] : 0.0) << "supernode " << k << " row " << r << " column " << c;
      }
  }
}

// Packing in CHOLMOD's own array gives what packing into a fresh one gives, also where the output
// runs ahead of blocks not yet read (1 × 2 supernodes take 3 entries in the solve's order, 2 in
// CHOLMOD's) and where the solve's order needs more room than CHOLMOD's array has.
TEST(KelvinSolver, PackingInPlaceEqualsPackingIntoAFreshArray) {
  std::mt19937 rng(5);
  for (const int tiny : {200, 0}) {
    for (const int random : {60, 0}) {
      if (tiny + random == 0) continue;
      std::vector<int> super{0}, pi{0}, px{0};
      for (int k = 0; k < tiny + random; ++k) {
        const int ncol = k < tiny ? 1 : 1 + static_cast<int>(rng() % 20);
        const int nrow = k < tiny ? 2 : ncol + static_cast<int>(rng() % 14);
        super.push_back(super.back() + ncol);
        pi.push_back(pi.back() + nrow);
        px.push_back(px.back() + ncol * nrow);
      }
      const int nsuper = tiny + random;
      SupernodalFactor f{super.back(), nsuper, super.data(), pi.data(), px.data(), nullptr};
      std::vector<double> x(static_cast<size_t>(px.back()));
      std::uniform_real_distribution<double> u(1, 2);
      for (double& v : x) v = u(rng);
      SolveValues fresh = solve_layout(f);
      for (int k = 0; k < nsuper; ++k) pack_supernode(f, k, x.data() + px[k], fresh.values.data() + fresh.start[k]);
      auto* cholmod = static_cast<double*>(std::malloc(x.size() * sizeof(double)));
      std::copy(x.begin(), x.end(), cholmod);
      const SolveValues packed = pack_in_place(f, cholmod);
      long ahead = 0;  // how far the output gets past the next unread block
      for (int k = 0; k < nsuper; ++k) ahead = std::max(ahead, packed.start[k + 1] - px[k + 1]);
      if (tiny > 0) {
        EXPECT_GT(ahead, 0) << "the case of blocks set aside";
      }
      if (random == 0) {
        EXPECT_GT(packed.start.back(), px.back()) << "the case of a grown array";
      }
      EXPECT_EQ(packed.start, fresh.start);
      ASSERT_EQ(packed.values.size(), fresh.values.size());
      EXPECT_TRUE(std::equal(packed.values.begin(), packed.values.end(), fresh.values.begin()))
          << "tiny " << tiny << " random " << random;
    }
  }
}

TEST(KelvinSolver, ReloadedFactorSolvesTheSame) {
  const Eigen::SparseMatrix<double> lower = grid_matrix(12, 3);
  CholmodSolver a, b;
  a.factorize(lower);
  std::stringstream io;
  a.save(io);
  ASSERT_TRUE(b.load(io));
  VecX x = VecX::LinSpaced(lower.rows(), -1, 2), y = x;
  a.solve(x);
  b.solve(y);
  EXPECT_EQ((x - y).norm(), 0.0);
  const Eigen::SparseMatrix<double> full = lower.selfadjointView<Eigen::Lower>();
  const VecX rhs = VecX::LinSpaced(lower.rows(), -1, 2);
  EXPECT_LT((full * x - rhs).norm(), 1e-12 * rhs.norm());
  // Saved again after CHOLMOD's copy was released, the file holds CHOLMOD's values rebuilt from
  // the solve's order: the same bytes, but for the unused upper parts of the diagonal blocks.
  a.release_cholmod_values();
  std::stringstream again;
  a.save(again);
  const std::string before = io.str(), after = again.str();
  ASSERT_EQ(before.size(), after.size());
  std::uint64_t sizes[8];
  std::memcpy(sizes, before.data(), sizeof sizes);
  const std::size_t n = sizes[0], nsuper = sizes[1], ssize = sizes[2], xsize = sizes[3];
  const std::size_t ints = sizeof sizes, super_at = ints + 4 * 2 * n, pi_at = super_at + 4 * (nsuper + 1),
                    px_at = pi_at + 4 * (nsuper + 1), x_at = px_at + 4 * (nsuper + 1) + 4 * ssize;
  ASSERT_EQ(x_at + 8 * xsize, before.size());
  EXPECT_EQ(before.substr(0, x_at), after.substr(0, x_at));
  auto at = [](const std::string& bytes, std::size_t offset, auto value) {
    std::memcpy(&value, bytes.data() + offset, sizeof value);
    return value;
  };
  long compared = 0;
  for (std::size_t k = 0; k < nsuper; ++k) {
    const int c0 = at(before, super_at + 4 * k, 0), ncol = at(before, super_at + 4 * (k + 1), 0) - c0;
    const int nrow = at(before, pi_at + 4 * (k + 1), 0) - at(before, pi_at + 4 * k, 0), p0 = at(before, px_at + 4 * k, 0);
    for (int c = 0; c < ncol; ++c)
      for (int r = c; r < nrow; ++r, ++compared) {
        const std::size_t offset = x_at + 8 * (static_cast<std::size_t>(p0) + static_cast<std::size_t>(c) * nrow + r);
        ASSERT_EQ(at(before, offset, 0.0), at(after, offset, 0.0)) << "supernode " << k;
      }
  }
  EXPECT_GT(compared, 10000);
}

// Above 10k unknowns the factor is ordered by nested dissection (METIS) instead of AMD: the solve
// must be as exact there; and the factorization, which runs CHOLMOD's OpenMP regions serially,
// leaves the process's OpenMP setting (max-active-levels) as it found it.
TEST(KelvinSolver, NestedDissectionOrderingSolvesAndRestoresOpenMP) {
  const Eigen::SparseMatrix<double> lower = grid_matrix(22, 4);  // 10,648 unknowns
  ASSERT_GE(lower.rows(), 10000);
  using Get = int (*)();
  using Set = void (*)(int);
  const auto get = reinterpret_cast<Get>(::dlsym(RTLD_DEFAULT, "omp_get_max_active_levels"));
  const auto set = reinterpret_cast<Set>(::dlsym(RTLD_DEFAULT, "omp_set_max_active_levels"));
  if (set != nullptr) set(3);
  CholmodSolver solver;
  solver.factorize(lower);
  if (get != nullptr) {
    EXPECT_EQ(get(), 3);
  }
  const Eigen::SparseMatrix<double> full = lower.selfadjointView<Eigen::Lower>();
  VecX b = VecX::LinSpaced(lower.rows(), -1, 2), x = b, y = b;
  solver.solve(x);
  solver.solve_cholmod(y);
  EXPECT_LT((x - y).norm(), 1e-12 * y.norm());
  EXPECT_LT((full * x - b).norm(), 1e-12 * b.norm());
}

// Large factors are solved in two lanes of the elimination tree on two threads: the answer must
// not depend on the thread count (bit for bit), must match cholmod_solve2, and the lanes must
// share the work (nested dissection balances a grid: the heavier lane and the top together read
// under 70% of the entries).
TEST(KelvinSolver, TwoLaneSolveIsExactAndIndependentOfThreads) {
  const Eigen::SparseMatrix<double> lower = grid_matrix(26, 5);  // 17,576 unknowns, METIS
  CholmodSolver solver;
  solver.factorize(lower);
  EXPECT_LT(solver.critical_share(), 0.7);
  ASSERT_GT(solver.factor_megabytes(), 16.0);  // over 1M entries: solved on two threads (kTwoLaneMin)
  std::mt19937 rng(6);
  std::normal_distribution<double> g;
  std::bernoulli_distribution keep(0.01);
  const Eigen::SparseMatrix<double> full = lower.selfadjointView<Eigen::Lower>();
  for (int trial = 0; trial < 3; ++trial) {
    VecX b = VecX::Zero(lower.rows());
    for (Eigen::Index i = 0; i < b.size(); ++i)
      if (trial == 0 || keep(rng)) b[i] = g(rng);
    VecX one = b, two = b, ref = b;
    solver.set_solve_threads(1);
    solver.solve(one);
    solver.set_solve_threads(2);
    solver.solve(two);
    solver.solve_cholmod(ref);
    EXPECT_EQ((one - two).norm(), 0.0) << trial;
    EXPECT_LT((two - ref).norm(), 1e-12 * ref.norm()) << trial;
    EXPECT_LT((full * two - b).norm(), 1e-12 * b.norm()) << trial;
  }
}

// Two unconnected grids: the elimination tree is a forest of two trees, which the plan deals to
// the two lanes (critical path: the larger tree, 59% of the entries).
TEST(KelvinSolver, TwoLaneSolveOfAForest) {
  const Eigen::SparseMatrix<double> a = grid_matrix(24, 7), b = grid_matrix(22, 8);
  std::vector<Eigen::Triplet<double>> t;
  for (int k = 0; k < a.outerSize(); ++k)
    for (Eigen::SparseMatrix<double>::InnerIterator it(a, k); it; ++it) t.emplace_back(it.row(), it.col(), it.value());
  const auto na = static_cast<int>(a.rows());
  for (int k = 0; k < b.outerSize(); ++k)
    for (Eigen::SparseMatrix<double>::InnerIterator it(b, k); it; ++it)
      t.emplace_back(na + it.row(), na + it.col(), it.value());
  Eigen::SparseMatrix<double> lower(na + b.rows(), na + b.rows());
  lower.setFromTriplets(t.begin(), t.end());
  CholmodSolver solver;
  solver.factorize(lower);
  EXPECT_LT(solver.critical_share(), 0.62);
  const VecX rhs = VecX::LinSpaced(lower.rows(), -1, 2);
  VecX one = rhs, two = rhs, ref = rhs;
  solver.set_solve_threads(1);
  solver.solve(one);
  solver.set_solve_threads(2);
  solver.solve(two);
  solver.solve_cholmod(ref);
  EXPECT_EQ((one - two).norm(), 0.0);
  EXPECT_LT((two - ref).norm(), 1e-12 * ref.norm());
  const Eigen::SparseMatrix<double> full = lower.selfadjointView<Eigen::Lower>();
  EXPECT_LT((full * two - rhs).norm(), 1e-12 * rhs.norm());
}

// A saved factor whose supernode layout is inconsistent (one block one entry longer than its
// rows × columns) is refused on load: the solve would otherwise read other supernodes' values.
TEST(KelvinSolver, LoadRefusesAnInconsistentSupernodeLayout) {
  CholmodSolver a, b;
  a.factorize(grid_matrix(8, 9));
  std::stringstream io;
  a.save(io);
  std::string bytes = io.str();
  std::uint64_t sizes[8];
  std::memcpy(sizes, bytes.data(), sizeof sizes);
  const std::size_t n = sizes[0], nsuper = sizes[1];
  ASSERT_GE(nsuper, 2u);
  // Layout: sizes, Perm (n), ColCount (n), super, pi, px (nsuper + 1 each), s, x.
  const std::size_t px1 = sizeof sizes + 4 * (2 * n + 2 * (nsuper + 1) + 1);
  int px;
  std::memcpy(&px, bytes.data() + px1, 4);
  std::stringstream good(bytes);
  ASSERT_TRUE(b.load(good));
  ++px;
  std::memcpy(bytes.data() + px1, &px, 4);
  std::stringstream bad(bytes);
  EXPECT_FALSE(b.load(bad));
  VecX x = VecX::Ones(static_cast<Eigen::Index>(n));  // no factor now, not a half-read one
  EXPECT_THROW(b.solve(x), std::logic_error);
  EXPECT_EQ(b.size(), 0);
}

// The boundary response (boundary_response.hpp) of a 1,728-unknown matrix and 700 random sparse
// boundary columns: single columns against Eigen's LDLᵀ solve of −A_Ω∂ e_b; all 700 changes at
// once (1.2M entries: two threads by default) the same bits on one thread and on two, and equal
// to the solve of their sum.
TEST(KelvinSolver, BoundaryResponseColumnsAndTheirSum) {
  const Eigen::SparseMatrix<double> lower = grid_matrix(12, 5);
  const Eigen::Index n = lower.rows(), nb = 700;
  CholmodSolver solver;
  solver.factorize(lower);
  const Eigen::SparseMatrix<double> full = lower.selfadjointView<Eigen::Lower>();
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(full);
  ASSERT_EQ(ldlt.info(), Eigen::Success);
  std::mt19937 rng(8);
  std::uniform_int_distribution<Eigen::Index> row(0, n - 1);
  std::uniform_real_distribution<double> value(-1, 1);
  std::vector<Eigen::Triplet<double>> t;
  for (Eigen::Index b = 0; b < nb; ++b)
    for (int k = 0; k < 5; ++k) t.emplace_back(row(rng), b, value(rng));
  Eigen::SparseMatrix<double> a_ob(n, nb);
  a_ob.setFromTriplets(t.begin(), t.end());
  BoundaryResponse response;
  response.build(solver, a_ob, {});
  EXPECT_DOUBLE_EQ(response.megabytes(), 8e-6 * static_cast<double>(n * nb));
  for (const Eigen::Index b : {Eigen::Index{0}, Eigen::Index{63}, Eigen::Index{64}, Eigen::Index{399}, nb - 1}) {
    VecX column = VecX::Zero(n);
    response.apply({{static_cast<std::size_t>(b), 1.0}}, column);
    const VecX expected = ldlt.solve(VecX(-a_ob.col(b)));
    EXPECT_LE((column - expected).cwiseAbs().maxCoeff(), 1e-12 * expected.cwiseAbs().maxCoeff()) << "column " << b;
  }
  std::vector<std::pair<std::size_t, double>> changes;
  VecX d = VecX::Zero(nb);
  for (Eigen::Index b = nb - 1; b >= 0; --b) changes.emplace_back(static_cast<std::size_t>(b), d[b] = value(rng));
  VecX one = VecX::Zero(n), two = VecX::Zero(n), automatic = VecX::Zero(n);
  response.apply(changes, one, 1);
  response.apply(changes, two, 2);
  response.apply(changes, automatic);
  EXPECT_EQ((one - two).cwiseAbs().maxCoeff(), 0);
  EXPECT_EQ((one - automatic).cwiseAbs().maxCoeff(), 0);
  const VecX expected = ldlt.solve(VecX(-(a_ob * d)));
  EXPECT_LE((one - expected).cwiseAbs().maxCoeff(), 1e-11 * expected.cwiseAbs().maxCoeff());
}

// The elapsed-time estimate: linear to 0.9 of the predicted time, continuous and increasing past
// it, below 1 however long the work runs, 0 without a prediction.
TEST(KelvinSolver, ElapsedFractionIsLinearThenApproachesOne) {
  EXPECT_EQ(ElapsedProgress::fraction(0, 2), 0);
  EXPECT_DOUBLE_EQ(ElapsedProgress::fraction(1, 2), 0.5);
  EXPECT_DOUBLE_EQ(ElapsedProgress::fraction(1.8, 2), 0.9);
  EXPECT_NEAR(ElapsedProgress::fraction(1.8 + 1e-9, 2), 0.9, 1e-9);
  double last = 0;
  for (double r = 0.01; r < 1000; r *= 1.1) {
    const double f = ElapsedProgress::fraction(r, 1);
    EXPECT_GT(f, last) << r;
    EXPECT_LT(f, 1) << r;
    last = f;
  }
  EXPECT_EQ(ElapsedProgress::fraction(5, 0), 0);
  EXPECT_EQ(ElapsedProgress::fraction(5, std::nan("")), 0);
}

// The ticker reports from its own thread while the work runs (here: until it has reported three
// times), increasing and below 1, and nothing after it is destroyed.
TEST(KelvinSolver, ElapsedProgressReportsUntilDestroyed) {
  std::mutex m;
  std::condition_variable cv;
  std::vector<double> seen;
  {
    const ElapsedProgress ticker(
        [&](double f) {
          const std::lock_guard<std::mutex> lock(m);
          seen.push_back(f);
          cv.notify_one();
        },
        0.05, std::chrono::milliseconds(1));
    std::unique_lock<std::mutex> lock(m);
    ASSERT_TRUE(cv.wait_for(lock, std::chrono::seconds(60), [&] { return seen.size() >= 3; }));
  }
  const size_t count = seen.size();
  ASSERT_GE(count, 3u);
  for (size_t i = 0; i < count; ++i) {
    EXPECT_GT(seen[i], 0) << i;
    EXPECT_LT(seen[i], 1) << i;
    if (i > 0) {
      EXPECT_GT(seen[i], seen[i - 1]) << i;
    }
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_EQ(seen.size(), count);  // joined: no report after the destructor
}

// factorize(done) reports the analysis's share as soon as it is analysed (both orderings), then
// only larger fractions below 1, and the same factor as without a callback.
TEST(KelvinSolver, FactorizationReportsItsProgress) {
  for (const int n : {10, 24}) {  // AMD (1,000 unknowns), METIS (13,824)
    const Eigen::SparseMatrix<double> lower = grid_matrix(n, 3);
    std::vector<double> seen;
    std::mutex m;
    CholmodSolver with, without;
    with.factorize(lower, [&](double f) {
      const std::lock_guard<std::mutex> lock(m);
      seen.push_back(f);
    });
    without.factorize(lower);
    ASSERT_FALSE(seen.empty()) << n;
    EXPECT_GT(seen.front(), 0) << n;
    for (size_t i = 0; i < seen.size(); ++i) {
      EXPECT_LT(seen[i], 1) << n;
      if (i > 0) {
        EXPECT_GT(seen[i], seen[i - 1]) << n;
      }
    }
    VecX a = VecX::Ones(lower.rows()), b = a;
    with.solve(a);
    without.solve(b);
    EXPECT_EQ((a - b).cwiseAbs().maxCoeff(), 0) << n;
  }
}
