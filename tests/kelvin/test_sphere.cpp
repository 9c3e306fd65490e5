// Sphere with constant σ against the exact solution (Section IV, eqs. 14–17); the unit cube
// (Table I) against its known capacitance and its exact boundary.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

#include "child_test.hpp"
#include "distlab/kelvin/tet_mesh.hpp"
#include "distlab/mesh/primitives.hpp"
#include "sphere_fixture.hpp"

using namespace distlab;
using namespace distlab::kelvin;
using namespace distlab::kelvin::testing;

namespace {

struct Errors {
  double h_rms = 0, h_max = 0, g_rms = 0;
};

Errors measure(double lx, const Sphere& s) {
  Field field = Field::prepare(sphere_mesh(s), sphere_options(lx));
  field.set_sigma(constant_sigma(s.sigma));
  Errors e;
  const auto points = shell_points(s, 1.1, 4.0, 2000);
  for (const Vec3& x : points) {
    const Sample q = field.query(x);
    EXPECT_EQ(q.status, Status::ok);
    const double dh = q.h - s.h(x);
    e.h_rms += dh * dh;
    e.h_max = std::max(e.h_max, std::abs(dh));
    e.g_rms += (q.gradient - s.gradient(x)).squaredNorm() / s.gradient(x).squaredNorm();
  }
  e.h_rms = std::sqrt(e.h_rms / points.size());
  e.g_rms = std::sqrt(e.g_rms / points.size());
  std::printf("lx %.4f  verts %ld  tets %ld  h rms %.3e max %.3e  grad rel rms %.3e  (mesh %.2fs build %.3fs decomp %.3fs solve %.4fs)\n",
              lx, field.stats().n_verts, field.stats().n_tets, e.h_rms, e.h_max, e.g_rms, field.stats().t_mesh,
              field.stats().t_build, field.stats().t_decomp, field.stats().t_solve);
  return e;
}

}  // namespace

TEST(KelvinSphere, ErrorsFallAsLxShrinks) {
  const Sphere s;
  const double lxs[] = {0.2, 0.1, 0.07};
  Errors prev;
  for (int i = 0; i < 3; ++i) {
    const Errors e = measure(lxs[i], s);
    if (i > 0) {
      const double order_h = std::log(prev.h_rms / e.h_rms) / std::log(lxs[i - 1] / lxs[i]);
      const double order_g = std::log(prev.g_rms / e.g_rms) / std::log(lxs[i - 1] / lxs[i]);
      std::printf("observed order: h %.2f  grad %.2f\n", order_h, order_g);
      // P1 elements: values converge at order 2, recovered gradients at order 1 (and better on
      // the smooth parts); pre-asymptotic meshes get a margin below those rates.
      EXPECT_GT(order_h, 1.0);
      EXPECT_GT(order_g, 0.8);
    }
    prev = e;
  }
}

namespace {

// The unit cube [−0.5, 0.5]³ with u = 1 on it: u → C/|x| far away, where C is its capacitance in
// units of 4πε₀ · side, 0.6606785 (Hwang & Mascagni, J. Appl. Phys. 95, 2004, random walks;
// Read 1997, boundary elements, agrees to 6 digits). V = u/G = u |x| (eq. 17), so V(0) = C.
constexpr double kCubeCapacitance = 0.6606785;

double cube_surface_distance(const Vec3& x) {
  const Vec3 q = x.cwiseAbs() - Vec3::Constant(0.5);
  const double outside = q.cwiseMax(0.0).norm();
  return outside > 0 ? outside : -q.maxCoeff();
}

struct CubeErrors {
  double capacitance = 0, boundary_max = 0;
  long n_verts = 0;
  int mesh_threads = 0;
};

CubeErrors measure_cube(double lx, double grading = 0, int mesh_threads = 0) {
  PrepareOptions o;
  o.lx = lx;
  o.grading = grading;
  o.mesh_threads = mesh_threads;
  Field field = Field::prepare(mesh::box(Vec3::Ones()), o);
  field.set_sigma(SigmaSpec{}, false);
  CubeErrors e;
  const Vec3 far(1e4, 3e3, 2e3);  // |y| ≈ 1e-4: V there is V(0) to ~1e-4 relative
  const double v0 = std::exp(-field.query(far).h) * far.norm();
  e.capacitance = std::abs(std::log(v0 / kCubeCapacitance));  // = the far-field error of h
  for (const Vec3& x : field.boundary_points()) e.boundary_max = std::max(e.boundary_max, cube_surface_distance(x));
  e.n_verts = field.stats().n_verts;
  e.mesh_threads = field.stats().mesh_threads;
  std::printf("cube threads %d  grading %.2f  lx %.3f  verts %ld  V(0) %.5f (C %.5f)  |ln(V0/C)| %.3e  boundary max dist %.2e = %.2f lx^2\n",
              e.mesh_threads, grading, lx, field.stats().n_verts, v0, kCubeCapacitance, e.capacitance, e.boundary_max,
              e.boundary_max / (lx * lx));
  return e;
}

}  // namespace

