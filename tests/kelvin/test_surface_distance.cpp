// The graded sizing's surface distance (surface_distance.hpp) against a brute-force minimum of
// CGAL's point–triangle distance over every triangle: exact near the surface, where the mesh
// follows it, and a lower bound everywhere (the mesh is never coarser than graded). Its edge
// distance: CGAL's exact query, bit for bit, wherever it is below the radius.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <thread>
#include <vector>

#include "distlab/mesh/cgal_surface.hpp"
#include "distlab/mesh/primitives.hpp"
#include "surface_distance.hpp"

namespace distlab::kelvin::sizing {
namespace {

// Two icospheres, one inside the other: a surface that is not convex seen from between them.
Polyhedron two_spheres() {
  return mesh::to_cgal_surface<K::Point_3>(
      mesh::merge(mesh::icosphere(1.0, 2), mesh::icosphere(0.4, 1, Vec3(0.2, -0.1, 0.05))));
}

double brute_force(const Polyhedron& poly, const K::Point_3& p) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto f : poly.faces()) {
    const auto h = poly.halfedge(f);
    const K::Triangle_3 t(poly.point(poly.target(h)), poly.point(poly.target(poly.next(h))), poly.point(poly.source(h)));
    best = std::min(best, CGAL::to_double(CGAL::squared_distance(p, t)));
  }
  return std::sqrt(best);
}

TEST(SurfaceDistance, ExactNearTheSurfaceALowerBoundEverywhere) {
  const Polyhedron poly = two_spheres();
  const SurfaceDistance distance(poly);
  const double cell = 2.0 / 256;  // the fine lattice: the bounding box's longest side / 256
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.3, 1.3);
  std::normal_distribution<double> g;
  int near = 0, far = 0;
  for (int i = 0; i < 4000; ++i) {
    K::Point_3 p(u(rng), u(rng), u(rng));
    if (i % 2 == 0) {  // half of them within a few cells of the outer sphere
      const Vec3 d = Vec3(g(rng), g(rng), g(rng)).normalized() * (1.0 + 3 * cell * (u(rng) / 1.3));
      p = K::Point_3(d.x(), d.y(), d.z());
    }
    const double exact = brute_force(poly, p), got = distance(p);
    ASSERT_LE(got, exact + 1e-14) << i << ": a lower bound";
    if (exact <= 2 * cell) {  // its fine cell's centre is within 4 cells: the exact query
      ++near;
      ASSERT_NEAR(got, exact, 1e-14) << i;
    } else {
      ++far;
      ASSERT_GT(got, 0.0) << i << ": off the surface, a positive bound";
    }
  }
  EXPECT_GT(near, 500);
  EXPECT_GT(far, 500);
}

TEST(EdgeDistance, ExactBelowTheRadiusALowerBoundEverywhere) {
  // A unit cube's 12 edges and two skew segments, the radius 4 l_x at l_x 0.03.
  EdgeDistance::Segments segments;
  for (int axis = 0; axis < 3; ++axis)
    for (int s = 0; s < 4; ++s) {
      double a[3], b[3];
      a[axis] = -0.5, b[axis] = 0.5;
      a[(axis + 1) % 3] = b[(axis + 1) % 3] = s % 2 == 0 ? -0.5 : 0.5;
      a[(axis + 2) % 3] = b[(axis + 2) % 3] = s / 2 == 0 ? -0.5 : 0.5;
      segments.emplace_back(K::Point_3(a[0], a[1], a[2]), K::Point_3(b[0], b[1], b[2]));
    }
  segments.emplace_back(K::Point_3(0.1, -0.3, 0.2), K::Point_3(0.9, 0.4, -0.7));
  segments.emplace_back(K::Point_3(-0.2, 0.05, 0.0), K::Point_3(-0.2001, 0.05, 0.3));
  const std::vector<K::Segment_3> all = segments;
  const double radius = 0.12;
  const EdgeDistance distance(std::move(segments), radius);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int near = 0, far = 0;
  for (int i = 0; i < 20000; ++i) {
    const double r = i % 10 == 0 ? std::pow(10.0, 6 * u(rng) + 3) : 1.0;  // some x far out (y near 0)
    const K::Point_3 x(r * u(rng), r * u(rng), r * u(rng));
    double brute = std::numeric_limits<double>::infinity();
    for (const auto& s : all) brute = std::min(brute, CGAL::to_double(CGAL::squared_distance(x, s)));
    brute = std::sqrt(brute);
    const double exact = distance.exact(x);
    ASSERT_NEAR(exact, brute, 1e-12 * (1 + brute)) << i;
    ASSERT_LE(distance.lower_bound(x), exact * (1 + 1e-12) + 1e-12) << i;
    const double got = distance(x);
    if (exact < radius) {
      ++near;
      ASSERT_EQ(got, exact) << i << ": bit for bit";
    } else {
      ++far;
      ASSERT_GE(got, radius) << i;
    }
  }
  EXPECT_GT(near, 1000);
  EXPECT_GT(far, 2000);
}

// The parallel mesher queries both distances from several threads at once (MeshingParams::threads):
// four threads, each its own order of the same points, through one shared object, answer what a
// fresh object answers one query at a time, bit for bit. Lattice cells filled by one thread and
// read by another (or filled by two at once) must hold the one value a cell has.
TEST(SurfaceDistance, ThreadsSharingOneObjectAnswerAsOneThread) {
  const Polyhedron poly = two_spheres();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.3, 1.3);
  std::vector<K::Point_3> points;
  for (int i = 0; i < 6000; ++i) points.emplace_back(u(rng), u(rng), u(rng));
  std::vector<double> one(points.size());
  {
    const SurfaceDistance fresh(poly);
    for (std::size_t i = 0; i < points.size(); ++i) one[i] = fresh(points[i]);
  }
  EdgeDistance::Segments segments;
  for (const auto e : poly.edges())
    if (e.idx() % 7 == 0) segments.emplace_back(poly.point(poly.source(poly.halfedge(e))), poly.point(poly.target(poly.halfedge(e))));
  const EdgeDistance::Segments kept = segments;
  std::vector<double> one_edge(points.size());
  {
    EdgeDistance::Segments copy = kept;
    const EdgeDistance fresh(std::move(copy), 0.1);
    for (std::size_t i = 0; i < points.size(); ++i) one_edge[i] = fresh(points[i]);
  }
  const SurfaceDistance shared(poly);
  const EdgeDistance shared_edges(std::move(segments), 0.1);
  constexpr int kThreads = 4;
  std::vector<std::vector<double>> got(kThreads, std::vector<double>(points.size())), got_edge = got;
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t)
    threads.emplace_back([&, t] {
      std::vector<std::size_t> order(points.size());
      for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
      std::shuffle(order.begin(), order.end(), std::mt19937(static_cast<unsigned>(100 + t)));
      for (const std::size_t i : order) {
        got[static_cast<std::size_t>(t)][i] = shared(points[i]);
        got_edge[static_cast<std::size_t>(t)][i] = shared_edges(points[i]);
      }
    });
  for (auto& th : threads) th.join();
  for (int t = 0; t < kThreads; ++t)
    for (std::size_t i = 0; i < points.size(); ++i) {
      ASSERT_EQ(got[static_cast<std::size_t>(t)][i], one[i]) << "thread " << t << ", point " << i;
      ASSERT_EQ(got_edge[static_cast<std::size_t>(t)][i], one_edge[i]) << "thread " << t << ", point " << i;
    }
}

}  // namespace
}  // namespace distlab::kelvin::sizing
