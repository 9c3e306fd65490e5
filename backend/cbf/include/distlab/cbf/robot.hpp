#pragma once
// The Franka Emika Panda of the corridor experiment (franka-corridor.md): standard DH kinematics
// (frame i = frame i-1 · Rz(q_i) · Tz(d_i) · Rx(α_i) · Tx(a_i), base = world), joint limits,
// collision primitives per link, forward kinematics and geometric Jacobians.
#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "distlab/geometry/pose.hpp"
#include "distlab/geometry/shape.hpp"

namespace distlab::cbf {

inline constexpr int kDof = 7;
using VecQ = Eigen::Matrix<double, kDof, 1>;
using Jac = Eigen::Matrix<double, 6, kDof>;  // rows: linear velocity, angular velocity

struct DhRow {
  double d, alpha, a;
};

// A convex primitive fixed to link frame `link` (1..7) at `pose` (in that frame).
struct LinkPrimitive {
  std::string name;
  int link;
  Shape shape;
  Pose pose;
};

// World poses of frames 0..7 (0 = base) and of the end effector (frame 7 · Rz(−π/4)).
struct Kinematics {
  std::array<Pose, kDof + 1> frames;
  std::array<Mat3, kDof + 1> R;  // rotation matrices of `frames`, cached
  Pose ee;
  Mat3 ee_R = Mat3::Identity();
};

class Panda {
 public:
  Panda();
  const std::array<DhRow, kDof>& dh() const { return dh_; }
  const VecQ& q_min() const { return q_min_; }
  const VecQ& q_max() const { return q_max_; }
  const std::vector<LinkPrimitive>& primitives() const { return primitives_; }
  // Self-collision pairs (indices into primitives()): links i and j with j ≥ i + 2.
  const std::vector<std::pair<int, int>>& self_pairs() const { return self_pairs_; }

  Kinematics forward(const VecQ& q) const;
  // Geometric Jacobian of the world point p, taken as fixed to link frame `link` (0..7):
  // column j ≤ link is [z_{j−1} × (p − o_{j−1}); z_{j−1}], later columns are zero.
  Jac point_jacobian(const Kinematics& k, int link, const Vec3& p) const;
  Jac ee_jacobian(const Kinematics& k) const { return point_jacobian(k, kDof, k.ee.position); }
  // World pose of primitive i.
  Pose primitive_pose(const Kinematics& k, int i) const;

 private:
  std::array<DhRow, kDof> dh_;
  VecQ q_min_, q_max_;
  std::vector<LinkPrimitive> primitives_;
  std::vector<std::pair<int, int>> self_pairs_;
};

Pose compose(const Pose& a, const Pose& b);  // a · b

}  // namespace distlab::cbf
