#pragma once
// A robot arm as data: a URDF file (assets/robots/NAME.urdf) parsed with urdfdom. Revolute
// joints (any number, a tree rooted at one base link fixed in the world), their limits and
// velocity limits, collision boxes, cylinders and spheres per link (capsules: a documented
// extension, see robot.cpp), the end effector (the one leaf link, or <distlab:end_effector
// link="..."/>). Forward kinematics, geometric Jacobians and the self-collision pairs (primitives
// of links at least two revolute joints apart in the tree) all come from that description.
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "distlab/geometry/pose.hpp"
#include "distlab/geometry/shape.hpp"

namespace distlab::cbf {

using VecQ = Eigen::VectorXd;                                         // one entry per revolute joint, in file order
using Jac = Eigen::Matrix<double, 6, Eigen::Dynamic>;                 // rows: linear velocity, angular velocity
using GradQ = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic>;  // rows: ∇_q of each pair

// A convex primitive fixed to link `link` (index into Robot::links()) at `pose` in that frame.
struct LinkPrimitive {
  std::string name;
  int link;
  Shape shape;
  Pose pose;
};

// A joint of the tree. Child frame = parent frame · origin · Rot(axis, q) (revolute) or
// parent · origin (fixed).
struct RobotJoint {
  std::string name;
  int parent = -1, child = -1;  // link indices
  int q = -1;                   // index into VecQ, −1 for a fixed joint
  Mat3 origin_R = Mat3::Identity();
  Vec3 origin_t = Vec3::Zero();
  bool origin_rotated = false;  // origin_R is not the identity
  Vec3 axis = Vec3::UnitZ();
};

// World frames of every link, the world axis and origin of every revolute joint, and the end
// effector.
struct Kinematics {
  std::vector<Pose> frames;  // per link
  std::vector<Mat3> R;       // rotation matrices of `frames`
  std::vector<Vec3> axis;    // per revolute joint (VecQ order), world
  std::vector<Vec3> origin;  // per revolute joint, world
  Pose ee;
  Mat3 ee_R = Mat3::Identity();
  std::vector<Mat3> local_R;  // scratch of forward(): per joint, its transform from the base used
  std::vector<Vec3> local_t;
};

class Robot {
 public:
  // Throws InvalidInput(field, ...) for a URDF that cannot be parsed or is outside the subset
  // above (the message names the URDF element).
  static std::shared_ptr<const Robot> from_urdf(const std::string& xml, const std::string& field = "robot");
  // Reads and parses a file once per path (cached; robots are immutable).
  static std::shared_ptr<const Robot> load(const std::string& path, const std::string& field = "robot");

  const std::string& name() const { return name_; }
  int dof() const { return static_cast<int>(q_joint_.size()); }
  const std::vector<std::string>& links() const { return links_; }
  int link_index(const std::string& name) const;  // −1 if there is none
  const std::vector<RobotJoint>& joints() const { return joints_; }
  // Names of the revolute joints in VecQ order.
  std::vector<std::string> joint_names() const;
  const VecQ& q_min() const { return q_min_; }
  const VecQ& q_max() const { return q_max_; }
  const VecQ& velocity_max() const { return velocity_max_; }  // URDF <limit velocity>
  int ee_link() const { return ee_link_; }
  const std::vector<LinkPrimitive>& primitives() const { return primitives_; }
  // Self-collision pairs (indices into primitives(), i < j): links ≥ 2 revolute joints apart.
  const std::vector<std::pair<int, int>>& self_pairs() const { return self_pairs_; }

  Kinematics forward(const VecQ& q) const;
  // The same into `k`, reusing its storage (the controller's per-step call: no allocation).
  void forward(const VecQ& q, Kinematics& k) const;
  // Geometric Jacobian of the world point p, fixed to link `link`: column j of every revolute
  // joint j between the base and the link is [a_j × (p − o_j); a_j], the others are zero.
  Jac point_jacobian(const Kinematics& k, int link, const Vec3& p) const;
  Jac ee_jacobian(const Kinematics& k) const { return point_jacobian(k, ee_link_, k.ee.position); }
  Pose primitive_pose(const Kinematics& k, int i) const;

 private:
  std::string name_;
  std::vector<std::string> links_;
  std::vector<RobotJoint> joints_;          // evaluation order: a parent link before its children
  std::vector<int> parent_joint_;           // per link, index into joints_ (−1 for the base)
  std::vector<int> q_joint_;                // per VecQ entry, index into joints_
  std::vector<std::vector<int>> moved_by_;  // per link, the VecQ indices of its revolute ancestors
  VecQ q_min_, q_max_, velocity_max_;
  int ee_link_ = -1;
  std::vector<LinkPrimitive> primitives_;
  std::vector<std::pair<int, int>> self_pairs_;
};

Pose compose(const Pose& a, const Pose& b);  // a · b

}  // namespace distlab::cbf
