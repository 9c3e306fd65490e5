#pragma once
// Shared fixtures for the collision tests: a zoo of shapes, random poses, exact signed
// distances (independent of the library's own inside tests) and world-frame supports.
#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "distlab/collision/euclidean.hpp"
#include "distlab/geometry/polytope.hpp"
#include "distlab/geometry/shape.hpp"

namespace distlab::test {

inline Vec3 random_unit(std::mt19937_64& rng) {
  std::normal_distribution<double> n;
  return Vec3(n(rng), n(rng), n(rng)).normalized();
}

inline Quat random_rotation(std::mt19937_64& rng) {
  std::normal_distribution<double> n;
  return Quat(n(rng), n(rng), n(rng), n(rng)).normalized();
}

inline Pose random_pose(std::mt19937_64& rng, double spread) {
  std::normal_distribution<double> n;
  Pose p;
  p.rotation = random_rotation(rng);
  p.position = Vec3(n(rng), n(rng), n(rng)) * spread;
  return p;
}

// A 10-row polytope around the origin (axis rows, four diagonals, jittered).
inline Polytope ten_row_polytope() {
  const double rows[10][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}, {1, 1, 1}, {-1, -1, 1}, {1, -1, -1}, {-1, 1, -1}};
  const double jitter[10] = {0.05, -0.02, 0.03, 0.0, -0.04, 0.02, 0.01, -0.03, 0.04, 0.0};
  MatX3 A(10, 3);
  VecX b(10);
  for (int i = 0; i < 10; ++i) {
    A.row(i) = Vec3(rows[i][0] + jitter[i], rows[i][1] - jitter[i], rows[i][2]).transpose();
    b[i] = 0.45 + 0.1 * std::abs(jitter[9 - i]) * 10;
  }
  return make_polytope(A, b, "test");
}

// One shape of each kind, sized ~1.
inline std::vector<std::pair<std::string, Shape>> shape_zoo() {
  return {{"box", Box{Vec3(1.0, 0.6, 0.8)}},
          {"sphere", Sphere{0.5}},
          {"cylinder", Cylinder{0.4, 1.2}},
          {"capsule", Capsule{0.3, 1.0}},
          {"polytope", ten_row_polytope()}};
}

// Signed distance to the shape from a local point (exact for the round shapes and the box;
// for a polytope max(A p - b), which is 0 exactly on the boundary and <= 0 inside).
inline double signed_distance(const Shape& s, const Vec3& p) {
  struct Visitor {
    const Vec3& p;
    double operator()(const Box& b) const {
      const Vec3 q = p.cwiseAbs() - 0.5 * b.size;
      return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
    }
    double operator()(const Sphere& s) const { return p.norm() - s.radius; }
    double operator()(const Cylinder& c) const {
      const double dr = std::hypot(p.x(), p.y()) - c.radius;
      const double dz = std::abs(p.z()) - 0.5 * c.height;
      return std::min(std::max(dr, dz), 0.0) + std::hypot(std::max(dr, 0.0), std::max(dz, 0.0));
    }
    double operator()(const Capsule& c) const {
      const double z = std::clamp(p.z(), -0.5 * c.height, 0.5 * c.height);
      return (p - Vec3(0, 0, z)).norm() - c.radius;
    }
    double operator()(const Polytope& q) const { return (q.A * p - q.b).maxCoeff(); }
  };
  return std::visit(Visitor{p}, s);
}

inline double world_signed_distance(const Shape& s, const Pose& pose, const Vec3& x) {
  return signed_distance(s, pose.to_local(x));
}

inline Vec3 world_support(const Shape& s, const Pose& pose, const Vec3& d) {
  return pose.to_world(support(s, pose.dir_to_local(d)));
}

// Lower bound on the distance certified by the unit direction n (from A to B).
inline double separation_along(const Shape& a, const Pose& pa, const Shape& b, const Pose& pb,
                               const Vec3& n) {
  return n.dot(world_support(b, pb, -n)) - n.dot(world_support(a, pa, n));
}

// R <- exp(h e_axis^) R: a small rotation about a world axis.
inline Pose rotated(Pose p, int axis, double h) {
  p.rotation = (Quat(Eigen::AngleAxisd(h, Vec3::Unit(axis))) * p.rotation).normalized();
  return p;
}

inline Pose translated(Pose p, int axis, double h) {
  p.position[axis] += h;
  return p;
}

}  // namespace distlab::test
