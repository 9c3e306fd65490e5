// Robots from URDF (urdfdom). The URDF subset and its two extensions:
// - joints: revolute (limits and velocity required) and fixed; one tree from one root link.
// - collisions: <box size>, <cylinder radius length> (axis z, centred), <sphere radius>; a
//   capsule is a <cylinder> whose <collision> has distlab:capsule="true" (length = its core
//   segment, as Capsule::height). Every collision needs a unique name.
// - <origin ... distlab:quaternion="w x y z"/>: an exact rotation for an origin (rpy must give
//   the same rotation for other URDF readers; checked to 1e-9).
// - <distlab:end_effector link="..."/>: the end-effector link (default: the one leaf link).
// urdfdom keeps origins only as quaternions computed from rpy; origins are read from the XML
// text instead so that an rpy rotation about one axis is the exact cos/sin matrix, e.g. the
// Rx(α) of a DH row Rz(q)·Tz(d)·Rx(α)·Tx(a) (a revolute joint, then a fixed joint).
#include "distlab/cbf/robot.hpp"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <mutex>
#include <set>
#include <sstream>

#include <tinyxml.h>
#include <urdf_parser/urdf_parser.h>
#include <Eigen/Geometry>

#include "distlab/geometry/error.hpp"

namespace distlab::cbf {
namespace {

Pose make_pose(const Vec3& t, const Quat& r = Quat::Identity()) {
  Pose p;
  p.position = t;
  p.rotation = r;
  return p;
}

[[noreturn]] void bad(const std::string& field, const std::string& what) {
  throw InvalidInput(field, "robot URDF: " + what);
}

std::vector<double> numbers(const char* text, std::size_t count, const std::string& field,
                            const std::string& what) {
  std::vector<double> v;
  const char* p = text;
  while (p && *p) {
    char* end = nullptr;
    const double x = std::strtod(p, &end);
    if (end == p) break;
    v.push_back(x);
    p = end;
  }
  for (; p && *p; ++p)
    if (!std::isspace(static_cast<unsigned char>(*p))) bad(field, what + ": not a number list");
  if (v.size() != count) bad(field, what + ": expected " + std::to_string(count) + " numbers");
  for (double x : v)
    if (!std::isfinite(x) || std::abs(x) > 1e6) bad(field, what + ": numbers must be finite, |x| <= 1e6");
  return v;
}

Mat3 elementary(int axis, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  Mat3 R = Mat3::Identity();
  const int i = (axis + 1) % 3, j = (axis + 2) % 3;
  R(i, i) = c;
  R(i, j) = -s;
  R(j, i) = s;
  R(j, j) = c;
  return R;
}

struct Origin {
  Vec3 t = Vec3::Zero();
  Mat3 R = Mat3::Identity();
  Quat q = Quat::Identity();
  bool rotated = false;
};

// <origin xyz rpy distlab:quaternion>: R = Rz(y)·Ry(p)·Rx(r), only the non-zero factors.
Origin read_origin(const TiXmlElement* parent, const std::string& field) {
  Origin o;
  const TiXmlElement* e = parent ? parent->FirstChildElement("origin") : nullptr;
  if (!e) return o;
  if (const char* xyz = e->Attribute("xyz")) {
    const auto v = numbers(xyz, 3, field, "origin xyz");
    o.t = Vec3(v[0], v[1], v[2]);
  }
  std::vector<double> rpy = {0, 0, 0};
  if (const char* text = e->Attribute("rpy")) rpy = numbers(text, 3, field, "origin rpy");
  for (int a = 2; a >= 0; --a)
    if (rpy[a] != 0) {
      o.R = o.rotated ? Mat3(o.R * elementary(a, rpy[a])) : elementary(a, rpy[a]);
      const Quat qa(Eigen::AngleAxisd(rpy[a], Vec3::Unit(a)));
      o.q = o.rotated ? Quat(o.q * qa) : qa;
      o.rotated = true;
    }
  if (const char* text = e->Attribute("distlab:quaternion")) {
    const auto v = numbers(text, 4, field, "origin distlab:quaternion");
    const Quat q(v[0], v[1], v[2], v[3]);
    if (std::abs(q.norm() - 1) > 1e-12) bad(field, "origin distlab:quaternion must have unit norm");
    if ((q.toRotationMatrix() - o.R).cwiseAbs().maxCoeff() > 1e-9)
      bad(field, "origin distlab:quaternion and rpy describe different rotations");
    o.q = q;
    o.R = q.toRotationMatrix();
    o.rotated = true;
  }
  return o;
}

std::string attr(const TiXmlElement* e, const char* name) {
  const char* v = e->Attribute(name);
  return v ? v : "";
}

}  // namespace

Pose compose(const Pose& a, const Pose& b) {
  return make_pose(a.position + a.rotation * b.position, (a.rotation * b.rotation).normalized());
}

std::shared_ptr<const Robot> Robot::load(const std::string& path, const std::string& field) {
  static std::mutex mutex;
  static std::map<std::string, std::shared_ptr<const Robot>> cache;
  std::lock_guard<std::mutex> lock(mutex);
  if (auto it = cache.find(path); it != cache.end()) return it->second;
  std::ifstream f(path);
  if (!f) throw std::runtime_error("cannot read a robot file");
  std::stringstream text;
  text << f.rdbuf();
  auto robot = from_urdf(text.str(), field);
  cache[path] = robot;
  return robot;
}

std::shared_ptr<const Robot> Robot::from_urdf(const std::string& xml, const std::string& field) {
  if (xml.size() > (1u << 20)) bad(field, "at most 1 MiB");
  const urdf::ModelInterfaceSharedPtr model = urdf::parseURDF(xml);
  if (!model) bad(field, "urdfdom cannot parse it");
  TiXmlDocument doc;
  doc.Parse(xml.c_str());
  const TiXmlElement* root = doc.RootElement();
  if (doc.Error() || !root) bad(field, "not XML");

  auto r = std::make_shared<Robot>();
  r->name_ = model->getName();
  std::map<std::string, int> link_index;
  std::vector<const TiXmlElement*> link_xml;
  for (const TiXmlElement* e = root->FirstChildElement("link"); e; e = e->NextSiblingElement("link")) {
    link_index[attr(e, "name")] = static_cast<int>(r->links_.size());
    r->links_.push_back(attr(e, "name"));
    link_xml.push_back(e);
  }
  const int nl = static_cast<int>(r->links_.size());
  if (nl > 256) bad(field, "at most 256 links");

  // Joints in file order; evaluation order (parents first) below.
  std::vector<RobotJoint> joints;
  r->parent_joint_.assign(nl, -1);
  for (const TiXmlElement* e = root->FirstChildElement("joint"); e; e = e->NextSiblingElement("joint")) {
    const std::string name = attr(e, "name");
    const std::string jf = field + ": joint \"" + name.substr(0, 64) + "\"";
    const urdf::JointConstSharedPtr uj = model->getJoint(name);
    if (!uj) bad(field, jf + " unknown to urdfdom");
    RobotJoint j;
    j.name = name;
    j.parent = link_index.at(uj->parent_link_name);
    j.child = link_index.at(uj->child_link_name);
    const Origin o = read_origin(e, jf);
    j.origin_R = o.R;
    j.origin_t = o.t;
    j.origin_rotated = o.rotated;
    if (uj->type == urdf::Joint::REVOLUTE) {
      if (!uj->limits) bad(field, jf + " needs <limit lower upper velocity>");
      const Vec3 axis(uj->axis.x, uj->axis.y, uj->axis.z);
      if (!(std::abs(axis.norm() - 1) < 1e-9)) bad(field, jf + " axis must be a unit vector");
      j.axis = axis;
      if (!(uj->limits->lower < uj->limits->upper))
        bad(field, jf + " limit lower must be < upper");
      if (!(uj->limits->velocity > 0)) bad(field, jf + " limit velocity must be > 0");
      j.q = 0;  // numbered below
    } else if (uj->type != urdf::Joint::FIXED) {
      bad(field, jf + ": only revolute and fixed joints are supported");
    }
    if (r->parent_joint_[j.child] >= 0) bad(field, jf + ": link has two parents");
    r->parent_joint_[j.child] = static_cast<int>(joints.size());
    joints.push_back(std::move(j));
  }
  if (joints.size() > 256) bad(field, "at most 256 joints");
  int root_link = -1;
  for (int l = 0; l < nl; ++l)
    if (r->parent_joint_[l] < 0) {
      if (root_link >= 0) bad(field, "links \"" + r->links_[root_link] + "\" and \"" + r->links_[l] +
                                         "\" both have no parent: one tree is needed");
      root_link = l;
    }
  // Evaluation order: breadth-first from the root (urdfdom has already refused cycles).
  std::vector<int> order;
  std::vector<int> queue = {root_link};
  for (std::size_t k = 0; k < queue.size(); ++k)
    for (std::size_t ji = 0; ji < joints.size(); ++ji)
      if (joints[ji].parent == queue[k]) {
        order.push_back(static_cast<int>(ji));
        queue.push_back(joints[ji].child);
      }
  std::vector<int> q_of_file;  // revolute joints numbered in file order
  for (std::size_t ji = 0; ji < joints.size(); ++ji)
    if (joints[ji].q >= 0) {
      joints[ji].q = static_cast<int>(q_of_file.size());
      q_of_file.push_back(static_cast<int>(ji));
    }
  for (int ji : order) r->joints_.push_back(joints[ji]);
  for (std::size_t k = 0; k < r->joints_.size(); ++k) r->parent_joint_[r->joints_[k].child] = static_cast<int>(k);
  const int dof = static_cast<int>(q_of_file.size());
  if (dof < 1) bad(field, "needs at least one revolute joint");
  r->q_joint_.assign(dof, -1);
  r->q_min_.resize(dof);
  r->q_max_.resize(dof);
  r->velocity_max_.resize(dof);
  for (std::size_t k = 0; k < r->joints_.size(); ++k) {
    const RobotJoint& j = r->joints_[k];
    if (j.q < 0) continue;
    r->q_joint_[j.q] = static_cast<int>(k);
    const auto& lim = model->getJoint(j.name)->limits;
    r->q_min_[j.q] = lim->lower;
    r->q_max_[j.q] = lim->upper;
    r->velocity_max_[j.q] = lim->velocity;
  }
  // Revolute ancestors of each link (VecQ order, base first).
  r->moved_by_.assign(nl, {});
  for (const RobotJoint& j : r->joints_) {
    r->moved_by_[j.child] = r->moved_by_[j.parent];
    if (j.q >= 0) r->moved_by_[j.child].push_back(j.q);
  }

  // End effector.
  if (const TiXmlElement* e = root->FirstChildElement("distlab:end_effector")) {
    auto it = link_index.find(attr(e, "link"));
    if (it == link_index.end()) bad(field, "distlab:end_effector link is not a link of the robot");
    r->ee_link_ = it->second;
  } else {
    std::vector<int> leaves;
    for (int l = 0; l < nl; ++l) {
      bool leaf = true;
      for (const RobotJoint& j : r->joints_) leaf = leaf && j.parent != l;
      if (leaf) leaves.push_back(l);
    }
    if (leaves.size() != 1) bad(field, "several leaf links: name one with <distlab:end_effector link=\"...\"/>");
    r->ee_link_ = leaves[0];
  }

  // Collision primitives, in file order.
  std::set<std::string> names;
  for (int l = 0; l < nl; ++l) {
    const urdf::LinkConstSharedPtr ul = model->getLink(r->links_[l]);
    std::size_t c = 0;
    for (const TiXmlElement* e = link_xml[l]->FirstChildElement("collision"); e;
         e = e->NextSiblingElement("collision"), ++c) {
      const std::string name = attr(e, "name");
      const std::string cf = field + ": collision \"" + name.substr(0, 64) + "\" of link \"" + r->links_[l] + "\"";
      if (name.empty()) bad(field, "every collision of link \"" + r->links_[l] + "\" needs a name");
      if (!names.insert(name).second) bad(field, cf + ": name used twice");
      if (c >= ul->collision_array.size() || !ul->collision_array[c]->geometry) bad(field, cf + ": no geometry");
      const urdf::GeometrySharedPtr& g = ul->collision_array[c]->geometry;
      Shape shape;
      auto positive = [&](double v, const char* what) {
        if (!(v > 0) || !(v < 100)) bad(field, cf + ": " + what + " must be in (0, 100) m");
        return v;
      };
      if (g->type == urdf::Geometry::BOX) {
        const auto& s = static_cast<const urdf::Box&>(*g).dim;
        shape = Box{Vec3(positive(s.x, "box size"), positive(s.y, "box size"), positive(s.z, "box size"))};
      } else if (g->type == urdf::Geometry::CYLINDER) {
        const auto& cyl = static_cast<const urdf::Cylinder&>(*g);
        const std::string capsule = attr(e, "distlab:capsule");
        if (capsule == "true") shape = Capsule{positive(cyl.radius, "radius"), positive(cyl.length, "length")};
        else if (capsule.empty() || capsule == "false") shape = Cylinder{positive(cyl.radius, "radius"), positive(cyl.length, "length")};
        else bad(field, cf + ": distlab:capsule must be \"true\" or \"false\"");
      } else if (g->type == urdf::Geometry::SPHERE) {
        shape = Sphere{positive(static_cast<const urdf::Sphere&>(*g).radius, "radius")};
      } else {
        bad(field, cf + ": only box, cylinder (capsule) and sphere are supported");
      }
      const Origin o = read_origin(e, cf);
      r->primitives_.push_back({name, l, std::move(shape), make_pose(o.t, o.q)});
    }
  }
  // Self-collision pairs: primitives of links at least two revolute joints apart along the tree
  // path (revolute ancestors of one but not both).
  for (int i = 0; i < static_cast<int>(r->primitives_.size()); ++i)
    for (int j = i + 1; j < static_cast<int>(r->primitives_.size()); ++j) {
      const auto& a = r->moved_by_[r->primitives_[i].link];
      const auto& b = r->moved_by_[r->primitives_[j].link];
      std::size_t common = 0;
      while (common < a.size() && common < b.size() && a[common] == b[common]) ++common;
      if ((a.size() - common) + (b.size() - common) >= 2) r->self_pairs_.emplace_back(i, j);
    }
  return r;
}

int Robot::link_index(const std::string& name) const {
  for (std::size_t i = 0; i < links_.size(); ++i)
    if (links_[i] == name) return static_cast<int>(i);
  return -1;
}

std::vector<std::string> Robot::joint_names() const {
  std::vector<std::string> out;
  for (int k : q_joint_) out.push_back(joints_[k].name);
  return out;
}

// World frames, parents first. A fixed joint right after a revolute one is evaluated with it as
// one local transform from the grandparent (how a DH row Rz(q)·Tz(d)·Rx(α)·Tx(a) is evaluated:
// Rz(q)·Rx(α) and Rz(q)·(a, 0, d) first, then the previous frame).
Kinematics Robot::forward(const VecQ& q) const {
  Kinematics k;
  forward(q, k);
  return k;
}

void Robot::forward(const VecQ& q, Kinematics& k) const {
  const int nl = static_cast<int>(links_.size());
  k.frames.resize(nl);
  k.R.resize(nl);
  for (int l = 0; l < nl; ++l)
    if (parent_joint_[l] < 0) k.frames[l] = Pose{}, k.R[l] = Mat3::Identity();
  k.axis.resize(dof());
  k.origin.resize(dof());
  k.local_R.resize(joints_.size());
  k.local_t.resize(joints_.size());
  std::vector<Mat3>& local_R = k.local_R;
  std::vector<Vec3>& local_t = k.local_t;
  for (std::size_t ji = 0; ji < joints_.size(); ++ji) {
    const RobotJoint& j = joints_[ji];
    Mat3 R = j.origin_R;
    if (j.q >= 0) {
      Mat3 rot;
      if (j.axis == Vec3::UnitZ()) {
        const double c = std::cos(q[j.q]), s = std::sin(q[j.q]);
        rot << c, -s, 0, s, c, 0, 0, 0, 1;
      } else {
        rot = Eigen::AngleAxisd(q[j.q], j.axis).toRotationMatrix();
      }
      R = j.origin_rotated ? Mat3(j.origin_R * rot) : rot;
      k.axis[j.q] = k.R[j.parent] * (j.origin_R * j.axis);
      k.origin[j.q] = k.frames[j.parent].position + k.R[j.parent] * j.origin_t;
    }
    local_R[ji] = R;
    local_t[ji] = j.origin_t;
    int base = j.parent;
    const int pj = parent_joint_[j.parent];
    if (j.q < 0 && pj >= 0 && joints_[pj].q >= 0) {  // fuse with the revolute joint before
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
  Jac J = Jac::Zero(6, dof());
  for (int j : moved_by_[link]) {
    J.block<3, 1>(0, j) = k.axis[j].cross(p - k.origin[j]);
    J.block<3, 1>(3, j) = k.axis[j];
  }
  return J;
}

Pose Robot::primitive_pose(const Kinematics& k, int i) const {
  const LinkPrimitive& prim = primitives_[i];
  return compose(k.frames[prim.link], prim.pose);
}

}  // namespace distlab::cbf
