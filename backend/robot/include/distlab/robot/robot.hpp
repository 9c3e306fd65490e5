#pragma once
// A robot as data: a URDF description parsed with urdfdom. Joints: revolute, continuous,
// prismatic and fixed, any of them a <mimic> of another (a tree rooted at one base link fixed in
// the world); floating and planar joints are refused. Collision elements per link (any number):
// <box>, <cylinder>, <sphere> (a capsule: distlab:capsule="true"), and <mesh filename scale>,
// which becomes the convex hull of its vertices (a polytope, the shape `convex_hull` requests
// make). Forward kinematics, point Jacobians in joint space and the self-collision pairs
// (elements of links at least two joints apart in the tree) all come from that description.
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "distlab/collision/euclidean.hpp"
#include "distlab/geometry/pose.hpp"
#include "distlab/geometry/shape.hpp"
#include "distlab/mesh/surface.hpp"
#include "distlab/robot/description_limits.hpp"

namespace distlab::robot {

using VecQ = Eigen::VectorXd;                                         // one entry per degree of freedom
using Jac = Eigen::Matrix<double, 6, Eigen::Dynamic>;                 // rows: linear velocity, angular velocity
using GradQ = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic>;  // rows: ∇_q of each pair

// A convex collision element fixed to link `link` (index into Robot::links()) at `pose` in that
// frame. `element`: its position among the link's <collision> elements (0, 1, ...); `name`: the
// element's name attribute, or "LINK/collision[ELEMENT]" when it has none.
struct LinkPrimitive {
  std::string name;
  int link;
  int element = 0;
  Shape shape;
  Pose pose;
  std::string mesh;  // the <mesh filename> as written (empty for the other geometries)
};

enum class JointType { revolute,
                       prismatic,
                       fixed };

// A joint of the tree. Child frame = parent · origin · Rot(axis, θ) (revolute) or
// parent · origin · Trans(axis θ) (prismatic) or parent · origin (fixed), with the joint's value
// θ = multiplier · q[q] + offset (multiplier 1, offset 0 unless it is a <mimic> of another joint).
struct RobotJoint {
  std::string name;
  JointType type = JointType::fixed;
  int parent = -1, child = -1;  // link indices
  int q = -1;                   // index into VecQ (the mimicked joint's for a mimic), −1 for fixed
  bool mimic = false;
  double multiplier = 1, offset = 0;
  Mat3 origin_R = Mat3::Identity();
  Vec3 origin_t = Vec3::Zero();
  bool origin_rotated = false;  // origin_R is not the identity
  Vec3 axis = Vec3::UnitZ();
};

// World frames of every link, the world axis and origin of every moving joint, and the end
// effector.
struct Kinematics {
  std::vector<Pose> frames;  // per link
  std::vector<Mat3> R;       // rotation matrices of `frames`
  std::vector<Vec3> axis;    // per joint (Robot::joints() order), world; moving joints only
  std::vector<Vec3> origin;  // per joint, world
  Pose ee;
  Mat3 ee_R = Mat3::Identity();
  std::vector<Mat3> local_R;  // scratch of forward(): per joint, its transform from the base used
  std::vector<Vec3> local_t;
};

// Where the <mesh> files of a description are found and how they are read.
struct UrdfOptions {
  // A relative filename is read from here (the URDF file's folder; "" for text without one: then
  // only package:// and absolute filenames resolve).
  std::string base_dir;
  // package://NAME/rest is read from package_dirs[NAME]/rest, else from the first DIR/NAME/rest
  // that exists for DIR in package_search_dirs (folders holding packages, as ROS_PACKAGE_PATH).
  std::map<std::string, std::string> package_dirs;
  std::vector<std::string> package_search_dirs;
  // Refuse a mesh that is not a closed surface. Off (the default): its hull is taken all the same
  // (the hull of an open mesh's vertices is as well defined; public descriptions often have holes)
  // and Robot::warnings() says so.
  bool require_closed_meshes = false;
  // Reads a mesh: its filename as the URDF writes it and the resolved path (resolve_mesh_path).
  // Unset: mesh::load_mesh in this process (files the caller trusts). The server passes one that
  // reads uploaded bytes in an isolated child (mesh/isolated_import.hpp).
  std::function<mesh::SurfaceMesh(const std::string& filename, const std::string& path, const std::string& field)>
      read_mesh;
  DescriptionLimits limits;
};

// filename → a path: package://NAME/rest through package_dirs, file:// and absolute paths as they
// are, relative ones below base_dir. Throws InvalidInput(field) for an unknown package, a
// relative filename without base_dir, or a path with ".." after package://NAME.
std::string resolve_mesh_path(const std::string& filename, const UrdfOptions& options, const std::string& field);

class Robot {
 public:
  // Throws InvalidInput(field, ...) for a URDF that cannot be parsed or is outside the subset
  // above; the message names the URDF element (joint, link and collision element). The text may
  // be untrusted: before any XML parser sees it, elements nesting deeper than 64, an element with
  // more than 64 attributes, CDATA, a DOCTYPE and unquoted attribute values are refused.
  static std::shared_ptr<const Robot> from_urdf(const std::string& xml, const std::string& field = "robot",
                                                const UrdfOptions& options = {});
  // Reads and parses a file (relative meshes below its folder).
  static std::shared_ptr<const Robot> from_file(const std::string& path, const std::string& field = "robot",
                                                UrdfOptions options = {});
  // from_file once per path (cached; for the built-in robots, which are immutable).
  static std::shared_ptr<const Robot> load(const std::string& path, const std::string& field = "robot");

