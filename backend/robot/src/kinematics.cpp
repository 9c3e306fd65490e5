// Forward kinematics and point Jacobians of a Robot.
#include <cmath>

#include <Eigen/Geometry>

#include "distlab/geometry/error.hpp"
#include "distlab/robot/robot.hpp"

namespace distlab::robot {

void Robot::check_q(const VecQ& q, const std::string& field) const {
  if (q.size() != dof())
    throw InvalidInput(field, field + " must have " + std::to_string(dof()) + " entries (one per joint), not " +
                                  std::to_string(q.size()));
  for (int i = 0; i < dof(); ++i)
    if (!std::isfinite(q[i]) || std::abs(q[i]) > 1e6)
      throw InvalidInput(field + "[" + std::to_string(i) + "]", field + "[" + std::to_string(i) + "] (joint \"" +
                                                                    joints_[q_joint_[i]].name + "\") must be finite, |q| <= 1e6");
}

Kinematics Robot::forward(const VecQ& q) const {
  Kinematics k;
  forward(q, k);
  return k;
}

// World frames, parents first. A fixed joint right after a moving one is evaluated with it as one
// local transform from the grandparent (how a DH row Rz(q)·Tz(d)·Rx(α)·Tx(a) is evaluated:
// Rz(q)·Rx(α) and Rz(q)·(a, 0, d) first, then the previous frame).
void Robot::forward(const VecQ& q, Kinematics& k) const {
  const int nl = static_cast<int>(links_.size());
  k.frames.resize(nl);
  k.R.resize(nl);
  for (int l = 0; l < nl; ++l)
    if (parent_joint_[l] < 0) k.frames[l] = Pose{}, k.R[l] = Mat3::Identity();
  k.axis.resize(joints_.size());
  k.origin.resize(joints_.size());
  k.local_R.resize(joints_.size());
  k.local_t.resize(joints_.size());
  std::vector<Mat3>& local_R = k.local_R;
  std::vector<Vec3>& local_t = k.local_t;
  for (std::size_t ji = 0; ji < joints_.size(); ++ji) {
    const RobotJoint& j = joints_[ji];
    Mat3 R = j.origin_R;
    Vec3 t = j.origin_t;
    if (j.type != JointType::fixed) {
      const double theta = j.mimic ? j.multiplier * q[j.q] + j.offset : q[j.q];
      if (j.type == JointType::revolute) {
        Mat3 rot;
        if (j.axis == Vec3::UnitZ()) {
          const double c = std::cos(theta), s = std::sin(theta);
          rot << c, -s, 0, s, c, 0, 0, 0, 1;
        } else {
          rot = Eigen::AngleAxisd(theta, j.axis).toRotationMatrix();
        }
        R = j.origin_rotated ? Mat3(j.origin_R * rot) : rot;
      } else {
        t = j.origin_t + j.origin_R * (theta * j.axis);
      }
      k.axis[ji] = k.R[j.parent] * (j.origin_R * j.axis);
      k.origin[ji] = k.frames[j.parent].position + k.R[j.parent] * j.origin_t;
    }
    local_R[ji] = R;
    local_t[ji] = t;
    int base = j.parent;
    const int pj = parent_joint_[j.parent];
    if (j.type == JointType::fixed && pj >= 0 && joints_[pj].type != JointType::fixed) {  // fuse with the joint before
      local_t[ji] = local_t[pj] + local_R[pj] * j.origin_t;
      local_R[ji] = j.origin_rotated ? Mat3(local_R[pj] * j.origin_R) : local_R[pj];
      base = joints_[pj].parent;
    }
    k.R[j.child] = k.R[base] * local_R[ji];
    k.frames[j.child].position = k.frames[base].position + k.R[base] * local_t[ji];
    k.frames[j.child].rotation = Quat(k.R[j.child]).normalized();
  }
  k.ee = k.frames[ee_link_];
  k.ee_R = k.R[ee_link_];
}

Jac Robot::point_jacobian(const Kinematics& k, int link, const Vec3& p) const {
  Jac J;
  point_jacobian(k, link, p, J);
  return J;
}

void Robot::point_jacobian(const Kinematics& k, int link, const Vec3& p, Jac& J) const {
  J.setZero(6, dof());
  for (int ji : moved_by_[link]) {
    const RobotJoint& j = joints_[ji];
    const Vec3& a = k.axis[ji];
    if (j.type == JointType::revolute) {
      if (j.mimic) {
        J.block<3, 1>(0, j.q) += j.multiplier * a.cross(p - k.origin[ji]);
        J.block<3, 1>(3, j.q) += j.multiplier * a;
      } else {
        J.block<3, 1>(0, j.q) += a.cross(p - k.origin[ji]);
        J.block<3, 1>(3, j.q) += a;
      }
    } else {
      J.block<3, 1>(0, j.q) += j.mimic ? Vec3(j.multiplier * a) : a;
    }
  }
}

Pose Robot::primitive_pose(const Kinematics& k, int i) const {
  const LinkPrimitive& prim = primitives_[i];
  return compose(k.frames[prim.link], prim.pose);
}

}  // namespace distlab::robot
