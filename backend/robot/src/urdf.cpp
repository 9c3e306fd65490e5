// Robots from URDF (urdfdom). The subset and its extensions:
// - joints: revolute and prismatic (<limit lower upper>; none given: unbounded, with a warning;
//   velocity optional), continuous (unbounded), fixed, and <mimic joint multiplier offset> of any
//   moving one (chains followed); one tree from one root link; no moving joint at all is a rigid
//   body (dof 0). floating and planar joints are refused.
// - collisions: <box size>, <cylinder radius length> (axis z, centred), <sphere radius>, and
//   <mesh filename scale> (the convex hull of the mesh's vertices, scaled); a capsule is a
//   <cylinder> whose <collision> has distlab:capsule="true" (length = its core segment).
// - <origin ... distlab:quaternion="w x y z"/>: an exact rotation for an origin (rpy must give
//   the same rotation for other URDF readers; checked to 1e-9).
// - <distlab:end_effector link="..."/>: the end-effector link (default: the one leaf link, or the
//   last link in file order when there are several).
// urdfdom keeps origins only as quaternions computed from rpy; origins are read from the XML
// text instead so that an rpy rotation about one axis is the exact cos/sin matrix, e.g. the
// Rx(α) of a DH row Rz(q)·Tz(d)·Rx(α)·Tx(a) (a revolute joint, then a fixed joint).
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>

#include <console_bridge/console.h>
#include <tinyxml.h>
#include <urdf_parser/urdf_parser.h>
#include <Eigen/Geometry>

#include "collision_mesh.hpp"
#include "distlab/geometry/error.hpp"
#include "distlab/robot/robot.hpp"
#include "urdf_text.hpp"

namespace distlab::robot {
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

std::string quoted(const std::string& s) { return "\"" + s.substr(0, 64) + "\""; }

// urdfdom leaves a collision element without geometry when it cannot read it ("nan" in a size,
// a missing radius): the element `cf` is refused naming what in its XML is wrong.
[[noreturn]] void bad_geometry(const TiXmlElement* collision, const std::string& field, const std::string& cf) {
  const TiXmlElement* g = collision->FirstChildElement("geometry");
  const TiXmlElement* shape = g ? g->FirstChildElement() : nullptr;
  if (!shape) bad(field, cf + ": no geometry");
  const std::string kind = shape->Value(), at = cf + ": <" + kind.substr(0, 64) + "> ";
  auto need = [&](const char* name, std::size_t count) {
    const char* v = shape->Attribute(name);
    if (!v) bad(field, at + "has no " + name);
    if (count > 0) numbers(v, count, field, at + name);
  };
  if (kind == "box") {
    need("size", 3);
  } else if (kind == "sphere") {
    need("radius", 1);
  } else if (kind == "cylinder") {
    need("radius", 1), need("length", 1);
  } else if (kind == "mesh") {
    need("filename", 0);
    if (shape->Attribute("scale")) need("scale", 3);
  } else {
    bad(field, at + "is not a URDF geometry (box, cylinder, sphere or mesh)");
  }
  bad(field, cf + ": urdfdom cannot read its geometry");
}

// urdfdom says why it refuses a description through console_bridge (to stderr by default, where a
// caller never sees it and a server's log fills up): its errors are captured for the exception.
// The handler is process-wide, so parses take turns.
class CapturedErrors : public console_bridge::OutputHandler {
 public:
  void log(const std::string& text, console_bridge::LogLevel level, const char* /*file*/, int /*line*/) override {
    if (level < console_bridge::CONSOLE_BRIDGE_LOG_ERROR || text_.size() > 400) return;
    if (!text_.empty()) text_ += "; ";
    text_ += text.substr(0, 200);
  }
  const std::string& text() const { return text_; }