  const std::string& name() const { return name_; }
  int dof() const { return static_cast<int>(q_joint_.size()); }
  const std::vector<std::string>& links() const { return links_; }
  int link_index(const std::string& name) const;  // −1 if there is none
  const std::vector<RobotJoint>& joints() const { return joints_; }
  // Names of the independent joints (not fixed, not mimic) in VecQ order: file order.
  std::vector<std::string> joint_names() const;
  const std::vector<JointType>& joint_types() const { return q_type_; }  // per VecQ entry
  // −inf / +inf for a continuous joint, and for a revolute or prismatic one whose <limit> gives no
  // lower and upper (urdfdom reads both as 0).
  const VecQ& q_min() const { return q_min_; }
  const VecQ& q_max() const { return q_max_; }
  const VecQ& velocity_max() const { return velocity_max_; }  // URDF <limit velocity>; +inf if none
  int ee_link() const { return ee_link_; }
  const std::vector<LinkPrimitive>& primitives() const { return primitives_; }
  // Each element's FCL geometry, built once at load and shared (read-only) by every DistanceModel:
  // FCL checks a mesh hull's topology in each Convex it constructs (the Kinova's 11 hulls, built
  // twice per model before: 24 ms of a rebuild, now 2 ms).
  const EuclideanShape& euclidean_shape(int i) const { return euclidean_[static_cast<std::size_t>(i)]; }
  // Self-collision pairs (indices into primitives(), i < j): links ≥ 2 moving joints apart.
  const std::vector<std::pair<int, int>>& self_pairs() const { return self_pairs_; }
  // What was accepted but may surprise: an open collision mesh, a joint whose limits are not given.
  const std::vector<std::string>& warnings() const { return warnings_; }
  // Moving joints (not fixed) between the tree's root and `link` (indices into joints()).
  const std::vector<int>& moved_by(int link) const { return moved_by_[link]; }
  // The number of moving joints on the tree path between two links.
  int joints_between(int link_a, int link_b) const;

  // Throws InvalidInput(field) unless q has dof() finite entries.
  void check_q(const VecQ& q, const std::string& field = "q") const;
  Kinematics forward(const VecQ& q) const;
  // The same into `k`, reusing its storage (the controller's per-step call: no allocation).
  void forward(const VecQ& q, Kinematics& k) const;
  // Geometric Jacobian of the world point p, fixed to link `link`: for each moving joint between
  // the base and the link, column q gets multiplier · [a × (p − o); a] (revolute) or
  // multiplier · [a; 0] (prismatic); the others are zero.
  Jac point_jacobian(const Kinematics& k, int link, const Vec3& p) const;
  // The same into J (6 × dof), reusing its storage.
  void point_jacobian(const Kinematics& k, int link, const Vec3& p, Jac& J) const;
  Jac ee_jacobian(const Kinematics& k) const { return point_jacobian(k, ee_link_, k.ee.position); }
  Pose primitive_pose(const Kinematics& k, int i) const;

 private:
  std::string name_;
  std::vector<std::string> links_;
  std::vector<RobotJoint> joints_;          // evaluation order: a parent link before its children
  std::vector<int> parent_joint_;           // per link, index into joints_ (−1 for the base)
  std::vector<int> q_joint_;                // per VecQ entry, index into joints_
  std::vector<JointType> q_type_;           // per VecQ entry
  std::vector<std::vector<int>> moved_by_;  // per link, its moving ancestor joints (root first)
  VecQ q_min_, q_max_, velocity_max_;
  int ee_link_ = -1;
  std::vector<LinkPrimitive> primitives_;
  std::vector<EuclideanShape> euclidean_;  // per primitive
  std::vector<std::pair<int, int>> self_pairs_;
  std::vector<std::string> warnings_;
};

Pose compose(const Pose& a, const Pose& b);  // a · b

}  // namespace distlab::robot
