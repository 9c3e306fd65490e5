// max_violated_halfspaces against an exact LP oracle (CGAL's solver over Gmpzf); the weighted
// eigenvalue bound against points in every cell; facet areas.
#include <CGAL/Gmpzf.h>
#include <CGAL/QP_functions.h>
#include <CGAL/QP_models.h>
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <random>
#include <vector>

#include <Eigen/Eigenvalues>

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

double largest_eigenvalue(const MatX3& A, const VecX& w, const std::vector<Eigen::Index>& set) {
  Mat3 sum = Mat3::Zero();
  for (Eigen::Index k : set) sum += w[k] * A.row(k).transpose() * A.row(k);
  return Eigen::SelfAdjointEigenSolver<Mat3>(sum).eigenvalues()[2];
}

// λ_max(Σ_{V(p)} w_k a_k a_kᵀ) over points p = t (v + δ(±a_i ± a_j)) far out beside every
// arrangement vertex v = ±(a_i × a_j): points of every cell around v, so in general position the
// largest is the exact maximum over all points, found without a sweep.
double largest_over_points(const MatX3& A, const VecX& w) {
  double best = 0;
  for (Eigen::Index i = 0; i < A.rows(); ++i)
    for (Eigen::Index j = i + 1; j < A.rows(); ++j) {
      const Vec3 ai = A.row(i), aj = A.row(j), c = ai.cross(aj);
      if (c.norm() < 1e-9) continue;
      for (double side : {-1.0, 1.0}) {
        const Vec3 v = side * c.normalized();
        for (double si : {-1.0, 1.0})
          for (double sj : {-1.0, 1.0}) {
            // A small step off v into the cell where a_i . d has sign si and a_j . d has sign sj.
            const Vec3 d = v + 1e-7 * (si * ai + sj * aj);
            std::vector<Eigen::Index> violated;
            for (Eigen::Index k = 0; k < A.rows(); ++k)
              if (A.row(k).dot(1e12 * d) > 1.0) violated.push_back(k);  // b = 1, p = 1e12 d
            best = std::max(best, largest_eigenvalue(A, w, violated));
          }
      }
    }
  return best;
}

// The weighted bound of the area-weighted hulls: never below λ_max at a point (random points,
// and points in every cell of the arrangement), equal to the largest of those in general position,
// and the sum of orthogonal rows' weights where that is known.
TEST(MaxViolated, EigenvalueBoundHoldsEverywhereAndIsExactInGeneralPosition) {
  std::mt19937 rng(4242);
  std::normal_distribution<double> gauss;
  std::uniform_real_distribution<double> weight(0.1, 3.0);
  for (int n : {4, 5, 8, 13, 30, 60}) {
    for (int trial = 0; trial < 4; ++trial) {
      MatX3 A(n, 3);
      VecX w(n);
      for (int k = 0; k < n; ++k) {
        A.row(k) = Vec3(gauss(rng), gauss(rng), gauss(rng)).normalized().transpose();
        w[k] = weight(rng);
      }
      SCOPED_TRACE(::testing::Message() << "n=" << n << " trial=" << trial);
      const double bound = max_violated_eigenvalue_bound(A, w);
      const double attained = largest_over_points(A, w);
      EXPECT_GE(bound, attained);
      EXPECT_NEAR(bound, attained, 1e-8 * bound);
      for (int s = 0; s < 2000; ++s) {  // rows are violated only outside b = 1, any distance out
        const Vec3 p = Vec3(gauss(rng), gauss(rng), gauss(rng)) * std::exp(3 * gauss(rng));
        std::vector<Eigen::Index> violated;
        for (Eigen::Index k = 0; k < n; ++k)
          if (A.row(k).dot(p) > 1.0) violated.push_back(k);
        EXPECT_LE(largest_eigenvalue(A, w, violated), bound);
      }
    }
  }
  // A cube's rows: one of each opposite pair at a time, orthogonal, so the largest weight.
  const MatX3 cube = rows({{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}});
  EXPECT_NEAR(max_violated_eigenvalue_bound(cube, VecX::Ones(6)), 1.0, 1e-8);
  VecX w(6);
  w << 1, 2, 3, 4, 6, 5;
  EXPECT_NEAR(max_violated_eigenvalue_bound(cube, w), 6.0, 1e-8);
  // Degenerate arrangements (a prism's side normals on one great circle, lattice normals): an
  // upper bound still.
  const MatX3 prism = unit_rows(rows({{1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {-1, 1, 0}, {-1, 0, 0}, {-1, -1, 0}, {0, -1, 0}, {1, -1, 0}, {0, 0, 1}, {0, 0, -1}}));
  EXPECT_GE(max_violated_eigenvalue_bound(prism, VecX::Ones(10)), largest_over_points(prism, VecX::Ones(10)));
  std::vector<Vec3> dirs;
  for (int x = -1; x <= 1; ++x)
    for (int y = -1; y <= 1; ++y)
      for (int z = -1; z <= 1; ++z)
        if (x || y || z) dirs.emplace_back(x, y, z);
  MatX3 lattice(static_cast<Eigen::Index>(dirs.size()), 3);
  for (std::size_t k = 0; k < dirs.size(); ++k) lattice.row(static_cast<Eigen::Index>(k)) = dirs[k].normalized().transpose();
  const VecX ones = VecX::Ones(lattice.rows());
  EXPECT_GE(max_violated_eigenvalue_bound(lattice, ones), largest_over_points(lattice, ones));
}

// Each row's facet area: a box's faces; a hull's areas sum to its surface; a row that only
// touches the set gets none.
TEST(FacetAreas, AreTheFacetsOwnAreasInRowOrder) {
  std::vector<Vec3> corners;
  for (int k = 0; k < 8; ++k) corners.emplace_back(k & 1 ? 0.5 : 0, k & 2 ? 2 : 0, k & 4 ? 3 : 0);
  const Polytope box = polytope_from_points(corners, "box");
  const VecX area = facet_areas(box);
  ASSERT_EQ(area.size(), 6);
  for (Eigen::Index r = 0; r < 6; ++r) {
    const Vec3 a = box.A.row(r).cwiseAbs();
    const double expected = a.x() > 0.5 ? 6.0 : a.y() > 0.5 ? 1.5
                                                            : 1.0;  // 2×3, 0.5×3, 0.5×2
    EXPECT_NEAR(area[r], expected, 1e-12) << "row " << r;
  }
  // A row through one edge of the unit cube only: a valid half-space, no facet.
  MatX3 A = rows({{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}, {1, 1, 0}});
  VecX b(7);
  b << 1, 0, 1, 0, 1, 0, 2;
  const Polytope cut = make_polytope(A, b, "cut");
  const VecX cut_area = facet_areas(cut);
  for (Eigen::Index r = 0; r < 6; ++r) EXPECT_NEAR(cut_area[r], 1.0, 1e-12) << "row " << r;
  EXPECT_EQ(cut_area[6], 0.0);
}

TEST(MaxViolated, ParallelRowsFallBack) {
  EXPECT_EQ(max_violated_halfspaces(rows({{1, 0, 0}, {1, 0, 0}, {-1, 0, 0}})), 2);
}

}  // namespace
}  // namespace distlab
