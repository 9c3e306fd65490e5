// distlab-make-assets OUTDIR: builds the project's test objects procedurally (metres, closed,
// outward-oriented, checked): cube (Table I), sphere, combination wrench 96.47 mm long (Table
// II, Fig. 5), knife (Fig. 1), and the wrench's three σ cases of Section V-B as requests.
#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/corefinement.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <numeric>
#include <vector>

#include "distlab/mesh/cgal_surface.hpp"
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

using Polyline = std::vector<Eigen::Vector2d>;

// Appends points from angle t0 to t1 (either direction) on a circle, without the end point.
void arc(Polyline& p, const Eigen::Vector2d& c, double r, double t0, double t1, double step) {
  // An even count puts a point on the arc's midpoint (the wrench's extreme at the ring end).
  const int n = 2 * std::max(1, static_cast<int>(std::ceil(std::abs(t1 - t0) * r / (2 * step))));
  for (int i = 0; i < n; ++i) {
    const double t = t0 + (t1 - t0) * i / n;
    p.push_back(c + r * Eigen::Vector2d(std::cos(t), std::sin(t)));
  }
}

// Appends points on the segment a → b, without b.
void line(Polyline& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b, double step) {
  const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / step)));
  for (int i = 0; i < n; ++i) p.push_back(a + (b - a) * i / n);
}

double area(const Polyline& p) {
  double a = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    const auto &u = p[i], &v = p[(i + 1) % p.size()];
    a += 0.5 * (u.x() * v.y() - v.x() * u.y());
  }
  return a;
}

bool inside(const Polyline& p, const Eigen::Vector2d& q) {
  bool in = false;
  for (size_t i = 0, j = p.size() - 1; i < p.size(); j = i++)
    if ((p[i].y() > q.y()) != (p[j].y() > q.y()) &&
        q.x() < p[j].x() + (p[i].x() - p[j].x()) * (q.y() - p[j].y()) / (p[i].y() - p[j].y()))
      in = !in;
  return in;
}

// The region inside loops[0] and outside the other loops, extruded over z ∈ [z0, z1]: caps from
// a constrained Delaunay triangulation of the loops' own points, walls from the loop edges.
SurfaceMesh extrude(std::vector<Polyline> loops, double z0, double z1) {
  using Vb = CGAL::Triangulation_vertex_base_with_info_2<int, K>;
  using Tds = CGAL::Triangulation_data_structure_2<Vb, CGAL::Constrained_triangulation_face_base_2<K>>;
  using CDT = CGAL::Constrained_Delaunay_triangulation_2<K, Tds>;
  for (size_t l = 0; l < loops.size(); ++l)  // outer loop counter-clockwise, holes clockwise
    if ((area(loops[l]) > 0) != (l == 0)) std::reverse(loops[l].begin(), loops[l].end());
  std::vector<Eigen::Vector2d> pts;
  CDT cdt;
  std::vector<Eigen::Vector3i> f;
  const int n_total = static_cast<int>(std::accumulate(loops.begin(), loops.end(), size_t{0},
                                                       [](size_t a, const Polyline& p) { return a + p.size(); }));
  for (const Polyline& loop : loops) {
    const int first = static_cast<int>(pts.size()), n = static_cast<int>(loop.size());
    std::vector<CDT::Vertex_handle> vh;
    for (int i = 0; i < n; ++i) {
      vh.push_back(cdt.insert(K::Point_2(loop[i].x(), loop[i].y())));
      vh.back()->info() = first + i;
      pts.push_back(loop[i]);
    }
    for (int i = 0; i < n; ++i) {
      cdt.insert_constraint(vh[i], vh[(i + 1) % n]);
      quad(f, first + i, first + (i + 1) % n, n_total + first + (i + 1) % n, n_total + first + i);  // wall
    }
  }
  if (static_cast<int>(cdt.number_of_vertices()) != n_total) throw std::runtime_error("outline has duplicate points");
  for (auto fh = cdt.finite_faces_begin(); fh != cdt.finite_faces_end(); ++fh) {
    const int a = fh->vertex(0)->info(), b = fh->vertex(1)->info(), c = fh->vertex(2)->info();
    const Eigen::Vector2d mid = (pts[a] + pts[b] + pts[c]) / 3;
    bool in = inside(loops[0], mid);
    for (size_t l = 1; l < loops.size() && in; ++l) in = !inside(loops[l], mid);
    if (!in) continue;
    f.emplace_back(n_total + a, n_total + b, n_total + c);  // top (CDT faces are counter-clockwise)
    f.emplace_back(a, c, b);                                // bottom
  }
  std::vector<Vec3> v;
  for (double z : {z0, z1})
    for (const auto& p : pts) v.emplace_back(p.x(), p.y(), z);
  return build(v, f);
}

