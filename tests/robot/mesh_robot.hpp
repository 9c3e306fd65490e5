#pragma once
// A robot written by the test: a tree of six links with rotated joint origins, a revolute,
// prismatic, continuous, mimic and fixed joint and a branch, whose collision elements are mesh
// files in five formats (binary STL, ASCII STL, OBJ with quads, PLY, OFF), with uniform,
// non-uniform and mirroring scales, named relative, package:// and absolute, plus a box and a
// sphere. The same numbers give the URDF text and the tests' own forward kinematics (4×4
// matrices) and hulls (the scaled meshes' extreme points, known by construction).
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "robot_test_util.hpp"

namespace distlab::robot::test {

struct JointSpec {
  std::string name, type, parent, child;
  Vec3 xyz, rpy;
  Vec3 axis = Vec3::UnitZ();
  double lower = 0, upper = 0;
  std::string mimic;  // the mimicked joint, or ""
  double multiplier = 1, offset = 0;
};

struct ElementSpec {
  std::string link, name;  // name "" writes no name attribute
  std::string geometry;    // the <geometry> child as written (a <mesh> gets filename and scale)
  Vec3 xyz, rpy;
  // Meshes: the file (its format's text, where, and its filename as the URDF writes it), the
  // scale, and the extreme points of the unscaled mesh.
  PolyMesh mesh;
  std::string file_text, file_path, filename;
  Vec3 scale = Vec3::Ones();
  std::vector<Vec3> extreme;
};

struct MeshRobot {
  std::vector<JointSpec> joints;  // file order
  std::vector<std::string> links;
  std::vector<ElementSpec> elements;  // file order (links in file order, then element order)
  std::string urdf, urdf_path;
  UrdfOptions options;  // package_dirs {"pkg": ...}
  std::string package_dir;
};

inline std::string vec_attr(const Vec3& v) { return numbers(v); }

inline ElementSpec element(const std::string& link, const std::string& name, const std::string& geometry,
                           const Vec3& xyz, const Vec3& rpy) {
  ElementSpec e;
  e.link = link;
  e.name = name;
  e.geometry = geometry;
  e.xyz = xyz;
  e.rpy = rpy;
  return e;
}

// The dented box: a box (half extents h, dyadic numbers: exact in a binary STL's floats) whose
// top face is a fan to a vertex pushed inside and whose bottom face is a fan to a point on it;
// neither of those two is an extreme point.
inline PolyMesh dented_box(const Vec3& h, std::vector<Vec3>& extreme) {
  PolyMesh m = box_mesh(h);
  extreme = m.vertices;
  m.vertices.emplace_back(h.x() / 8, -h.y() / 8, 0.0);                // 8: below the top face
  m.vertices.emplace_back(h.x() / 4, h.y() / 4, -h.z());              // 9: on the bottom face
  m.faces = {{0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5},  // sides
             {4, 5, 8},
             {5, 7, 8},
             {7, 6, 8},
             {6, 4, 8},  // top fan
             {0, 2, 9},
             {2, 3, 9},
             {3, 1, 9},
             {1, 0, 9}};  // bottom fan
  return m;
}

inline MeshRobot write_mesh_robot(const TempDir& dir) {
  MeshRobot r;
  r.package_dir = dir.path() + "/share/pkg";  // also found through package_search_dirs {share}
  r.links = {"base", "l1", "l2", "l3", "l4", "l5", "l6"};
  // File order: j6 (the branch) second, so the independent joints are numbered j1, j6, j2, j3.
  const auto joint = [](const char* name, const char* type, const char* parent, const char* child, const Vec3& xyz,
                        const Vec3& rpy, const Vec3& axis = Vec3::UnitZ(), double lower = 0, double upper = 0) {
    JointSpec j;
    j.name = name, j.type = type, j.parent = parent, j.child = child;
    j.xyz = xyz, j.rpy = rpy, j.axis = axis, j.lower = lower, j.upper = upper;
    return j;
  };
  r.joints = {
      joint("j1", "revolute", "base", "l1", Vec3(0.1, -0.2, 0.3), Vec3(0.3, -0.4, 0.5), Vec3(0, 0.6, 0.8), -2, 2),
      joint("j6", "revolute", "l1", "l6", Vec3(-0.1, 0, 0.2), Vec3::Zero(), Vec3(0, 1, 0), -1.5, 1.5),
      joint("j2", "prismatic", "l1", "l2", Vec3(0.2, 0.05, -0.1), Vec3(-0.7, 0.2, 1.1), Vec3(0.48, 0.6, 0.64), -0.1, 0.3),
      joint("j3", "continuous", "l2", "l3", Vec3(0, 0.15, 0.05), Vec3(1.2, 0, -0.3)),
      joint("j4", "revolute", "l3", "l4", Vec3(0.12, 0, 0), Vec3(0, 0.9, 0), Vec3(1, 0, 0), -3, 3),
      joint("j5", "fixed", "l4", "l5", Vec3(0, 0, 0.1), Vec3(0.2, 0.3, 0.4)),
  };
  r.joints[4].mimic = "j1";  // j4 = −0.5 j1 + 0.2
  r.joints[4].multiplier = -0.5;
  r.joints[4].offset = 0.2;

  ElementSpec dented = element("l1", "", "", Vec3(0.01, 0.02, 0.03), Vec3(0.1, 0.2, 0.3));
  dented.mesh = dented_box(Vec3(0.125, 0.0625, 0.03125), dented.extreme);
  dented.file_text = binary_stl(dented.mesh);
  dented.file_path = dir.path() + "/robot/meshes/dented.stl";
  dented.filename = "meshes/dented.stl";  // relative to the URDF's folder
  dented.scale = Vec3(0.5, 1, 2);

  ElementSpec wedge = element("l2", "wedge", "", Vec3(0, 0, 0.02), Vec3::Zero());
  wedge.mesh.vertices = {Vec3(0, 0, -0.05), Vec3(0.1, 0, -0.05), Vec3(0, 0.08, -0.05),
                         Vec3(0, 0, 0.05), Vec3(0.1, 0, 0.05), Vec3(0, 0.08, 0.05)};
  wedge.mesh.faces = {{0, 2, 1}, {3, 4, 5}, {0, 1, 4, 3}, {1, 2, 5, 4}, {2, 0, 3, 5}};
  wedge.extreme = wedge.mesh.vertices;
  wedge.file_text = ascii_stl(wedge.mesh);
  wedge.file_path = r.package_dir + "/meshes/wedge.stl";
  wedge.filename = "package://pkg/meshes/wedge.stl";  // no scale attribute: 1 1 1

  ElementSpec box = element("l3", "", "", Vec3(0.05, 0, 0), Vec3(0, 0, 0.4));
  box.mesh = box_mesh(Vec3(1, 0.5, 0.25));
  box.extreme = box.mesh.vertices;
  box.file_text = obj(box.mesh);  // quads
  box.file_path = dir.path() + "/robot/meshes/box.obj";
  box.filename = "meshes/box.obj";
  box.scale = Vec3(0.1, 0.2, 0.3);

  ElementSpec l3_box = element("l3", "l3_box", R"(<box size="0.05 0.04 0.03"/>)", Vec3(-0.05, 0.1, 0), Vec3(0.5, 0, 0));

  ElementSpec octahedron = element("l4", "", "", Vec3::Zero(), Vec3(0, 0, 0.7));
  const double a = 0.06;
  octahedron.mesh.vertices = {Vec3(a, 0, 0), Vec3(-a, 0, 0), Vec3(0, a, 0), Vec3(0, -a, 0), Vec3(0, 0, a), Vec3(0, 0, -a)};
  octahedron.mesh.faces = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  octahedron.extreme = octahedron.mesh.vertices;
  octahedron.file_text = ascii_ply(octahedron.mesh);
  octahedron.file_path = dir.path() + "/elsewhere/octahedron.ply";
  octahedron.filename = octahedron.file_path;  // absolute
  octahedron.scale = Vec3(1, 1, 1.5);

  ElementSpec pyramid = element("l5", "pyramid", "", Vec3(0, 0.02, 0), Vec3(-0.3, 0, 0));
  pyramid.mesh.vertices = {Vec3(-0.05, -0.05, 0), Vec3(0.05, -0.05, 0), Vec3(0.05, 0.05, 0), Vec3(-0.05, 0.05, 0),
                           Vec3(0.01, 0.02, 0.08)};
  pyramid.mesh.faces = {{0, 3, 2, 1}, {0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}};
  pyramid.extreme = pyramid.mesh.vertices;
  pyramid.file_text = off(pyramid.mesh);
  pyramid.file_path = r.package_dir + "/pyramid.off";
  pyramid.filename = "package://pkg/pyramid.off";
  pyramid.scale = Vec3(-1.5, 1, 1);  // mirrored

  ElementSpec ball = element("l6", "ball", R"(<sphere radius="0.03"/>)", Vec3(0, 0, 0.05), Vec3::Zero());
  r.elements = {dented, wedge, box, l3_box, octahedron, pyramid, ball};

  std::string x = R"(<?xml version="1.0"?>)"
                  "\n<robot name=\"meshy\">\n";
  for (const std::string& link : r.links) {
    x += "  <link name=\"" + link + "\">\n";
    for (ElementSpec& e : r.elements) {
      if (e.link != link) continue;
      std::string geometry = e.geometry;
      if (!e.filename.empty()) {
        dir.write(std::filesystem::relative(e.file_path, dir.path()).string(), e.file_text);
        geometry = "<mesh filename=\"" + e.filename + "\"" +
                   (e.scale == Vec3::Ones() ? std::string() : " scale=\"" + vec_attr(e.scale) + "\"") + "/>";
      }
      x += "    <collision" + (e.name.empty() ? std::string() : " name=\"" + e.name + "\"") + ">\n";
      x += "      <origin xyz=\"" + vec_attr(e.xyz) + "\" rpy=\"" + vec_attr(e.rpy) + "\"/>\n";
      x += "      <geometry>" + geometry + "</geometry>\n    </collision>\n";
    }
    x += "  </link>\n";
  }
  for (const JointSpec& j : r.joints) {
    x += "  <joint name=\"" + j.name + "\" type=\"" + j.type + "\">\n    <parent link=\"" + j.parent +
         "\"/>\n    <child link=\"" + j.child + "\"/>\n";
    x += "    <origin xyz=\"" + vec_attr(j.xyz) + "\" rpy=\"" + vec_attr(j.rpy) + "\"/>\n";
    if (j.type != "fixed") x += "    <axis xyz=\"" + vec_attr(j.axis) + "\"/>\n";
    if (j.type == "revolute" || j.type == "prismatic")
      x += "    <limit lower=\"" + number(j.lower) + "\" upper=\"" + number(j.upper) + "\" velocity=\"1\" effort=\"1\"/>\n";
    if (!j.mimic.empty())
      x += "    <mimic joint=\"" + j.mimic + "\" multiplier=\"" + number(j.multiplier) + "\" offset=\"" + number(j.offset) + "\"/>\n";
    x += "  </joint>\n";
  }
  x += "</robot>\n";
  r.urdf = x;
  r.urdf_path = dir.write("robot/meshy.urdf", x);  // relative meshes: robot/meshes/
  r.options.package_dirs["pkg"] = r.package_dir;
  return r;
}

// World transforms of every link at q (VecQ order j1, j6, j2, j3), from the specs alone.
inline std::map<std::string, Mat4> spec_fk(const MeshRobot& r, const VecQ& q) {
  const std::map<std::string, int> index = {{"j1", 0}, {"j6", 1}, {"j2", 2}, {"j3", 3}};
  std::map<std::string, Mat4> T = {{"base", Mat4::Identity()}};
  while (T.size() < r.links.size())
    for (const JointSpec& j : r.joints) {
      if (!T.count(j.parent) || T.count(j.child)) continue;
      const double theta = j.mimic.empty() ? (j.type == "fixed" ? 0.0 : q[index.at(j.name)])
                                           : j.multiplier * q[index.at(j.mimic)] + j.offset;
      const Vec3 axis = j.axis.normalized();
      Mat4 motion = Mat4::Identity();
      if (j.type == "prismatic") motion = translation(theta * axis);
      else if (j.type != "fixed") motion = rotation(axis, theta);
      T[j.child] = T.at(j.parent) * origin(j.xyz, j.rpy) * motion;
    }
  return T;
}

}  // namespace distlab::robot::test