 private:
  std::string text_;
};

// The links and joints must form one tree before urdfdom sees them: on a cycle (no root link)
// urdfdom 3.0 fails with its links holding each other (shared pointers in a ring), which leaks
// them on every such request.
void check_tree(const TiXmlElement* robot, const std::string& field, const DescriptionLimits& limits) {
  std::map<std::string, std::string> parent;  // child link -> parent link
  std::map<std::string, int> links;
  for (const TiXmlElement* e = robot->FirstChildElement("link"); e; e = e->NextSiblingElement("link"))
    if (++links[attr(e, "name")] > 1) bad(field, "link " + quoted(attr(e, "name")) + " is defined twice");
  std::map<std::string, int> joints;
  for (const TiXmlElement* e = robot->FirstChildElement("joint"); e; e = e->NextSiblingElement("joint")) {
    const std::string jf = "joint " + quoted(attr(e, "name"));
    if (++joints[attr(e, "name")] > 1) bad(field, jf + " is defined twice");
    const TiXmlElement* p = e->FirstChildElement("parent");
    const TiXmlElement* c = e->FirstChildElement("child");
    if (!p || !c) bad(field, jf + " needs <parent link> and <child link>");
    const std::string pl = attr(p, "link"), cl = attr(c, "link");
    if (!links.count(pl) || !links.count(cl)) bad(field, jf + " names a link the URDF does not define");
    if (!parent.emplace(cl, pl).second) bad(field, jf + ": link " + quoted(cl) + " has two parents");
  }
  if (links.size() > static_cast<std::size_t>(limits.links)) bad(field, "at most " + std::to_string(limits.links) + " links");
  if (joints.size() > static_cast<std::size_t>(limits.joints)) bad(field, "at most " + std::to_string(limits.joints) + " joints");
  std::vector<std::string> roots;
  for (const auto& [link, count] : links)
    if (!parent.count(link)) roots.push_back(link);
  if (roots.size() > 1)
    bad(field, "links " + quoted(roots[0]) + " and " + quoted(roots[1]) + " both have no parent: one tree is needed");
  for (const auto& [link, count] : links) {  // walk up from every link: a root, or a cycle
    std::string at = link;
    for (std::size_t steps = 0; parent.count(at); ++steps) {
      if (steps > parent.size()) bad(field, "the joints form a cycle through link " + quoted(link) + ": one tree is needed");
      at = parent.at(at);
    }
  }
}

urdf::ModelInterfaceSharedPtr parse_urdf(const std::string& xml, std::string& errors) {
  static std::mutex mutex;
  const std::lock_guard lock(mutex);
  CapturedErrors captured;
  console_bridge::useOutputHandler(&captured);
  urdf::ModelInterfaceSharedPtr model;
  try {
    model = urdf::parseURDF(xml);
  } catch (...) {
    console_bridge::restorePreviousOutputHandler();
    throw;
  }
  console_bridge::restorePreviousOutputHandler();
  errors = captured.text();
  return model;
}

}  // namespace

Pose compose(const Pose& a, const Pose& b) {
  return make_pose(a.position + a.rotation * b.position, (a.rotation * b.rotation).normalized());
}

std::shared_ptr<const Robot> Robot::from_file(const std::string& path, const std::string& field, UrdfOptions options) {
  std::ifstream f(path, std::ios::binary);
  if (!f) {
    const std::string name = path.substr(path.find_last_of('/') + 1);  // npos + 1 = 0: all of it
    throw InvalidInput(field, "cannot read the robot file \"" + name.substr(0, 200) + "\": " + std::strerror(errno));
  }
  std::stringstream text;
  text << f.rdbuf();
  if (options.base_dir.empty()) {
    const auto slash = path.find_last_of('/');
    options.base_dir = slash == std::string::npos ? "." : path.substr(0, slash);
  }
  return from_urdf(text.str(), field, options);
}

std::shared_ptr<const Robot> Robot::load(const std::string& path, const std::string& field) {
  static std::mutex mutex;
  static std::map<std::string, std::shared_ptr<const Robot>> cache;
  std::lock_guard<std::mutex> lock(mutex);
  if (auto it = cache.find(path); it != cache.end()) return it->second;
  auto robot = from_file(path, field);
  cache[path] = robot;
  return robot;
}

