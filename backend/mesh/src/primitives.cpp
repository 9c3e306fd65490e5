// Procedural boxes, icospheres and tori.
#include <cmath>
#include <map>
#include <vector>

#include "distlab/mesh/primitives.hpp"

namespace distlab::mesh {

SurfaceMesh box(const Vec3& size) {
  SurfaceMesh m;
  m.vertices.resize(8, 3);
  for (int i = 0; i < 8; ++i)
    m.vertices.row(i) << (i & 1 ? 0.5 : -0.5) * size.x(), (i & 2 ? 0.5 : -0.5) * size.y(),
        (i & 4 ? 0.5 : -0.5) * size.z();
  m.faces.resize(12, 3);
  m.faces << 0, 2, 1, 1, 2, 3,  // z-
      4, 5, 6, 5, 7, 6,         // z+
      0, 1, 4, 1, 5, 4,         // y-
      2, 6, 3, 3, 6, 7,         // y+
      0, 4, 2, 2, 4, 6,         // x-
      1, 3, 5, 3, 7, 5;         // x+
  return m;
}

SurfaceMesh rippled_torus(int n) {
  SurfaceMesh s;
  s.vertices.resize(static_cast<Eigen::Index>(n) * n, 3);
  s.faces.resize(2 * static_cast<Eigen::Index>(n) * n, 3);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double u = 2 * M_PI * i / n, v = 2 * M_PI * j / n;
      const double r = 0.3 * (1 + 0.05 * std::sin(17 * u) * std::sin(11 * v)) + 0.002 * std::sin(191 * u + 7 * v);
      const Eigen::Index k = static_cast<Eigen::Index>(i) * n + j;
      s.vertices.row(k) << (1 + r * std::cos(v)) * std::cos(u), (1 + r * std::cos(v)) * std::sin(u), r * std::sin(v);
      const int a = i * n + j, b = ((i + 1) % n) * n + j, c = ((i + 1) % n) * n + (j + 1) % n, d = i * n + (j + 1) % n;
      s.faces.row(2 * k) << a, b, c;
      s.faces.row(2 * k + 1) << a, c, d;
    }
  return s;
}

SurfaceMesh icosphere(double radius, int level, const Vec3& centre) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Vec3> v = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t}, {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  for (auto& p : v) p.normalize();
  std::vector<Eigen::Vector3i> f = {{0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8}, {3, 9, 4}, {3, 4, 2}, {3, 2, 6}, {3, 6, 8}, {3, 8, 9}, {4, 9, 5}, {2, 4, 11}, {6, 2, 10}, {8, 6, 7}, {9, 8, 1}};
  for (int l = 0; l < level; ++l) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      auto key = std::minmax(a, b);
      auto [it, inserted] = mid.emplace(key, static_cast<int>(v.size()));
      if (inserted) v.push_back((v[a] + v[b]).normalized());
      return it->second;
    };
    std::vector<Eigen::Vector3i> next;
    next.reserve(f.size() * 4);
    for (const auto& tri : f) {
      const int a = midpoint(tri[0], tri[1]), b = midpoint(tri[1], tri[2]), c = midpoint(tri[2], tri[0]);
      next.insert(next.end(), {{tri[0], a, c}, {tri[1], b, a}, {tri[2], c, b}, {a, b, c}});
    }
    f.swap(next);
  }
  SurfaceMesh m;
  m.vertices.resize(static_cast<Eigen::Index>(v.size()), 3);
  for (size_t i = 0; i < v.size(); ++i)
    m.vertices.row(static_cast<Eigen::Index>(i)) = centre + radius * v[i];
  m.faces.resize(static_cast<Eigen::Index>(f.size()), 3);
  for (size_t i = 0; i < f.size(); ++i) m.faces.row(static_cast<Eigen::Index>(i)) = f[i];
  return m;
}

SurfaceMesh merge(const SurfaceMesh& a, const SurfaceMesh& b) {
  SurfaceMesh m;
  m.vertices.resize(a.vertices.rows() + b.vertices.rows(), 3);
  m.vertices << a.vertices, b.vertices;
  m.faces.resize(a.faces.rows() + b.faces.rows(), 3);
  m.faces << a.faces, (b.faces.array() + static_cast<int>(a.vertices.rows())).matrix();
  return m;
}

}  // namespace distlab::mesh
