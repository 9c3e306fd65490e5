#pragma once
// Shared fixtures for the GAP tests: random shapes, poses and finite differences.
#include <random>

#include "distlab/geometry/polytope.hpp"
#include "distlab/geometry/shape.hpp"

namespace distlab::test {

inline Vec3 random_unit(std::mt19937_64& rng) {
  std::normal_distribution<double> n;
  Vec3 v(n(rng), n(rng), n(rng));
  return v.normalized();
}

inline Quat random_rotation(std::mt19937_64& rng) {
  std::normal_distribution<double> n;
  return Quat(n(rng), n(rng), n(rng), n(rng)).normalized();
}

// A random regular polytope with `rows` half-spaces around the origin, size ~`scale`: random
// unit normals (re-drawn until they surround the origin) and offsets in [0.5, 1] * scale.
inline Polytope random_polytope(std::mt19937_64& rng, int rows, double scale) {
  std::uniform_real_distribution<double> u(0.5, 1.0);
  for (;;) {
    MatX3 A(rows, 3);
    VecX b(rows);
    for (int i = 0; i < rows; ++i) {
      A.row(i) = random_unit(rng).transpose();
      b[i] = u(rng) * scale;
    }
    try {
      return make_polytope(A, b, "test");
    } catch (const std::exception&) {
      continue;  // unbounded draw
    }
  }
}

// Rotation of a quaternion by a small world-frame rotation vector w: exp(ŵ) R.
inline Quat rotate_world(const Quat& q, const Vec3& w) {
  const double angle = w.norm();
  if (angle == 0) return q;
  return (Quat(Eigen::AngleAxisd(angle, w / angle)) * q).normalized();
}

// Pose moved along coordinate c of (v, ω) (c < 3: translation, else world rotation) by `delta`.
inline Pose perturbed(const Pose& base, int c, double delta) {
  Pose q = base;
  Vec3 step = Vec3::Zero();
  step[c % 3] = delta;
  if (c < 3) q.position += step;
  else q.rotation = rotate_world(base.rotation, step);
  return q;
}

}  // namespace distlab::test
