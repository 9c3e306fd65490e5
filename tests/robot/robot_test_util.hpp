#pragma once
// Shared by the robot tests: the built-in Panda, random configurations, a Jacobian check by
// central differences, an error's field and message, a temporary folder, and mesh files written
// byte by byte (binary and ASCII STL, OBJ, PLY, OFF) for URDF <mesh> elements.
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "collision/collision_test_util.hpp"

#include "distlab/geometry/error.hpp"
#include "distlab/robot/robot.hpp"
#include "temp_dir.hpp"

namespace distlab::robot::test {

inline std::shared_ptr<const Robot> panda() {
  return Robot::load(std::string(DISTLAB_SOURCE_DIR) + "/assets/robots/panda.urdf");
}
// DH frame i of franka-corridor.md (panda_link{i}) as a link index.
inline int dh_frame(const Robot& robot, int i) { return robot.link_index("panda_link" + std::to_string(i)); }

// Uniform within the joint limits; continuous joints in [−π, π].
inline VecQ random_q(std::mt19937_64& rng, const Robot& robot) {
  VecQ q(robot.dof());
  for (int i = 0; i < robot.dof(); ++i) {
    const double lo = std::isfinite(robot.q_min()[i]) ? robot.q_min()[i] : -M_PI;
    const double hi = std::isfinite(robot.q_max()[i]) ? robot.q_max()[i] : M_PI;
    q[i] = std::uniform_real_distribution<double>(lo, hi)(rng);
  }
  return q;
}

using distlab::test::random_rotation;  // tests/collision's
using distlab::test::random_unit;

// log of a rotation close to I, as a rotation vector.
inline Vec3 rotvec(const Mat3& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}

// point_jacobian of the point `local` fixed to `link` against central differences (step 1e-6) of
// its world position and of the link's rotation (as a rotation vector), every joint.
inline void expect_jacobian_matches_differences(const Robot& robot, const VecQ& q, int link, const Vec3& local) {
  const double h = 1e-6;
  const Kinematics k = robot.forward(q);
  const Jac J = robot.point_jacobian(k, link, k.frames[link].to_world(local));
  for (int j = 0; j < robot.dof(); ++j) {
    VecQ qp = q, qm = q;
    qp[j] += h;
    qm[j] -= h;
    const Kinematics kp = robot.forward(qp), km = robot.forward(qm);
    const Vec3 v = (kp.frames[link].to_world(local) - km.frames[link].to_world(local)) / (2 * h);
    const Vec3 w = rotvec(kp.R[link] * km.R[link].transpose()) / (2 * h);
    EXPECT_LT((J.block<3, 1>(0, j) - v).norm(), 1e-8) << robot.links()[link] << " joint " << j;
    EXPECT_LT((J.block<3, 1>(3, j) - w).norm(), 1e-8) << robot.links()[link] << " joint " << j;
  }
}

// "FIELD: MESSAGE" of the InvalidInput f throws, or "accepted".
inline std::string field_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InvalidInput& e) {
    return e.field() + ": " + e.what();
  }
  return "accepted";
}

// The field and message of the InvalidInput f throws (field "accepted" if none).
struct Refusal {
  std::string field, message;
};
inline Refusal refusal(const std::function<void()>& f) {
  try {
    f();
  } catch (const InvalidInput& e) {
    return {e.field(), e.what()};
  }
  return {"accepted", ""};
}

using distlab::test::TempDir;

// A polygon mesh as the files below write it: vertices and faces (counter-clockwise from outside).
struct PolyMesh {
  std::vector<Vec3> vertices;
  std::vector<std::vector<int>> faces;
};

// Fans of the faces into triangles, each as its three corner positions.
inline std::vector<std::array<Vec3, 3>> triangles(const PolyMesh& m) {
  std::vector<std::array<Vec3, 3>> out;
  for (const auto& f : m.faces)
    for (std::size_t j = 1; j + 1 < f.size(); ++j) out.push_back({m.vertices[f[0]], m.vertices[f[j]], m.vertices[f[j + 1]]});
  return out;
}

inline Vec3 normal_of(const std::array<Vec3, 3>& t) { return (t[1] - t[0]).cross(t[2] - t[0]).normalized(); }

