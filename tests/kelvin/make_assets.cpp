// distlab-make-assets OUTDIR: builds the project's test objects procedurally (metres, closed,
// outward-oriented, checked): cube (Table I), sphere, combination wrench 96.47 mm long (Table
// II, Fig. 5), knife (Fig. 1), and the wrench's three σ cases of Section V-B as requests.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/corefinement.h>
#include <CGAL/Surface_mesh.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <vector>

#include "distlab/mesh/checks.hpp"
#include "distlab/mesh/primitives.hpp"

using namespace distlab;
using mesh::SurfaceMesh;
using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Mesh = CGAL::Surface_mesh<K::Point_3>;

namespace {

// Quad (a, b, c, d) as two triangles.
void quad(std::vector<Eigen::Vector3i>& f, int a, int b, int c, int d) {
  f.emplace_back(a, b, c);
  f.emplace_back(a, c, d);
}

SurfaceMesh build(const std::vector<Vec3>& v, const std::vector<Eigen::Vector3i>& f) {
  SurfaceMesh m;
  m.vertices.resize(static_cast<Eigen::Index>(v.size()), 3);
  for (size_t i = 0; i < v.size(); ++i) m.vertices.row(static_cast<Eigen::Index>(i)) = v[i];
  m.faces.resize(static_cast<Eigen::Index>(f.size()), 3);
  for (size_t i = 0; i < f.size(); ++i) m.faces.row(static_cast<Eigen::Index>(i)) = f[i];
  if (mesh::signed_volume(m) < 0) m.faces.col(1).swap(m.faces.col(2));
  return m;
}

// Annular sector [t0, t1] of radii [r0, r1] in the xy-plane around c, extruded over z ∈ [z0, z1];
// a full turn (t1 − t0 = 2π) closes into a ring.
SurfaceMesh annulus(const Vec3& c, double r0, double r1, double z0, double z1, double t0, double t1, int n) {
  const bool full = std::abs(t1 - t0 - 2 * M_PI) < 1e-12;
  const int cols = full ? n : n + 1;
  std::vector<Vec3> v;
  for (int i = 0; i < cols; ++i) {
    const double t = t0 + (t1 - t0) * i / n;
    const Vec3 d(std::cos(t), std::sin(t), 0);
    for (double r : {r0, r1})
      for (double z : {z0, z1}) v.push_back(c + r * d + Vec3(0, 0, z));
  }
  auto id = [&](int i, int r, int z) { return 4 * (i % cols) + 2 * r + z; };
  std::vector<Eigen::Vector3i> f;
  for (int i = 0; i < n; ++i) {
    const int j = i + 1;
    quad(f, id(i, 1, 0), id(j, 1, 0), id(j, 1, 1), id(i, 1, 1));  // outer wall
    quad(f, id(i, 0, 0), id(i, 0, 1), id(j, 0, 1), id(j, 0, 0));  // inner wall
    quad(f, id(i, 0, 1), id(i, 1, 1), id(j, 1, 1), id(j, 0, 1));  // top
    quad(f, id(i, 0, 0), id(j, 0, 0), id(j, 1, 0), id(i, 1, 0));  // bottom
  }
  if (!full) {
    quad(f, id(0, 0, 0), id(0, 1, 0), id(0, 1, 1), id(0, 0, 1));
    quad(f, id(n, 0, 0), id(n, 0, 1), id(n, 1, 1), id(n, 1, 0));
  }
  return build(v, f);
}

// Convex polygon (xy, counter-clockwise) extruded over z ∈ [z0, z1].
SurfaceMesh prism(const std::vector<Eigen::Vector2d>& poly, double z0, double z1) {
  const int n = static_cast<int>(poly.size());
  std::vector<Vec3> v;
  for (const auto& p : poly) v.emplace_back(p.x(), p.y(), z0);
  for (const auto& p : poly) v.emplace_back(p.x(), p.y(), z1);
  std::vector<Eigen::Vector3i> f;
  for (int i = 1; i + 1 < n; ++i) {
    f.emplace_back(0, i + 1, i);
    f.emplace_back(n, n + i, n + i + 1);
  }
  for (int i = 0; i < n; ++i) quad(f, i, (i + 1) % n, n + (i + 1) % n, n + i);
  return build(v, f);
}

SurfaceMesh box_at(const Vec3& lo, const Vec3& hi) {
  SurfaceMesh b = mesh::box(hi - lo);
  b.vertices.rowwise() += (0.5 * (lo + hi)).transpose();
  return b;
}

Mesh to_cgal(const SurfaceMesh& s) {
  Mesh m;
  std::vector<Mesh::Vertex_index> vi;
  for (Eigen::Index v = 0; v < s.vertices.rows(); ++v)
    vi.push_back(m.add_vertex(K::Point_3(s.vertices(v, 0), s.vertices(v, 1), s.vertices(v, 2))));
  for (Eigen::Index f = 0; f < s.faces.rows(); ++f)
    m.add_face(vi[static_cast<size_t>(s.faces(f, 0))], vi[static_cast<size_t>(s.faces(f, 1))], vi[static_cast<size_t>(s.faces(f, 2))]);
  return m;
}

SurfaceMesh from_cgal(const Mesh& m) {
  SurfaceMesh out;
  std::vector<int> index(m.number_of_vertices() + m.number_of_removed_vertices(), -1);
  std::vector<Vec3> v;
  for (auto vi : m.vertices()) {
    index[vi.idx()] = static_cast<int>(v.size());
    v.emplace_back(m.point(vi).x(), m.point(vi).y(), m.point(vi).z());
  }
  std::vector<Eigen::Vector3i> f;
  for (auto fi : m.faces()) {
    Eigen::Vector3i t;
    int k = 0;
    for (auto vi : vertices_around_face(m.halfedge(fi), m)) t[k++] = index[vi.idx()];
    f.push_back(t);
  }
  return build(v, f);
}

// Solid union through CGAL's corefinement (exact predicates): a closed manifold result.
SurfaceMesh unite(const std::vector<SurfaceMesh>& parts) {
  Mesh acc = to_cgal(parts[0]);
  for (size_t i = 1; i < parts.size(); ++i) {
    Mesh next = to_cgal(parts[i]), out;
    if (!CGAL::Polygon_mesh_processing::corefine_and_compute_union(acc, next, out))
      throw std::runtime_error("union failed");
    acc = std::move(out);
  }
  return from_cgal(acc);
}

// Combination wrench along x, 96.47 mm overall: a closed ring end (left), an open end with its
// jaws facing +x (right), a thinner handle between them.
SurfaceMesh wrench() {
  const double half = 0.096470 / 2, gap = 50 * M_PI / 180;
  const Vec3 ring(-half + 0.009, 0, 0);
  const Vec3 open(half - 0.010 * std::cos(gap), 0, 0);
  return unite({box_at(Vec3(-0.033, -0.004, -0.002), Vec3(0.034, 0.004, 0.002)),
                annulus(ring, 0.0055, 0.009, -0.0025, 0.0025, 0, 2 * M_PI, 48),
                annulus(open, 0.0045, 0.010, -0.0025, 0.0025, gap, 2 * M_PI - gap, 40)});
}

// Kitchen knife along x: a 2 mm blade with a curved cutting edge and a box handle.
SurfaceMesh knife() {
  // Counter-clockwise and convex: heel, the edge curving up (y = −18 mm + 30 mm t³) to the tip,
  // then the straight spine back.
  std::vector<Eigen::Vector2d> blade{{-0.01, -0.018}};
  for (int i = 1; i <= 12; ++i) {
    const double t = i / 12.0;
    blade.emplace_back(-0.01 + 0.19 * t, -0.018 + 0.030 * t * t * t);
  }
  blade.emplace_back(-0.01, 0.012);
  return unite({prism(blade, -0.001, 0.001), box_at(Vec3(-0.115, -0.011, -0.008), Vec3(-0.005, 0.011, 0.008))});
}

void write_case(const std::filesystem::path& file, const std::string& comment, const std::string& sigma) {
  std::ofstream(file) << "{\n  \"comment\": \"" << comment << "\",\n"
                      << "  \"mesh\": {\"asset\": \"wrench\"},\n  \"lx\": 0.0015,\n"
                      << "  \"sigma\": " << sigma << ",\n"
                      << "  \"query\": [[0.0, 0.0, 0.01], [0.045, 0.0, 0.01], [-0.06, 0.0, 0.0]]\n}\n";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: distlab-make-assets OUTDIR\n";
    return 2;
  }
  const std::filesystem::path dir = argv[1];
  std::filesystem::create_directories(dir);
  const std::pair<std::string, SurfaceMesh> objects[] = {
      {"cube", mesh::box(Vec3::Ones())}, {"sphere", mesh::icosphere(0.5, 4)}, {"wrench", wrench()}, {"knife", knife()}};
  for (auto [name, m] : objects) {
    mesh::require_closed_manifold(m, name);  // refuse to write anything the importer would refuse
    const Vec3 extent = m.vertices.colwise().maxCoeff() - m.vertices.colwise().minCoeff();
    mesh::save_mesh(m, (dir / (name + ".stl")).string(), "stl");
    std::cout << name << ": " << m.vertices.rows() << " vertices, " << m.faces.rows() << " faces, extent "
              << extent.transpose() << " m\n";
  }
  // Section V-B, eq. 24 along e_l = x with the transition at |x| = d0 = 30 mm over 3 mm:
  // (a) contact only on the handle, (b) nowhere, (c) only at the tool ends.
  write_case(dir / "wrench_case_a.json", "(a) contact allowed only on the handle",
             R"({"axis": {"axis": [1, 0, 0], "d0": 0.03, "sigma_nom": -1.0, "width": 0.003}})");
  write_case(dir / "wrench_case_b.json", "(b) no contact anywhere", R"({"constant": -1.0})");
  write_case(dir / "wrench_case_c.json", "(c) contact allowed only at the tool ends",
             R"({"axis": {"axis": [1, 0, 0], "d0": 0.03, "sigma_nom": 1.0, "width": 0.003}})");
  return 0;
}
