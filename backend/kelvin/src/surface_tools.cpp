// CGAL AABB tree and Polygon_mesh_processing on the input surface.
#include "distlab/kelvin/surface_tools.hpp"

#include <cmath>
#include <limits>
#include <map>

#include <CGAL/AABB_face_graph_triangle_primitive.h>
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Side_of_triangle_mesh.h>
#include <CGAL/Surface_mesh.h>

#include "distlab/mesh/cgal_surface.hpp"

namespace distlab::kelvin {

std::vector<std::pair<int, int>> sharp_edges(const mesh::SurfaceMesh& s, double feature_angle) {
  std::vector<std::pair<int, int>> out;
  if (feature_angle >= 180) return out;
  const double cos_limit = std::cos(feature_angle * 3.14159265358979323846 / 180.0);
  std::map<std::pair<int, int>, std::pair<int, int>> edges;  // (a < b) -> first face, second face
  const auto nf = static_cast<int>(s.faces.rows());
  std::vector<Vec3> normal(static_cast<size_t>(nf));
  for (int f = 0; f < nf; ++f) {
    const Vec3 a = s.vertices.row(s.faces(f, 0)), b = s.vertices.row(s.faces(f, 1)), c = s.vertices.row(s.faces(f, 2));
    normal[static_cast<size_t>(f)] = (b - a).cross(c - a).normalized();
    for (int k = 0; k < 3; ++k) {
      int u = s.faces(f, k), v = s.faces(f, (k + 1) % 3);
      if (u > v) std::swap(u, v);
      auto [it, fresh] = edges.try_emplace({u, v}, f, -1);
      if (!fresh) it->second.second = f;
    }
  }
  for (const auto& [e, fs] : edges)
    if (fs.second >= 0 && normal[static_cast<size_t>(fs.first)].dot(normal[static_cast<size_t>(fs.second)]) < cos_limit) out.push_back(e);
  return out;
}

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Mesh = CGAL::Surface_mesh<K::Point_3>;
using Primitive = CGAL::AABB_face_graph_triangle_primitive<Mesh>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<K, Primitive>>;

}  // namespace

struct SurfaceOracle::Impl {
  Mesh mesh;
  Tree tree;
  std::unique_ptr<CGAL::Side_of_triangle_mesh<Mesh, K>> side;
  mesh::SurfaceMesh indexed;
};

SurfaceOracle::SurfaceOracle(const mesh::SurfaceMesh& surface) : impl_(std::make_unique<Impl>()) {
  impl_->indexed = surface;
  impl_->mesh = mesh::to_cgal_surface<K::Point_3>(surface);
  impl_->tree.insert(faces(impl_->mesh).first, faces(impl_->mesh).second, impl_->mesh);
  impl_->tree.build();
  impl_->tree.accelerate_distance_queries();
  impl_->side = std::make_unique<CGAL::Side_of_triangle_mesh<Mesh, K>>(impl_->tree);
}

SurfaceOracle::~SurfaceOracle() = default;

bool SurfaceOracle::inside(const Vec3& x) const {
  return (*impl_->side)(K::Point_3(x.x(), x.y(), x.z())) == CGAL::ON_BOUNDED_SIDE;
}

double SurfaceOracle::distance(const Vec3& x) const {
  return std::sqrt(CGAL::to_double(impl_->tree.squared_distance(K::Point_3(x.x(), x.y(), x.z()))));
}

void SurfaceOracle::closest(const Vec3& x, int& face, Vec3& weights) const {
  const auto [p, f] = impl_->tree.closest_point_and_primitive(K::Point_3(x.x(), x.y(), x.z()));
  face = static_cast<int>(f.idx());
  const auto& s = impl_->indexed;
  const Vec3 a = s.vertices.row(s.faces(face, 0)), b = s.vertices.row(s.faces(face, 1)),
             c = s.vertices.row(s.faces(face, 2));
  const Vec3 q(p.x(), p.y(), p.z());
  const Vec3 n = (b - a).cross(c - a);
  const double area2 = n.squaredNorm();
  weights.x() = (c - b).cross(q - b).dot(n) / area2;
  weights.y() = (a - c).cross(q - c).dot(n) / area2;
  weights.z() = 1.0 - weights.x() - weights.y();
}

Vec3 SurfaceOracle::deepest_point(const std::function<void(double)>& tick) const {
  // Coarse grid over the bounding box, then a finer grid around the best point.
  const auto& v = impl_->indexed.vertices;
  Vec3 lo = v.colwise().minCoeff().transpose(), hi = v.colwise().maxCoeff().transpose();
  Vec3 best = 0.5 * (lo + hi);
  double best_d = inside(best) ? distance(best) : -1.0;
  for (int pass = 0; pass < 2; ++pass) {
    const int n = 24;
    const Vec3 step = (hi - lo) / n;
    // The distance is 1-Lipschitz: along a row, d ≤ (last computed d) + (steps since)·step.z, and
    // a point bounded below the best cannot win; skipping it changes nothing (margin for rounding).
    const double margin = 1e-12 * (hi - lo).norm();
    for (int i = 0; i < n; ++i) {
      if (tick) tick((pass * n + i) / (2.0 * n));
      for (int j = 0; j < n; ++j) {
        double bound = std::numeric_limits<double>::infinity();
        for (int k = 0; k < n; ++k) {
          const Vec3 p = lo + Vec3((i + 0.5) * step.x(), (j + 0.5) * step.y(), (k + 0.5) * step.z());
          bound += step.z();
          if (!inside(p)) {
            bound = std::numeric_limits<double>::infinity();
            continue;
          }
          if (bound + margin < best_d) continue;
          const double d = distance(p);
          bound = d;
          if (d > best_d) best_d = d, best = p;
        }
      }
    }
    lo = best - 2 * step;
    hi = best + 2 * step;
  }
  return best;
}

}  // namespace distlab::kelvin
