// Grid and plane sampling, marching tetrahedra.
#include "distlab/levelset/grid.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "distlab/geometry/error.hpp"
#include "distlab/geometry/parallel.hpp"
#include "distlab/mesh/marching_tetrahedra.hpp"

namespace distlab::levelset {
namespace {

// The six tetrahedra of the Kuhn (Freudenthal) split of a cell; corners numbered by bits
// x = 1, y = 2, z = 4. All share the diagonal 0-7, so neighbouring cells agree on face splits.
constexpr int kTets[6][4] = {{0, 1, 3, 7}, {0, 1, 5, 7}, {0, 2, 3, 7}, {0, 2, 6, 7}, {0, 4, 5, 7}, {0, 4, 6, 7}};

}  // namespace

std::vector<Grid> sample_grid(const MultiField& f, int count, const Vec3& lo, const Vec3& hi,
                              const std::array<int, 3>& n, unsigned threads, const Progress& progress) {
  if (count < 1) throw InvalidInput("grid", "no field to sample");
  for (int a = 0; a < 3; ++a) {
    if (n[a] < 2) throw InvalidInput("grid", "a grid needs at least 2 nodes per axis");
    if (!(hi[a] > lo[a]) || !std::isfinite(hi[a] - lo[a]))
      throw InvalidInput("grid", "the grid box is empty or not finite");
  }
  std::vector<Grid> grids(static_cast<std::size_t>(count));
  const Vec3 spacing((hi.x() - lo.x()) / (n[0] - 1), (hi.y() - lo.y()) / (n[1] - 1),
                     (hi.z() - lo.z()) / (n[2] - 1));
  const std::size_t total = static_cast<std::size_t>(n[0]) * n[1] * n[2];
  for (Grid& g : grids) {
    g.origin = lo;
    g.spacing = spacing;
    g.n = n;
    g.values.assign(total, 0.0);
  }
  const std::size_t rows = static_cast<std::size_t>(n[1]) * n[2];
  parallel_for(rows, threads, [&](std::size_t row) {
    progress("sample", static_cast<double>(row) / static_cast<double>(rows));
    const int j = static_cast<int>(row % n[1]), k = static_cast<int>(row / n[1]);
    std::vector<double> out(static_cast<std::size_t>(count));
    for (int i = 0; i < n[0]; ++i) {
      f(grids[0].node(i, j, k), out.data());
      const std::size_t idx = grids[0].index(i, j, k);
      for (int c = 0; c < count; ++c) grids[static_cast<std::size_t>(c)].values[idx] = out[static_cast<std::size_t>(c)];
    }
  });
  return grids;
}

mesh::SurfaceMesh marching_tetrahedra(const Grid& grid, double level) {
  const auto& n = grid.n;
  std::vector<Vec3> verts;
  std::vector<Eigen::Vector3i> tris;
  std::unordered_map<std::uint64_t, int> edge_vertex;

  // The vertex where value - level changes sign on the edge between nodes a and b
  // (fa < 0 <= fb); a crossing exactly at a node is keyed by the node so it is shared.
  auto vertex_on = [&](std::size_t a, std::size_t b, double fa, double fb, const Vec3& pa,
                       const Vec3& pb) {
    const double t = fa / (fa - fb);
    std::uint64_t key;
    if (t >= 1.0 || fb == 0.0) {
      key = (std::uint64_t{1} << 63) | b;
    } else {
      const std::uint64_t lo = std::min(a, b), hi = std::max(a, b);
      key = (lo << 32) | hi;
    }
    auto [it, inserted] = edge_vertex.try_emplace(key, static_cast<int>(verts.size()));
    if (inserted) verts.push_back(t >= 1.0 || fb == 0.0 ? pb : Vec3(pa + t * (pb - pa)));
    return it->second;
  };

  for (int k = 0; k + 1 < n[2]; ++k)
    for (int j = 0; j + 1 < n[1]; ++j)
      for (int i = 0; i + 1 < n[0]; ++i) {
        std::size_t node[8];
        double f[8];
        bool any_in = false, any_out = false;
        for (int c = 0; c < 8; ++c) {
          node[c] = grid.index(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1));
          f[c] = grid.values[node[c]] - level;
          if (!std::isfinite(f[c])) f[c] = 1.0;  // undefined values count as outside
          (f[c] < 0 ? any_in : any_out) = true;
        }
        if (!any_in || !any_out) continue;
        Vec3 p[8];
        for (int c = 0; c < 8; ++c) p[c] = grid.node(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1));
        for (const auto& tet : kTets) {
          const bool in[4] = {f[tet[0]] < 0, f[tet[1]] < 0, f[tet[2]] < 0, f[tet[3]] < 0};
          if (in[0] == in[1] && in[1] == in[2] && in[2] == in[3]) continue;
          // Gradient of the linear interpolant on this tetrahedron: the side normals face.
          Mat3 m;
          Vec3 df;
          for (int r = 0; r < 3; ++r) {
            m.row(r) = (p[tet[r + 1]] - p[tet[0]]).transpose();
            df[r] = f[tet[r + 1]] - f[tet[0]];
          }
          const Vec3 grad = m.partialPivLu().solve(df);
          const auto cross = [&](int a, int b) {  // a inside, b outside
            return vertex_on(node[a], node[b], f[a], f[b], p[a], p[b]);
          };
          const auto emit = [&](int a, int b, int c) {
            if (a == b || b == c || a == c) return;
            const Vec3 normal = (verts[static_cast<std::size_t>(b)] - verts[static_cast<std::size_t>(a)])
                                    .cross(verts[static_cast<std::size_t>(c)] - verts[static_cast<std::size_t>(a)]);
            if (normal.dot(grad) < 0) std::swap(b, c);
            tris.emplace_back(a, b, c);
          };
          mesh::march_tetrahedron(tet, in, cross, emit);
        }
      }

  mesh::SurfaceMesh out;
  out.vertices.resize(static_cast<Eigen::Index>(verts.size()), 3);
  for (std::size_t v = 0; v < verts.size(); ++v) out.vertices.row(static_cast<Eigen::Index>(v)) = verts[v].transpose();
  out.faces.resize(static_cast<Eigen::Index>(tris.size()), 3);
  for (std::size_t t = 0; t < tris.size(); ++t) out.faces.row(static_cast<Eigen::Index>(t)) = tris[t].transpose();
  return out;
}