// Binary STL: 80-byte header, uint32 count, per triangle 12 floats (normal, corners) and a uint16.
// Coordinates are floats: the mesh's numbers must be exact in float (the tests use multiples of 1/64).
inline std::string binary_stl(const PolyMesh& m) {
  const auto tris = triangles(m);
  std::string out(80, ' ');
  out.replace(0, 15, "distlab tests  ");
  const auto n = static_cast<std::uint32_t>(tris.size());
  out.append(reinterpret_cast<const char*>(&n), 4);
  for (const auto& t : tris) {
    const Vec3 nrm = normal_of(t);
    std::array<float, 12> f{};
    for (int c = 0; c < 3; ++c) {
      f[c] = static_cast<float>(nrm[c]);
      for (int v = 0; v < 3; ++v) f[3 + 3 * v + c] = static_cast<float>(t[v][c]);
    }
    out.append(reinterpret_cast<const char*>(f.data()), sizeof(f));
    out.append(2, '\0');
  }
  return out;
}

inline std::string number(double x) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
}
inline std::string numbers(const Vec3& v) { return number(v.x()) + " " + number(v.y()) + " " + number(v.z()); }

inline std::string ascii_stl(const PolyMesh& m) {
  std::string out = "solid test\n";
  for (const auto& t : triangles(m)) {
    out += "  facet normal " + numbers(normal_of(t)) + "\n    outer loop\n";
    for (const Vec3& v : t) out += "      vertex " + numbers(v) + "\n";
    out += "    endloop\n  endfacet\n";
  }
  return out + "endsolid test\n";
}

// OBJ with the faces as written (quads stay quads); indices from 1.
inline std::string obj(const PolyMesh& m) {
  std::string out = "# distlab test\n";
  for (const Vec3& v : m.vertices) out += "v " + numbers(v) + "\n";
  for (const auto& f : m.faces) {
    out += "f";
    for (int i : f) out += " " + std::to_string(i + 1);
    out += "\n";
  }
  return out;
}

// Vertex lines "x y z", then face lines "k i0 … i(k−1)": the body of both OFF and ASCII PLY.
inline std::string vertex_and_face_lines(const PolyMesh& m) {
  std::string out;
  for (const Vec3& v : m.vertices) out += numbers(v) + "\n";
  for (const auto& f : m.faces) {
    out += std::to_string(f.size());
    for (int i : f) out += " " + std::to_string(i);
    out += "\n";
  }
  return out;
}

inline std::string ascii_ply(const PolyMesh& m) {
  std::string out = "ply\nformat ascii 1.0\nelement vertex " + std::to_string(m.vertices.size()) +
                    "\nproperty double x\nproperty double y\nproperty double z\nelement face " +
                    std::to_string(m.faces.size()) + "\nproperty list uchar int vertex_indices\nend_header\n";
  return out + vertex_and_face_lines(m);
}

inline std::string off(const PolyMesh& m) {
  std::string out = "OFF\n" + std::to_string(m.vertices.size()) + " " + std::to_string(m.faces.size()) + " 0\n";
  return out + vertex_and_face_lines(m);
}

// The box [−h, h] with quads, outward.
inline PolyMesh box_mesh(const Vec3& h) {
  PolyMesh m;
  for (int i = 0; i < 8; ++i) m.vertices.emplace_back(i & 1 ? h.x() : -h.x(), i & 2 ? h.y() : -h.y(), i & 4 ? h.z() : -h.z());
  m.faces = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  return m;
}

// Homogeneous transforms from the numbers (the independent forward kinematics of the tests).
using Mat4 = Eigen::Matrix4d;
inline Mat4 translation(const Vec3& t) {
  Mat4 T = Mat4::Identity();
  T.block<3, 1>(0, 3) = t;
  return T;
}
// Rotation by θ about the unit axis a: Rodrigues, I + sin θ K + (1 − cos θ) K².
inline Mat4 rotation(const Vec3& a, double theta) {
  Mat3 K;
  K << 0, -a.z(), a.y(), a.z(), 0, -a.x(), -a.y(), a.x(), 0;
  Mat4 T = Mat4::Identity();
  T.block<3, 3>(0, 0) = Mat3::Identity() + std::sin(theta) * K + (1 - std::cos(theta)) * K * K;
  return T;
}
// A URDF <origin xyz rpy>: T(xyz) · Rz(yaw) · Ry(pitch) · Rx(roll).
inline Mat4 origin(const Vec3& xyz, const Vec3& rpy) {
  return translation(xyz) * rotation(Vec3::UnitZ(), rpy.z()) * rotation(Vec3::UnitY(), rpy.y()) *
         rotation(Vec3::UnitX(), rpy.x());
}
inline Mat4 matrix(const Pose& p) {
  Mat4 T = Mat4::Identity();
  T.block<3, 3>(0, 0) = p.R();
  T.block<3, 1>(0, 3) = p.position;
  return T;
}

}  // namespace distlab::robot::test