std::shared_ptr<const Robot> Robot::from_urdf(const std::string& xml, const std::string& field,
                                              const UrdfOptions& options) {
  if (const std::size_t max = options.limits.urdf_bytes; xml.size() > max)
    bad(field, "at most " + (max % (std::size_t{1} << 20) == 0 ? std::to_string(max >> 20) + " MiB" : std::to_string(max) + " bytes"));
  check_urdf_text(xml, field);  // once, before both parsers below
  TiXmlDocument doc;
  doc.Parse(xml.c_str());
  const TiXmlElement* root = doc.RootElement();
  if (doc.Error() || !root) bad(field, "not XML");
  check_tree(root, field, options.limits);
  std::string reason;
  const urdf::ModelInterfaceSharedPtr model = parse_urdf(xml, reason);
  if (!model) bad(field, "urdfdom cannot parse it" + (reason.empty() ? std::string() : ": " + reason));

  auto r = std::make_shared<Robot>();
  r->name_ = model->getName();
  std::map<std::string, int> link_index;
  std::vector<const TiXmlElement*> link_xml;
  for (const TiXmlElement* e = root->FirstChildElement("link"); e; e = e->NextSiblingElement("link")) {
    link_index[attr(e, "name")] = static_cast<int>(r->links_.size());
    r->links_.push_back(attr(e, "name"));
    link_xml.push_back(e);
  }
  const int nl = static_cast<int>(r->links_.size());  // check_tree: at most limits.links, one tree

  // Joints in file order; evaluation order (parents first) below.
  std::vector<RobotJoint> joints;
  std::map<std::string, int> joint_of_name;  // file order
  r->parent_joint_.assign(nl, -1);
  for (const TiXmlElement* e = root->FirstChildElement("joint"); e; e = e->NextSiblingElement("joint")) {
    const std::string name = attr(e, "name");
    const std::string jf = "joint " + quoted(name);
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
    switch (uj->type) {
      case urdf::Joint::REVOLUTE:
      case urdf::Joint::CONTINUOUS:
        j.type = JointType::revolute;
        break;
      case urdf::Joint::PRISMATIC:
        j.type = JointType::prismatic;
        break;
      case urdf::Joint::FIXED:
        break;
      default:
        bad(field, jf + ": type " + quoted(attr(e, "type")) +
                       " is not supported (supported: revolute, continuous, prismatic, fixed)");
    }
    if (j.type != JointType::fixed) {
      const Vec3 axis(uj->axis.x, uj->axis.y, uj->axis.z);
      if (!(axis.norm() > 1e-9)) bad(field, jf + ": axis must be a non-zero vector");
      // urdfdom normalises the axis; keep an exact unit axis as written (bit-identical frames).
      j.axis = std::abs(axis.norm() - 1) < 1e-12 ? axis : Vec3(axis.normalized());
      j.q = 0;  // numbered below
    }
    r->parent_joint_[j.child] = static_cast<int>(joints.size());
    joint_of_name[name] = static_cast<int>(joints.size());
    joints.push_back(std::move(j));
  }
  int root_link = -1;  // the one link without a parent (check_tree)
  for (int l = 0; l < nl && root_link < 0; ++l)
    if (r->parent_joint_[l] < 0) root_link = l;

  // Independent joints numbered in file order; then each mimic takes its mimicked joint's number.
  std::vector<int> q_of_file;
  for (std::size_t ji = 0; ji < joints.size(); ++ji) {
    RobotJoint& j = joints[ji];
    if (j.type == JointType::fixed) continue;
    const urdf::JointConstSharedPtr uj = model->getJoint(j.name);
    if (uj->mimic) {
      j.mimic = true;
      j.multiplier = uj->mimic->multiplier;
      j.offset = uj->mimic->offset;
      if (!std::isfinite(j.multiplier) || !std::isfinite(j.offset) || std::abs(j.multiplier) > 1e6 ||
          std::abs(j.offset) > 1e6)
        bad(field, "joint " + quoted(j.name) + ": mimic multiplier and offset must be finite");
      continue;
    }
    j.q = static_cast<int>(q_of_file.size());
    q_of_file.push_back(static_cast<int>(ji));
  }
  // A mimic of a mimic follows the chain: θ = m1 (m2 q + o2) + o1.
  for (RobotJoint& j : joints) {
    if (!j.mimic) continue;
    const RobotJoint* source = &j;
    double multiplier = 1, offset = 0;
    for (std::size_t hops = 0; source->mimic; ++hops) {
      const urdf::JointMimic& mimic = *model->getJoint(source->name)->mimic;  // the file's numbers
      const std::string& mimicked = mimic.joint_name;
      const auto it = joint_of_name.find(mimicked);
      if (it == joint_of_name.end())
        bad(field, "joint " + quoted(j.name) + ": mimics joint " + quoted(mimicked) + ", which the URDF does not have");
      if (joints[it->second].type == JointType::fixed)
        bad(field, "joint " + quoted(j.name) + ": mimics joint " + quoted(mimicked) + ", a fixed joint");
      if (hops > joints.size()) bad(field, "joint " + quoted(j.name) + ": its mimic joints form a cycle");
      offset += multiplier * mimic.offset;
      multiplier *= mimic.multiplier;
      source = &joints[it->second];
    }
    j.multiplier = multiplier;
    j.offset = offset;
    j.q = source->q;
  }
  const int dof = static_cast<int>(q_of_file.size());
  r->q_min_.resize(dof);
  r->q_max_.resize(dof);
  r->velocity_max_.resize(dof);
  r->q_type_.resize(dof);
  for (int i = 0; i < dof; ++i) {
    const RobotJoint& j = joints[q_of_file[i]];
    const urdf::JointConstSharedPtr uj = model->getJoint(j.name);
    const std::string jf = "joint " + quoted(j.name);
    r->q_type_[i] = j.type;
    constexpr double inf = std::numeric_limits<double>::infinity();
    if (uj->type == urdf::Joint::CONTINUOUS) {
      r->q_min_[i] = -inf;
      r->q_max_[i] = inf;
    } else if (!uj->limits || (uj->limits->lower == 0 && uj->limits->upper == 0)) {
      // No <limit>, or one without lower and upper (urdfdom reads both as 0): unbounded.
      r->q_min_[i] = -inf;
      r->q_max_[i] = inf;
      r->warnings_.push_back(jf + " has no lower and upper limit: taken as unbounded");
    } else {
      if (!(uj->limits->lower < uj->limits->upper)) bad(field, jf + " limit lower must be < upper");
      r->q_min_[i] = uj->limits->lower;
      r->q_max_[i] = uj->limits->upper;
    }
    const double v = uj->limits ? uj->limits->velocity : 0.0;
    if (!(v >= 0) || !std::isfinite(v)) bad(field, jf + " limit velocity must be finite and >= 0");
    r->velocity_max_[i] = v > 0 ? v : inf;  // 0 or absent: not given
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
  std::vector<int> eval_of_file(joints.size());
  for (int ji : order) {
    eval_of_file[ji] = static_cast<int>(r->joints_.size());
    r->joints_.push_back(joints[ji]);
  }
  for (std::size_t k = 0; k < r->joints_.size(); ++k) r->parent_joint_[r->joints_[k].child] = static_cast<int>(k);
  r->q_joint_.resize(dof);
  for (int i = 0; i < dof; ++i) r->q_joint_[i] = eval_of_file[q_of_file[i]];
  // Moving ancestors of each link (evaluation order, root first).
  r->moved_by_.assign(nl, {});
  for (std::size_t k = 0; k < r->joints_.size(); ++k) {
    const RobotJoint& j = r->joints_[k];
    r->moved_by_[j.child] = r->moved_by_[j.parent];
    if (j.type != JointType::fixed) r->moved_by_[j.child].push_back(static_cast<int>(k));
  }

  // End effector.
  if (const TiXmlElement* e = root->FirstChildElement("distlab:end_effector")) {
    auto it = link_index.find(attr(e, "link"));
    if (it == link_index.end()) bad(field, "distlab:end_effector link is not a link of the robot");
    r->ee_link_ = it->second;
  } else {
    std::vector<bool> leaf(nl, true);
    for (const RobotJoint& j : r->joints_) leaf[j.parent] = false;
    for (int l = 0; l < nl; ++l)
      if (leaf[l]) r->ee_link_ = l;  // the last leaf in file order
  }

  // Collision elements, in file order.
  for (int l = 0; l < nl; ++l) {
    const urdf::LinkConstSharedPtr ul = model->getLink(r->links_[l]);
    int c = 0;
    for (const TiXmlElement* e = link_xml[l]->FirstChildElement("collision"); e;
         e = e->NextSiblingElement("collision"), ++c) {
      const std::string given = attr(e, "name");
      const std::string name = given.empty() ? r->links_[l] + "/collision[" + std::to_string(c) + "]" : given;
      const std::string cf = "collision[" + std::to_string(c) + "] " + (given.empty() ? "" : quoted(given) + " ") +
                             "of link " + quoted(r->links_[l]);
      if (static_cast<int>(r->primitives_.size()) >= options.limits.collision_elements)
        bad(field, "at most " + std::to_string(options.limits.collision_elements) + " collision elements");
      if (c >= static_cast<int>(ul->collision_array.size()) || !ul->collision_array[c]->geometry)
        bad_geometry(e, field, cf);
      const urdf::GeometrySharedPtr& g = ul->collision_array[c]->geometry;
      LinkPrimitive prim{name, l, c, Sphere{1}, Pose{}, ""};
      auto positive = [&](double v, const char* what) {
        if (!(v > 0) || !(v < 100)) bad(field, cf + ": " + what + " must be in (0, 100) m");
        return v;
      };
      if (g->type == urdf::Geometry::BOX) {
        const auto& s = static_cast<const urdf::Box&>(*g).dim;
        prim.shape = Box{Vec3(positive(s.x, "box size"), positive(s.y, "box size"), positive(s.z, "box size"))};
      } else if (g->type == urdf::Geometry::CYLINDER) {
        const auto& cyl = static_cast<const urdf::Cylinder&>(*g);
        const std::string capsule = attr(e, "distlab:capsule");
        if (capsule == "true") prim.shape = Capsule{positive(cyl.radius, "radius"), positive(cyl.length, "length")};
        else if (capsule.empty() || capsule == "false") prim.shape = Cylinder{positive(cyl.radius, "radius"), positive(cyl.length, "length")};
        else bad(field, cf + ": distlab:capsule must be \"true\" or \"false\"");
      } else if (g->type == urdf::Geometry::SPHERE) {
        prim.shape = Sphere{positive(static_cast<const urdf::Sphere&>(*g).radius, "radius")};
      } else if (g->type == urdf::Geometry::MESH) {
        const auto& m = static_cast<const urdf::Mesh&>(*g);
        const Vec3 scale(m.scale.x, m.scale.y, m.scale.z);
        if (!scale.allFinite() || !(scale.cwiseAbs().minCoeff() > 0) || scale.cwiseAbs().maxCoeff() > 1e6)
          bad(field, cf + ": mesh scale must be finite and non-zero");
        prim.mesh = m.filename;
        try {
          std::string warning;
          prim.shape = mesh_hull(m.filename, scale, options, field, warning);
          if (!warning.empty()) r->warnings_.push_back(cf + ": " + warning.substr(std::string("robot URDF: ").size()));
        } catch (const InvalidInput& error) {
          // The field stays the caller's; the message names the element before the mesh's defect.
          std::string what = error.what();
          if (what.rfind("robot URDF: ", 0) == 0) what.erase(0, 12);
          std::string message = "robot URDF: ";
          message.append(cf).append(": ").append(what);
          throw InvalidInput(error.field(), message);
        }
      } else {
        bad(field, cf + ": unknown geometry (supported: box, cylinder, sphere, mesh)");
      }
      const Origin o = read_origin(e, cf);
      prim.pose = make_pose(o.t, o.q);
      r->primitives_.push_back(std::move(prim));
    }
  }
  r->euclidean_.reserve(r->primitives_.size());
  for (const LinkPrimitive& prim : r->primitives_) r->euclidean_.emplace_back(prim.shape);
  // Self-collision pairs: elements of links at least two moving joints apart along the tree path.
  for (int i = 0; i < static_cast<int>(r->primitives_.size()); ++i)
    for (int j = i + 1; j < static_cast<int>(r->primitives_.size()); ++j)
      if (r->joints_between(r->primitives_[i].link, r->primitives_[j].link) >= 2) r->self_pairs_.emplace_back(i, j);
  return r;
}

int Robot::link_index(const std::string& name) const {
  for (std::size_t i = 0; i < links_.size(); ++i)
    if (links_[i] == name) return static_cast<int>(i);
  return -1;
}

int Robot::joints_between(int link_a, int link_b) const {
  const auto& a = moved_by_[link_a];
  const auto& b = moved_by_[link_b];
  std::size_t common = 0;
  while (common < a.size() && common < b.size() && a[common] == b[common]) ++common;
  return static_cast<int>((a.size() - common) + (b.size() - common));
}

std::vector<std::string> Robot::joint_names() const {
  std::vector<std::string> out;
  for (int k : q_joint_) out.push_back(joints_[k].name);
  return out;
}

}  // namespace distlab::robot
