// max_violated_halfspaces against an exact LP oracle (CGAL's solver over Gmpzf).
#include <CGAL/Gmpzf.h>
#include <CGAL/QP_functions.h>
#include <CGAL/QP_models.h>
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <random>
#include <vector>

#include "distlab/geometry/error.hpp"
#include "distlab/geometry/polytope.hpp"

namespace distlab {
namespace {

// Exactly: is there a point x with a_i . x > b_i for every row i in `subset` (a bit mask)?
// Maximise t subject to a_i . x - t >= b_i, t <= 1; feasible iff the optimum t is > 0.
bool violable(const MatX3& A, const VecX& b, unsigned subset) {
  CGAL::Quadratic_program<double> lp(CGAL::LARGER, false, 0.0, false, 0.0);  // free variables
  int r = 0;
  for (int i = 0; i < A.rows(); ++i) {
    if (!(subset >> i & 1u)) continue;
    for (int j = 0; j < 3; ++j) lp.set_a(j, r, A(i, j));
    lp.set_a(3, r, -1.0);
    lp.set_b(r, b[i]);
    ++r;
  }
  lp.set_u(3, true, 1.0);
  lp.set_c(3, -1.0);  // minimise -t
  const auto sol = CGAL::solve_linear_program(lp, CGAL::Gmpzf());
  EXPECT_TRUE(sol.is_optimal());
  const int sign = CGAL::sign(sol.objective_value_numerator()) *
                   CGAL::sign(sol.objective_value_denominator());
  return sign < 0;
}

// Largest subset of rows one point violates, by brute force over subsets (largest first).
int oracle(const MatX3& A, const VecX& b) {
  const int n = static_cast<int>(A.rows());
  for (int size = n; size > 0; --size)
    for (unsigned s = 0; s < (1u << n); ++s)
      if (std::popcount(s) == size && violable(A, b, s)) return size;
  return 0;
}

MatX3 unit_rows(const MatX3& A) { return A.rowwise().normalized(); }

MatX3 rows(std::initializer_list<Vec3> list) {
  MatX3 A(static_cast<Eigen::Index>(list.size()), 3);
  int i = 0;
  for (const Vec3& v : list) A.row(i++) = v.transpose();
  return A;
}

// The origin is interior when b > 0, so only the row directions matter.
void expect_matches_oracle(const MatX3& A, int expected) {
  const VecX ones = VecX::Ones(A.rows());
  EXPECT_EQ(oracle(A, ones), expected);
  EXPECT_EQ(max_violated_halfspaces(unit_rows(A)), expected);
}

TEST(MaxViolated, Box) {
  expect_matches_oracle(rows({{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}}),
                        3);
}

TEST(MaxViolated, BoxWithDuplicatedRow) {
  // A redundant copy of +x is violated together with +x.
  expect_matches_oracle(
      rows({{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}, {2, 0, 0}}), 4);
}

TEST(MaxViolated, RegularTetrahedron) {
  // Normals sum to zero, so not all 4; d = -a_3 has a_i . d = 1/3 > 0 for the other three.
  expect_matches_oracle(rows({{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}}), 3);
}

TEST(MaxViolated, TriangularPrism) {
  // Side normals sum to zero: two sides plus a cap.
  const double s = std::sqrt(3.0);
  expect_matches_oracle(rows({{2, 0, 0}, {-1, s, 0}, {-1, -s, 0}, {0, 0, 1}, {0, 0, -1}}), 3);
}

TEST(MaxViolated, HexagonalPrism) {
  // Three of six side normals fit in an open half circle, plus a cap. All side circles meet
  // at +-z: the degenerate arrangement vertex the half-circle count exists for.
  MatX3 A(8, 3);
  for (int k = 0; k < 6; ++k)
    A.row(k) << std::cos(k * std::numbers::pi / 3), std::sin(k * std::numbers::pi / 3), 0;
  A.row(6) << 0, 0, 1;
  A.row(7) << 0, 0, -1;
  EXPECT_EQ(max_violated_halfspaces(A), 4);
  // Oracle on exactly representable directions of the same combinatorics.
  expect_matches_oracle(rows({{2, 0, 0}, {1, 2, 0}, {-1, 2, 0}, {-2, 0, 0}, {-1, -2, 0}, {1, -2, 0}, {0, 0, 1}, {0, 0, -1}}),
                        4);
}

TEST(MaxViolated, Octahedron) {
  // Eight normals in four antipodal pairs: at most one of each pair, and 4 is reached.
  MatX3 A(8, 3);
  int i = 0;
  for (int x : {-1, 1})
    for (int y : {-1, 1})
      for (int z : {-1, 1}) A.row(i++) << x, y, z;
  expect_matches_oracle(A, 4);
}

TEST(MaxViolated, RandomPolytopesMatchOracle) {
  std::mt19937 rng(12345);
  std::normal_distribution<double> gauss;
  std::uniform_real_distribution<double> offset(0.2, 2.0);
  const auto random_unit = [&] { return Vec3(gauss(rng), gauss(rng), gauss(rng)).normalized(); };
  for (int n = 4; n <= 10; ++n) {
    for (int trial = 0; trial < 12; ++trial) {
      // A jittered, randomly rotated regular tetrahedron surrounds the origin; more rows at random.
      const Mat3 R = Quat::UnitRandom().toRotationMatrix();
      MatX3 A(n, 3);
      const Vec3 tet[4] = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
      for (int k = 0; k < n; ++k) {
        const Vec3 a = k < 4 ? Vec3(R * tet[k].normalized() + 0.1 * random_unit()) : random_unit();
        A.row(k) = a.normalized().transpose();
      }
      VecX b(n);
      for (int k = 0; k < n; ++k) b[k] = offset(rng);
      SCOPED_TRACE(::testing::Message() << "n=" << n << " trial=" << trial << "\nA=\n"
                                        << A);
      ASSERT_NO_THROW(make_polytope(A, b, "p"));  // bounded with an interior: the premise
      EXPECT_EQ(max_violated_halfspaces(A), oracle(A, b));
    }
  }
}

TEST(MaxViolated, DegenerateLatticeNormalsMatchOracle) {
  // Normals from {-1,0,1}^3: many rows share great circles, so arrangement vertices are
  // highly degenerate. The oracle uses the integer rows (exact), the function unit rows.
  std::vector<Vec3> dirs;
  for (int x = -1; x <= 1; ++x)
    for (int y = -1; y <= 1; ++y)
      for (int z = -1; z <= 1; ++z)
        if (x || y || z) dirs.emplace_back(x, y, z);
  std::mt19937 rng(777);
  int tested = 0;
  while (tested < 40) {
    std::shuffle(dirs.begin(), dirs.end(), rng);
    const int n = 6 + tested % 5;
    MatX3 A(n, 3);
    for (int k = 0; k < n; ++k) A.row(k) = dirs[k].transpose();
    try {
      make_polytope(A, VecX::Ones(n), "p");
    } catch (const InvalidInput&) {
      continue;  // unbounded: not a regular polytope
    }
    SCOPED_TRACE(::testing::Message() << "A=\n"
                                      << A);
    EXPECT_EQ(max_violated_halfspaces(unit_rows(A)), oracle(A, VecX::Ones(n)));
    ++tested;
  }
}

// The O(n² log n) bound: equal to the exact count on random rows (general position, where each
// arrangement vertex has two ties), never below it on degenerate ones, and equal to the oracle on
// the random polytopes above.
TEST(MaxViolated, BoundEqualsExactInGeneralPositionAndNeverUndercounts) {
  std::mt19937 rng(4242);
  std::normal_distribution<double> gauss;
  for (int n : {4, 5, 8, 13, 30, 60, 120}) {
    for (int trial = 0; trial < 6; ++trial) {
      MatX3 A(n, 3);
      for (int k = 0; k < n; ++k) A.row(k) = Vec3(gauss(rng), gauss(rng), gauss(rng)).normalized().transpose();
      SCOPED_TRACE(::testing::Message() << "n=" << n << " trial=" << trial);
      EXPECT_EQ(max_violated_halfspaces_bound(A), max_violated_halfspaces(A));
    }
  }
  // Degenerate: a prism's 8 side normals on one great circle (the oracle is a subset search), and
  // lattice normals.
  // Integer rows for the oracle (exact), unit rows for the functions, as above.
  const MatX3 prism = rows({{1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {-1, 1, 0}, {-1, 0, 0}, {-1, -1, 0}, {0, -1, 0}, {1, -1, 0}, {0, 0, 1}, {0, 0, -1}});
  const int exact = max_violated_halfspaces(unit_rows(prism));
  EXPECT_EQ(exact, oracle(prism, VecX::Ones(10)));
  EXPECT_GE(max_violated_halfspaces_bound(unit_rows(prism)), exact);
  std::vector<Vec3> dirs;
  for (int x = -1; x <= 1; ++x)
    for (int y = -1; y <= 1; ++y)
      for (int z = -1; z <= 1; ++z)
        if (x || y || z) dirs.emplace_back(x, y, z);
  MatX3 lattice(static_cast<Eigen::Index>(dirs.size()), 3);
  for (std::size_t k = 0; k < dirs.size(); ++k) lattice.row(static_cast<Eigen::Index>(k)) = dirs[k].normalized().transpose();
  EXPECT_GE(max_violated_halfspaces_bound(lattice), max_violated_halfspaces(lattice));
}

TEST(MaxViolated, ParallelRowsFallBack) {
  EXPECT_EQ(max_violated_halfspaces(rows({{1, 0, 0}, {1, 0, 0}, {-1, 0, 0}})), 2);
}

}  // namespace
}  // namespace distlab
