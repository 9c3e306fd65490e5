// Panda kinematics and collision model; every number is from franka-corridor.md.
#include "distlab/cbf/robot.hpp"

#include <cmath>
#include <numbers>

namespace distlab::cbf {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;

Pose make_pose(const Vec3& t, const Quat& r = Quat::Identity()) {
  Pose p;
  p.position = t;
  p.rotation = r;
  return p;
}
Quat rx(double a) { return Quat(Eigen::AngleAxisd(a, Vec3::UnitX())); }
Quat rz(double a) { return Quat(Eigen::AngleAxisd(a, Vec3::UnitZ())); }

}  // namespace

Pose compose(const Pose& a, const Pose& b) {
  return make_pose(a.position + a.rotation * b.position, (a.rotation * b.rotation).normalized());
}

Panda::Panda() {
  dh_ = {{{0.333, -kPi / 2, 0.0},
          {0.0, kPi / 2, 0.0},
          {0.316, kPi / 2, 0.0825},
          {0.0, -kPi / 2, -0.0825},
          {0.384, kPi / 2, 0.0},
          {0.0, kPi / 2, 0.088},
          {0.177, 0.0, 0.0}}};
  q_min_ << -166, -101, -166, -176, -166, -1, -166;
  q_max_ << 166, 101, 166, -4, 166, 215, 166;
  q_min_ *= kDeg;
  q_max_ *= kDeg;

  // M maps (x, y, z) to (x, z − 0.383, −y): the rotation Rx(−π/2) and translation (0, −0.383, 0).
  const Pose M = make_pose(Vec3(0, -0.383, 0), rx(-kPi / 2));
  const Pose box5 = compose(M, make_pose(Vec3(0, 0.09, 0.28), rx(-0.24)));
  primitives_ = {
      {"link1_cylinder", 1, Cylinder{0.08, 0.28}, Pose{}},
      {"link2_cylinder", 2, Cylinder{0.07, 0.25}, make_pose(Vec3(0, 0, 0.18))},
      {"link3_cylinder", 3, Cylinder{0.07, 0.24}, Pose{}},
      {"link4_cylinder", 4, Cylinder{0.07, 0.20}, make_pose(Vec3(0, 0, 0.13))},
      {"link5_box", 5, Box{Vec3(0.08, 0.05, 0.23)}, box5},
      {"link5_cylinder", 5, Cylinder{0.06, 0.22}, make_pose(Vec3(0, 0, -0.03))},
      {"link6_cylinder", 6, Cylinder{0.06, 0.21}, make_pose(Vec3(0, 0, 0.02))},
      {"link7_box", 7, Box{Vec3(0.05, 0.21, 0.10)}, make_pose(Vec3(0, 0, -0.05), rz(-kPi / 4))},
      {"link7_gripper", 7, Box{Vec3(0.10, 0.09, 0.034)}, make_pose(Vec3(0.03, 0.03, -0.095))},
  };
  for (int i = 0; i < static_cast<int>(primitives_.size()); ++i)
    for (int j = i + 1; j < static_cast<int>(primitives_.size()); ++j)
      if (primitives_[j].link >= primitives_[i].link + 2) self_pairs_.emplace_back(i, j);
}

Kinematics Panda::forward(const VecQ& q) const {
  Kinematics k;
  k.frames[0] = Pose{};
  k.R[0] = Mat3::Identity();
  for (int i = 0; i < kDof; ++i) {
    const DhRow& row = dh_[i];
    const double cq = std::cos(q[i]), sq = std::sin(q[i]);
    const double ca = std::cos(row.alpha), sa = std::sin(row.alpha);
    // Rz(q) Tz(d) Rx(α) Tx(a) as one homogeneous transform.
    Mat3 A;
    A << cq, -sq * ca, sq * sa,  //
        sq, cq * ca, -cq * sa,   //
        0, sa, ca;
    const Vec3 t(row.a * cq, row.a * sq, row.d);
    k.R[i + 1] = k.R[i] * A;
    k.frames[i + 1].position = k.frames[i].position + k.R[i] * t;
    k.frames[i + 1].rotation = Quat(k.R[i + 1]).normalized();
  }
  k.ee_R = k.R[kDof] * rz(-kPi / 4).toRotationMatrix();
  k.ee.position = k.frames[kDof].position;
  k.ee.rotation = Quat(k.ee_R).normalized();
  return k;
}

Jac Panda::point_jacobian(const Kinematics& k, int link, const Vec3& p) const {
  Jac J = Jac::Zero();
  for (int j = 0; j < link; ++j) {
    const Vec3 z = k.R[j].col(2);  // axis of joint j+1 is z of frame j
    J.block<3, 1>(0, j) = z.cross(p - k.frames[j].position);
    J.block<3, 1>(3, j) = z;
  }
  return J;
}

Pose Panda::primitive_pose(const Kinematics& k, int i) const {
  const LinkPrimitive& prim = primitives_[i];
  return compose(k.frames[prim.link], prim.pose);
}

}  // namespace distlab::cbf
