// make_polytope and polytope_from_points: vertices, outward faces, merged rows, errors.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "distlab/geometry/error.hpp"
#include "distlab/geometry/polytope.hpp"

namespace distlab {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

MatX3 rows(std::initializer_list<Vec3> list) {
  MatX3 A(static_cast<Eigen::Index>(list.size()), 3);
  int i = 0;
  for (const Vec3& v : list) A.row(i++) = v.transpose();
  return A;
}

VecX vec(std::initializer_list<double> list) {
  VecX b(static_cast<Eigen::Index>(list.size()));
  int i = 0;
  for (double x : list) b[i++] = x;
  return b;
}

const MatX3 kCubeA = rows({{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}});

// Runs f, expecting InvalidInput; returns it so the test can look at field and message.
InvalidInput invalid(const std::function<void()>& f) {
  try {
    f();
  } catch (const InvalidInput& e) {
    return e;
  }
  ADD_FAILURE() << "expected InvalidInput";
  return InvalidInput("<none>", "<none>");
}

Vec3 centroid(const Polytope& P) {
  Vec3 c = Vec3::Zero();
  for (const Vec3& v : P.vertices) c += v;
  return c / static_cast<double>(P.vertices.size());
}

double signed_volume(const Polytope& P) {
  double vol = 0;
  for (const auto& f : P.faces)
    vol += P.vertices[f[0]].dot(P.vertices[f[1]].cross(P.vertices[f[2]])) / 6.0;
  return vol;
}

// Faces are outward (counter-clockwise seen from outside) and close up into a surface.
void expect_outward_closed(const Polytope& P) {
  const Vec3 c = centroid(P);
  for (const auto& f : P.faces) {
    const Vec3 p = P.vertices[f[0]], q = P.vertices[f[1]], r = P.vertices[f[2]];
    EXPECT_GT((q - p).cross(r - p).dot((p + q + r) / 3 - c), 0);
  }
  EXPECT_GT(signed_volume(P), 0);
  EXPECT_EQ(P.faces.size(), 2 * P.vertices.size() - 4);  // Euler, triangulated sphere
}

// Every vertex lies in the set and is a corner: at least 3 tight rows of full rank.
void expect_vertices_are_corners(const Polytope& P, double tol) {
  for (const Vec3& v : P.vertices) {
    std::vector<Vec3> tight;
    for (int i = 0; i < P.rows(); ++i) {
      const double slack = P.b[i] - P.A.row(i).dot(v);
      EXPECT_GE(slack, -tol);
      if (std::abs(slack) <= tol) tight.emplace_back(P.A.row(i).transpose());
    }
    Eigen::MatrixXd T(static_cast<Eigen::Index>(tight.size()), 3);
    for (std::size_t k = 0; k < tight.size(); ++k)
      T.row(static_cast<Eigen::Index>(k)) = tight[k].transpose();
    EXPECT_EQ(Eigen::FullPivLU<Eigen::MatrixXd>(T).rank(), 3) << "not a corner: " << v.transpose();
  }
}

TEST(MakePolytope, UnitCube) {
  const Polytope P = make_polytope(kCubeA, VecX::Constant(6, 0.5), "a");
  EXPECT_EQ(P.rows(), 6);
  ASSERT_EQ(P.vertices.size(), 8u);
  EXPECT_EQ(P.faces.size(), 12u);
  for (const Vec3& v : P.vertices) EXPECT_NEAR(v.cwiseAbs().maxCoeff(), 0.5, 1e-15);
  for (const Vec3& v : P.vertices) EXPECT_NEAR(v.cwiseAbs().minCoeff(), 0.5, 1e-15);
  expect_outward_closed(P);
  EXPECT_NEAR(signed_volume(P), 1.0, 1e-12);
}

TEST(MakePolytope, NormalisesRowsAndKeepsRedundantOnes) {
  MatX3 A(7, 3);
  A << 2, 0, 0, -1, 0, 0, 0, 3, 0, 0, -1, 0, 0, 0, 1, 0, 0, -4, 1, 1, 1;
  const Polytope P = make_polytope(A, vec({2, 1, 3, 1, 1, 4, 100}), "a");
  ASSERT_EQ(P.rows(), 7);  // x + y + z <= 100 is redundant but stays
  for (int i = 0; i < 7; ++i) EXPECT_NEAR(P.A.row(i).norm(), 1.0, 1e-15);
  EXPECT_NEAR(P.b[0], 1.0, 1e-15);
  EXPECT_NEAR(P.b[5], 1.0, 1e-15);
  EXPECT_NEAR(P.b[6], 100 / std::sqrt(3.0), 1e-12);
  EXPECT_EQ(P.vertices.size(), 8u);
  EXPECT_NEAR(signed_volume(P), 8.0, 1e-12);  // [-1,1]^3
}

TEST(MakePolytope, TetrahedronFacesOutward) {
  // Four points take a different path through CGAL's hull; it must be outward too.
  const Polytope P = make_polytope(rows({{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}}),
                                   VecX::Ones(4), "t");
  EXPECT_EQ(P.vertices.size(), 4u);
  EXPECT_EQ(P.faces.size(), 4u);
  expect_outward_closed(P);
  expect_vertices_are_corners(P, 1e-12);
}

TEST(MakePolytope, DegenerateVerticesAreDeduplicated) {
  // Square pyramid: four side planes meet in the apex, so several triples give it.
  const Polytope P = make_polytope(
      rows({{1, 0, 1}, {-1, 0, 1}, {0, 1, 1}, {0, -1, 1}, {0, 0, -1}}), vec({1, 1, 1, 1, 1}), "p");
  // Normalised offsets 1/sqrt(2): apex at z = 1, base square at z = -1 of half-width 2.
  EXPECT_EQ(P.vertices.size(), 5u);
  expect_outward_closed(P);
  expect_vertices_are_corners(P, 1e-12);
}

TEST(MakePolytope, RandomPolytopesHaveAllTheirCorners) {
  std::mt19937 rng(42);
  std::normal_distribution<double> gauss;
  std::uniform_real_distribution<double> unif(-1, 1);
  for (int trial = 0; trial < 20; ++trial) {
    const int n = 8 + trial;
    MatX3 A(n, 3);
    VecX b(n);
    for (int i = 0; i < n; ++i) {
      A.row(i) = Vec3(gauss(rng), gauss(rng), gauss(rng)).normalized().transpose();
      b[i] = 0.5 + 0.5 * (unif(rng) + 1);
    }
    A.topRows(6) = kCubeA;  // keep it bounded
    b.head(6).setConstant(1.5);
    const Polytope P = make_polytope(A, b, "a");
    expect_outward_closed(P);
    expect_vertices_are_corners(P, 1e-9);
    // No corner is missing: random points of the set lie inside every face plane.
    for (int s = 0; s < 200; ++s) {
      const Vec3 x(1.5 * unif(rng), 1.5 * unif(rng), 1.5 * unif(rng));
      if (((A * x) - b).maxCoeff() > 0) continue;
      for (const auto& f : P.faces) {
        const Vec3 p = P.vertices[f[0]], q = P.vertices[f[1]], r = P.vertices[f[2]];
        EXPECT_LE((q - p).cross(r - p).normalized().dot(x - p), 1e-9);
      }
    }
  }
}

TEST(MakePolytope, Errors) {
  const VecX half = VecX::Constant(6, 0.5);
  auto e = invalid([&] {
    make_polytope(kCubeA, vec({0, -1, 0.5, 0.5, 0.5, 0.5}), "a");  // x <= 0 and x >= 1
  });
  EXPECT_EQ(e.field(), "a");
  EXPECT_NE(std::string(e.what()).find("empty polytope"), std::string::npos) << e.what();

  e = invalid([&] { make_polytope(kCubeA.topRows(3), half.head(3), "b"); });
  EXPECT_EQ(e.field(), "b");
  EXPECT_NE(std::string(e.what()).find("unbounded polytope"), std::string::npos) << e.what();

  e = invalid([&] { make_polytope(kCubeA, vec({0, 0, 0.5, 0.5, 0.5, 0.5}), "c"); });  // x = 0
  EXPECT_EQ(e.field(), "c");
  EXPECT_NE(std::string(e.what()).find("flat polytope"), std::string::npos) << e.what();

  MatX3 bad = kCubeA;
  bad(2, 1) = kNaN;
  e = invalid([&] { make_polytope(bad, half, "d"); });
  EXPECT_EQ(e.field(), "d.A[2]");

  bad = kCubeA;
  bad(4, 0) = std::numeric_limits<double>::infinity();
  e = invalid([&] { make_polytope(bad, half, "d"); });
  EXPECT_EQ(e.field(), "d.A[4]");

  VecX badb = half;
  badb[3] = kNaN;
  e = invalid([&] { make_polytope(kCubeA, badb, "e"); });
  EXPECT_EQ(e.field(), "e.b[3]");

  bad = kCubeA;
  bad.row(5).setZero();
  e = invalid([&] { make_polytope(bad, half, "f"); });
  EXPECT_EQ(e.field(), "f.A[5]");
  EXPECT_NE(std::string(e.what()).find("zero"), std::string::npos) << e.what();

  e = invalid([&] { make_polytope(MatX3(0, 3), VecX(0), "g"); });
  EXPECT_EQ(e.field(), "g.A");

  e = invalid([&] { make_polytope(kCubeA, VecX::Ones(5), "h"); });
  EXPECT_EQ(e.field(), "h.b");
}

std::vector<Vec3> cube_corners(const Mat3& R) {
  std::vector<Vec3> pts;
  for (int x : {-1, 1})
    for (int y : {-1, 1})
      for (int z : {-1, 1}) pts.emplace_back(R * Vec3(x, y, z));
  return pts;
}

TEST(PolytopeFromPoints, CubeGivesSixRows) {
  std::vector<Vec3> pts = cube_corners(Mat3::Identity());
  pts.emplace_back(1, 0.25, 0.5);  // on a face: not a vertex
  pts.emplace_back(0.5, 0, 0);     // inside
  const Polytope P = polytope_from_points(pts, "m");
  ASSERT_EQ(P.rows(), 6);
  for (int i = 0; i < 6; ++i) {
    EXPECT_NEAR(P.A.row(i).cwiseAbs().maxCoeff(), 1.0, 1e-15);
    EXPECT_NEAR(P.b[i], 1.0, 1e-15);
  }
  EXPECT_EQ(P.vertices.size(), 8u);
  EXPECT_EQ(P.faces.size(), 12u);
  expect_outward_closed(P);
}

TEST(PolytopeFromPoints, RotatedCubeStillGivesSixRows) {
  // Rounding makes the rotated corners only nearly coplanar.
  const Mat3 R = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  std::vector<Vec3> pts = cube_corners(R);
  pts.emplace_back(Vec3::Zero());  // interior point: dropped
  const Polytope P = polytope_from_points(pts, "m");
  EXPECT_EQ(P.rows(), 6);
  EXPECT_EQ(P.vertices.size(), 8u);
  expect_vertices_are_corners(P, 1e-12);
}

TEST(PolytopeFromPoints, RandomPointsAreInsideAndVerticesAreInputs) {
  std::mt19937 rng(7);
  std::normal_distribution<double> gauss;
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<Vec3> pts;
    for (int i = 0; i < 10 + 5 * trial; ++i) pts.emplace_back(gauss(rng), gauss(rng), gauss(rng));
    const Polytope P = polytope_from_points(pts, "m");
    for (int i = 0; i < P.rows(); ++i) EXPECT_NEAR(P.A.row(i).norm(), 1.0, 1e-14);
    for (const Vec3& p : pts) EXPECT_LE((P.A * p - P.b).maxCoeff(), 1e-9);
    for (const Vec3& v : P.vertices)
      EXPECT_TRUE(std::find(pts.begin(), pts.end(), v) != pts.end()) << v.transpose();
    expect_outward_closed(P);
    expect_vertices_are_corners(P, 1e-9);
    // Round trip: the rows describe the same corners.
    const Polytope Q = make_polytope(P.A, P.b, "q");
    ASSERT_EQ(Q.vertices.size(), P.vertices.size());
    for (const Vec3& v : Q.vertices) {
      double nearest = 1e300;
      for (const Vec3& w : P.vertices) nearest = std::min(nearest, (v - w).norm());
      EXPECT_LE(nearest, 1e-9);
    }
  }
}

TEST(PolytopeFromPoints, DegenerateInputsThrow) {
  const auto expect_field = [](const std::vector<Vec3>& pts, const std::string& field) {
    EXPECT_EQ(invalid([&] { polytope_from_points(pts, "m"); }).field(), field);
  };
  expect_field({}, "m.points");
  expect_field({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, "m.points");                        // 3 points
  expect_field({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {2, 3, 0}}, "m.points");  // plane
  expect_field({{0, 0, 0}, {1, 1, 1}, {2, 2, 2}, {3, 3, 3}}, "m.points");             // line
  expect_field({{1, 1, 1}, {1, 1, 1}, {1, 1, 1}, {1, 1, 1}}, "m.points");             // one point
  expect_field({{0, 0, 0}, {1, 0, 0}, {0, kNaN, 0}, {0, 0, 1}}, "m.points[2]");
}

}  // namespace
}  // namespace distlab