// Table I's object: the far field converges to the cube's capacitance and the meshed boundary
// lies on the cube (chord error O(l_x²)). Both failed when the polyhedron handed to Mesh_3 kept
// corner-to-corner triangles: the boundary bulged 0.18 m out and V(0) stayed 9% high at every l_x.
TEST(KelvinCube, CapacitanceConvergesAndBoundaryIsFaithful) {
  const double lxs[] = {0.2, 0.14, 0.1};
  CubeErrors prev;
  for (int i = 0; i < 3; ++i) {
    const CubeErrors e = measure_cube(lxs[i]);
    // Boundary vertices lie on the flat facets of the inverted polyhedron (edges ≤ l_x in x); a
    // face at distance d = 0.5 inverts to a sphere of radius 1/(2d), and a facet with edges ≤ c
    // leaves it by ≤ c²/(6R) in y: ≤ c² d/(3|x|²) ≤ (2/3) l_x² in x.
    EXPECT_LT(e.boundary_max, 2.0 / 3.0 * lxs[i] * lxs[i]);
    if (i > 0) {
      const double order = std::log(prev.capacitance / e.capacitance) / std::log(lxs[i - 1] / lxs[i]);
      std::printf("observed order of the capacitance: %.2f\n", order);
      // The cube's edges make u singular (r^(2/3)); the energy, hence C, converges at ≈ 4/3.
      EXPECT_GT(order, 1.0);
    }
    prev = e;
  }
  EXPECT_LT(prev.capacitance, 0.03);  // 2% measured; 8.7% before the fix
}

// The grading the graded-sizing tests use (PrepareOptions::grading).
constexpr double kGrading = 0.05;

// The cube's boundary is refined by longest-edge bisection before meshing: still bit-identical,
// also with the graded sizing (its distance lattice's values do not depend on the query order).
TEST(KelvinCube, MeshingIsDeterministic) {
  for (const double grading : {0.0, kGrading}) {
    PrepareOptions o;
    o.lx = 0.14;
    o.grading = grading;
    o.mesh_threads = 1;  // also what 0 (the default) chooses
    const Field a = Field::prepare(mesh::box(Vec3::Ones()), o);
    const Field b = Field::prepare(mesh::box(Vec3::Ones()), o);
    ASSERT_EQ(a.tet_mesh().points.rows(), b.tet_mesh().points.rows());
    ASSERT_EQ(a.tet_mesh().tets.rows(), b.tet_mesh().tets.rows());
    EXPECT_TRUE((a.tet_mesh().points.array() == b.tet_mesh().points.array()).all());
    EXPECT_TRUE((a.tet_mesh().tets.array() == b.tet_mesh().tets.array()).all());
  }
}

// The graded sizing (PrepareOptions::grading: finer at the sharp edges, where the cube's
// solution is singular, and growing with the distance from the inverted surface) reaches the
// paper's sizing's accuracy with fewer vertices: at l_x 0.08 it beats eq. 23 at l_x 0.05 on both
// counts (measured: 14954 against 26245 vertices, |ln(V(0)/C)| 6.30e-3 against 8.02e-3). The
// first graded sizing, which only coarsened, failed this (l_x 0.08, g 0.1: 5030 vertices, 1.62e-2).
TEST(KelvinCube, GradedSizingMeetsTheAccuracyWithFewerVertices) {
  const CubeErrors paper = measure_cube(0.05), graded = measure_cube(0.08, kGrading);
  EXPECT_LT(graded.n_verts, paper.n_verts);
  EXPECT_LT(graded.capacitance, paper.capacitance);
}