SurfaceMesh box_at(const Vec3& lo, const Vec3& hi) {
  SurfaceMesh b = mesh::box(hi - lo);
  b.vertices.rowwise() += (0.5 * (lo + hi)).transpose();
  return b;
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
  Mesh acc = mesh::to_cgal_surface<K::Point_3>(parts[0]);
  for (size_t i = 1; i < parts.size(); ++i) {
    Mesh next = mesh::to_cgal_surface<K::Point_3>(parts[i]), out;
    if (!CGAL::Polygon_mesh_processing::corefine_and_compute_union(acc, next, out))
      throw std::runtime_error("union failed");
    acc = std::move(out);
  }
  return from_cgal(acc);
}

// Combination wrench along x, 96.47 mm overall, as one extruded outline: a ring end (left), an
// open end with its jaws facing +x (right) and a handle between them. Built directly as a single
// closed manifold with ~1 mm edges: a boolean union leaves tiny edges and slivers where the parts
// meet, and Mesh_3's feature protection then refines around them without end.
SurfaceMesh wrench() {
  const double half = 0.096470 / 2, thick = 0.005, step = 0.001;
  const double r_ring = 0.009, r_hole = 0.0055, r_open = 0.010, jaw = 0.0045, handle = 0.004;
  const double t_jaw = std::asin(jaw / r_open);  // where the jaw faces meet the outer arc
  const Eigen::Vector2d c_ring(-half + r_ring, 0), c_open(half - r_open * std::cos(t_jaw), 0);
  const double t_ring = std::asin(handle / r_ring), t_neck = std::asin(handle / r_open);
  Polyline outer, hole;
  // Counter-clockwise from the lower jaw tip: outer arc of the open end down and round to the
  // handle, handle bottom, ring arc, handle top, open-end arc to the upper jaw tip, then the slot.
  arc(outer, c_open, r_open, -t_jaw, -(M_PI - t_neck), step);
  line(outer, c_open + r_open * Eigen::Vector2d(-std::cos(t_neck), -handle / r_open),
       c_ring + r_ring * Eigen::Vector2d(std::cos(t_ring), -std::sin(t_ring)), step);
  arc(outer, c_ring, r_ring, -t_ring, -(2 * M_PI - t_ring), step);
  line(outer, c_ring + r_ring * Eigen::Vector2d(std::cos(t_ring), std::sin(t_ring)),
       c_open + r_open * Eigen::Vector2d(-std::cos(t_neck), handle / r_open), step);
  arc(outer, c_open, r_open, M_PI - t_neck, t_jaw, step);
  line(outer, c_open + r_open * Eigen::Vector2d(std::cos(t_jaw), std::sin(t_jaw)), c_open + Eigen::Vector2d(0, jaw), step);
  arc(outer, c_open, jaw, M_PI / 2, 3 * M_PI / 2, step);
  line(outer, c_open + Eigen::Vector2d(0, -jaw), c_open + r_open * Eigen::Vector2d(std::cos(t_jaw), -std::sin(t_jaw)), step);
  arc(hole, c_ring, r_hole, 0, 2 * M_PI, step);
  return extrude({outer, hole}, -thick / 2, thick / 2);
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
                      << "  \"mesh\": {\"asset\": \"wrench\"},\n  \"lx\": 0.002,\n"
                      << "  \"center\": [0.0, 0.0, 0.0],\n  \"feature_angle\": 180,\n  \"grading\": 0,\n"
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