PlaneFrame plane_from_normal(const Vec3& centre, const Vec3& normal, double size_u, double size_v,
                             int nu, int nv) {
  if (!(normal.norm() > 1e-12) || !normal.allFinite()) throw InvalidInput("plane.normal", "plane.normal must be a non-zero vector");
  const Vec3 nn = normal.normalized();
  // The coordinate axis least aligned with the normal seeds u.
  Eigen::Index axis = 0;
  nn.cwiseAbs().minCoeff(&axis);
  PlaneFrame p;
  p.centre = centre;
  p.u = Vec3::Unit(axis).cross(nn).normalized();
  p.v = nn.cross(p.u);
  p.size_u = size_u;
  p.size_v = size_v;
  p.nu = nu;
  p.nv = nv;
  return p;
}

std::vector<std::vector<double>> sample_plane(const MultiField& f, int count, const PlaneFrame& plane,
                                              unsigned threads) {
  if (plane.nu < 2 || plane.nv < 2) throw InvalidInput("plane.resolution", "a plane needs at least 2 x 2 samples");
  std::vector<std::vector<double>> out(static_cast<std::size_t>(count),
                                       std::vector<double>(static_cast<std::size_t>(plane.nu) * plane.nv));
  parallel_for(static_cast<std::size_t>(plane.nv), threads, [&](std::size_t t) {
    std::vector<double> vals(static_cast<std::size_t>(count));
    const double tv = static_cast<double>(t) / (plane.nv - 1) - 0.5;
    for (int s = 0; s < plane.nu; ++s) {
      const double su = static_cast<double>(s) / (plane.nu - 1) - 0.5;
      f(plane.centre + su * plane.size_u * plane.u + tv * plane.size_v * plane.v, vals.data());
      for (int c = 0; c < count; ++c)
        out[static_cast<std::size_t>(c)][static_cast<std::size_t>(s) + static_cast<std::size_t>(plane.nu) * t] = vals[static_cast<std::size_t>(c)];
    }
  });
  return out;
}

}  // namespace distlab::levelset