namespace {

// h against the sphere's closed form on the plane z = 0 in [−3, 3]² (as bench_kelvin's sizing
// table): almost all of it is the far field, which grading coarsens.
struct SphereGridErrors {
  double rms = 0;
  long n_verts = 0;
};

SphereGridErrors sphere_grid_errors(double lx, double grading) {
  const Sphere s;
  PrepareOptions o = sphere_options(lx);
  o.grading = grading;
  Field field = Field::prepare(sphere_mesh(s), o);
  field.set_sigma(constant_sigma(s.sigma));
  double sum = 0;
  long n = 0;
  constexpr int kGrid = 100;
  for (int i = 0; i < kGrid; ++i)
    for (int j = 0; j < kGrid; ++j) {
      const Vec3 x(-3 + 6.0 * (j + 0.5) / kGrid, -3 + 6.0 * (i + 0.5) / kGrid, 0);
      if ((x - s.centre).norm() <= s.radius) continue;
      const Sample q = field.query(x);
      EXPECT_EQ(q.status, Status::ok);
      sum += std::pow(q.h - s.h(x), 2), ++n;
    }
  SphereGridErrors e{std::sqrt(sum / static_cast<double>(n)), field.stats().n_verts};
  std::printf("sphere grading %.2f  lx %.3f  verts %ld  h rms on the grid %.3e\n", grading, lx, e.n_verts, e.rms);
  return e;
}

}  // namespace

// The sphere has no sharp edges: only the growth away from the surface acts, and it must not cost
// far-field accuracy. Measured at l_x 0.05: 8560 against 10421 vertices, h rms 5.69e-5 against
// 6.60e-5; the growth the first graded sizing was tested with (g 0.1) fails here (6002 vertices,
// 7.51e-5: it coarsens the far field too much).
TEST(KelvinSphere, GradedSizingMeetsTheAccuracyWithFewerVertices) {
  const SphereGridErrors paper = sphere_grid_errors(0.05, 0), graded = sphere_grid_errors(0.05, kGrading);
  EXPECT_LT(graded.n_verts, paper.n_verts);
  EXPECT_LE(graded.rms, paper.rms);
}

// Parallel refinement (PrepareOptions::mesh_threads > 1) makes another mesh on every run, but one
// as good: on the cube at l_x 0.08, with both sizings, the capacitance error within a tenth of the
// one-thread mesh's (measured: 0.5–3% apart, 3–5% more vertices), the boundary within the same
// chord bound, the vertex count within 10%. In a child process (child_test.hpp): CGAL's parallel
// refinement crashes now and then, and a crash runs it again.
TEST(KelvinCube, ParallelMeshingIsAsAccurateAsOneThread) {
  run_test_in_child("KelvinCubeInChild.ParallelMeshingIsAsAccurateAsOneThread");
}

TEST(KelvinCubeInChild, ParallelMeshingIsAsAccurateAsOneThread) {
  if (!is_child_test("KelvinCubeInChild.ParallelMeshingIsAsAccurateAsOneThread"))
    GTEST_SKIP() << "run in a child by KelvinCube.ParallelMeshingIsAsAccurateAsOneThread";
  for (const double grading : {0.0, kGrading}) {
    const CubeErrors one = measure_cube(0.08, grading, 1), two = measure_cube(0.08, grading, 2);
    EXPECT_EQ(one.mesh_threads, 1);
    EXPECT_EQ(two.mesh_threads, 2);
    EXPECT_NEAR(two.capacitance, one.capacitance, 0.1 * one.capacitance) << "grading " << grading;
    EXPECT_LT(two.boundary_max, 2.0 / 3.0 * 0.08 * 0.08);
    EXPECT_NEAR(static_cast<double>(two.n_verts), static_cast<double>(one.n_verts), 0.1 * static_cast<double>(one.n_verts));
  }
}

// Eq. 23's closed-form vertex bound (the automatic sizing's and the budget's).
TEST(KelvinMesher, Eq23VertexBoundIsItsClosedForm) {
  const double r = std::sqrt(3.0) / 2;  // the unit cube's corners from its centre, far_radius 1 (field.cpp)
  MeshingParams p;
  p.lx = 0.02;
  p.min_size = p.lx / (r * r);
  const double bound = eq23_vertex_bound(p);
  // ∫ dV_y / l_y³ ≤ 2 (4/3)π / (ρ l_x)³ with ρ l_x = √(min_size l_x) = l_x / r.
  EXPECT_NEAR(bound, kVerticesPerSizingIntegral * 2 * 4 * std::numbers::pi / 3 / std::pow(0.02 / r, 3), 1e-9 * bound);
  p.lx = 0.14;
  p.min_size = p.lx / (r * r);
  EXPECT_NEAR(eq23_vertex_bound(p), bound * std::pow(0.02 / 0.14, 3), 1e-9 * bound);
}
